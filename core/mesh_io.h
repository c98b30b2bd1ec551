// Mesh input (OBJ, STL through assimp; PLY ascii/binary through sdfkit's own core/ply_io.h; OFF through sdfkit's
// own reader), validation, and mesh writers (OBJ, PLY, OFF).
#pragma once

#include "core/types.h"

#include <string>

namespace sdfkit {

/// What validation found. Empty meshes, non-finite coordinates and out-of-range indices are errors
/// (InvalidInput); the counts below are problems that are handled (removed or tolerated) and reported.
struct MeshReport {
  long degenerate_faces = 0;    ///< faces with a repeated index or (near-)zero area, removed
  long duplicate_faces = 0;     ///< faces with the same vertex set as an earlier face, removed
  long unreferenced_vertices = 0;  ///< vertices used by no face (kept; harmless)
  long input_faces = 0;         ///< faces after triangulation, before clean-up
};

/// Read a mesh by extension (obj, ply, off, stl; case-insensitive; .ply goes through read_ply of
/// core/ply_io.h, .off through sdfkit's OFF reader: messages give the line, counted from 1). Polygons are triangulated, identical vertices are merged, all parts are merged into one mesh in the file's global frame. Throws IoError naming
/// the file when it cannot be parsed (unknown extension, truncated, malformed) and InvalidInput when it is
/// unusable (empty, non-finite coordinates, out-of-range indices).
Mesh read_mesh(const std::string& path, MeshReport* report = nullptr);

/// True when `path` ends in an extension read_mesh reads (.obj, .ply, .off, .stl; case-insensitive).
bool has_mesh_extension(const std::string& path);

/// Throws InvalidInput "<what>: face index out of range: face f uses vertex i of n" for the first face that
/// names a vertex outside [0, V.rows()).
void check_face_indices(const Mesh& mesh, const std::string& what);

/// Throws InvalidInput (message starts with `what`) if the mesh is empty, has non-finite coordinates or
/// out-of-range indices. Otherwise returns a copy without degenerate and duplicate faces and fills `report`.
Mesh validate_mesh(const Mesh& mesh, const std::string& what, MeshReport* report = nullptr);

/// Write by extension: .obj (with "v x y z r g b" colours when present), .ply (binary little endian, uchar
/// colours when present), .off. Atomic (temporary file + rename). Throws InvalidInput on non-finite
/// coordinates: sdfkit never writes a NaN to disk.
void write_mesh(const std::string& path, const Mesh& mesh);

/// Concatenate meshes (faces re-indexed; colours kept when every part has them).
Mesh concatenate(const Mesh& a, const Mesh& b);

}  // namespace sdfkit
