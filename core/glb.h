// Binary glTF 2.0 (.glb) encoding of a mesh: what write_mesh writes for a .glb path, and what `sdfkit report`
// embeds in its pages. sdfkit writes its own GLB (a JSON chunk and a BIN chunk, glTF 2.0 spec "GLB File Format")
// rather than assimp's exporter so that the bytes depend on the mesh alone and the vertex colours follow the spec.
#pragma once

#include "core/types.h"

#include <string>

namespace sdfkit {

/// The GLB file of `mesh`: one node, one triangle primitive with POSITION (float32, with the min/max the spec
/// requires), NORMAL (area-weighted vertex normals, unit length; (0, 0, 1) at a vertex of zero-area faces only),
/// COLOR_0 when the mesh has colours (float32 RGB, converted from sdfkit's sRGB colours to the linear values glTF
/// specifies) and uint32 indices; a matte double-sided material (base colour 0.7 grey when the mesh has no colours: read_mesh reads that back as
/// every vertex's colour). The same
/// mesh gives the same bytes. InvalidInput for non-finite coordinates or colours and for an empty mesh.
std::string encode_glb(const Mesh& mesh);

/// sRGB <-> linear transfer functions of one channel in [0, 1] (IEC 61966-2-1); glTF's COLOR_0 holds linear values.
float srgb_to_linear(float c);
float linear_to_srgb(float c);

}  // namespace sdfkit
