// Mesh input (OBJ, STL, glTF/GLB through assimp; PLY ascii/binary and OFF through sdfkit's own readers), validation,
// and mesh writers (OBJ, PLY, OFF, STL). One file per format in core/io/ (obj, ply, off, stl, gltf, and assimp.cpp for
// the formats assimp parses); point clouds (.xyz, .npy) are read by core/io/points.h.
#pragma once

#include "core/types.h"

#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

/// What validation found. Empty meshes, non-finite coordinates and out-of-range indices are errors
/// (InvalidInput); the counts below are problems that are handled (removed or tolerated) and reported.
struct MeshReport {
  long degenerate_faces = 0;    ///< faces with a repeated index or (near-)zero area, removed
  long duplicate_faces = 0;     ///< faces with the same vertex set as an earlier face, removed
  long unreferenced_vertices = 0;  ///< vertices used by no face (kept; harmless)
  long input_faces = 0;         ///< faces after triangulation, before clean-up
  long textured_parts = 0;      ///< parts coloured from a texture image (read_mesh with a TextureSampler)
  std::vector<std::string> missing_textures;  ///< texture files named by materials that could not be found or read, each once
};

/// Samples the image file `path` at texture coordinates (u, v) (OBJ/glTF convention: v = 0 at the bottom row;
/// coordinates wrap), one RGB colour in [0, 1] per coordinate; throws sdfkit::Error when the image cannot be read.
/// core/ reads no images: camera/texture.h provides one (image_texture_sampler).
using TextureSampler =
    std::function<std::vector<Eigen::Vector3f>(const std::string& path, const std::vector<Eigen::Vector2f>& uv)>;

/// Read a mesh by extension (obj, ply, off, stl, gltf, glb; case-insensitive; OBJ materials' diffuse colours
/// (Kd) and glTF base colours become vertex colours when the file has none; .ply goes through read_ply of
/// core/io/ply.h, .off through sdfkit's OFF reader: messages give the line, counted from 1). Polygons are triangulated,
/// identical vertices are merged, all parts are merged into one mesh in the file's global frame. Throws IoError naming
/// the file when it cannot be read (missing, a folder) or parsed (unknown extension, truncated, malformed; assimp's
/// reasons as "<file>: cannot read mesh: <reason>") and InvalidInput when it is
/// unusable (empty, non-finite coordinates, out-of-range indices).
/// With `textures`, parts whose material has a diffuse (glTF: base colour) texture file and UVs are coloured by
/// sampling it at the vertices (a per-vertex colour: detail finer than the mesh's edges is lost).
Mesh read_mesh(const std::string& path, MeshReport* report = nullptr, const TextureSampler& textures = {});

/// True when `path` ends in an extension read_mesh reads (.obj, .ply, .off, .stl, .gltf, .glb; case-insensitive).
bool has_mesh_extension(const std::string& path);

/// The axis that points up in a mesh file; sdfkit's object frame has +y up (ShapeNet, DISN).
enum class UpAxis { kY, kZ, kX };
/// "y", "z", "x" (or "+y", ...) -> UpAxis; InvalidInput otherwise.
UpAxis parse_up_axis(const std::string& name);
std::string up_axis_name(UpAxis up);
/// The mesh turned so that `up` becomes +y, by a proper rotation (faces keep their orientation):
/// z-up (x, y, z) -> (x, z, -y), the usual conversion from Blender's and CAD tools' frame to glTF's;
/// x-up (x, y, z) -> (-y, x, z). y-up: unchanged.
Mesh to_y_up(const Mesh& mesh, UpAxis up);

/// Throws InvalidInput "<what>: face index out of range: face f uses vertex i of n" for the first face that
/// names a vertex outside [0, V.rows()).
void check_face_indices(const Mesh& mesh, const std::string& what);

/// Throws InvalidInput (message starts with `what`) if the mesh is empty, has non-finite coordinates or
/// out-of-range indices. Otherwise returns a copy without degenerate and duplicate faces and fills `report`.
Mesh validate_mesh(const Mesh& mesh, const std::string& what, MeshReport* report = nullptr);

/// Write by extension: .obj (with "v x y z r g b" colours when present), .ply (binary little endian, uchar
/// colours when present), .off, .stl (binary). Atomic (temporary file + rename). Throws InvalidInput on non-finite
/// coordinates: sdfkit never writes a NaN to disk. .glb: binary glTF 2.0 with COLOR_0 vertex colours (core/glb.h).
void write_mesh(const std::string& path, const Mesh& mesh);

/// Concatenate meshes (faces re-indexed; colours kept when every part has them).
Mesh concatenate(const Mesh& a, const Mesh& b);

}  // namespace sdfkit
