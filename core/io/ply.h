// sdfkit's own PLY reader (ascii, binary little and big endian). assimp 5.2 (Debian 12) misreads some valid
// binary PLYs (coloured procedural shapes) and no other maintained PLY reader is packaged by Debian, so this
// one is ours. read_mesh (core/mesh_io.h) routes every .ply file here; write_mesh writes binary little endian PLY
// (core/io/formats.h, write_ply).
#pragma once

#include "core/types.h"

#include <string>

namespace sdfkit {

/// What the PLY reader saw besides the mesh (for reports and tests).
struct PlyInfo {
  std::string format;        ///< "ascii", "binary_little_endian" or "binary_big_endian"
  long vertices = 0;         ///< declared vertex count
  long faces = 0;            ///< declared face count
  long polygons = 0;         ///< faces with more than three corners (fanned into triangles)
  long skipped_faces = 0;    ///< faces with fewer than three corners (points, lines): no surface, skipped
  long skipped_elements = 0; ///< elements other than vertex/face, skipped by their declared size
};

/// Parse PLY bytes into a mesh: vertex x, y, z of any numeric type; red/green/blue (uchar as /255, float as
/// is) kept as colours when all three are present; face lists `vertex_indices` or `vertex_index` of any
/// integer count/index types, polygons fanned into triangles; every other element and property skipped by
/// its declared type. No welding and no clean-up (read_mesh does that). `name` prefixes every message.
/// Throws IoError for a malformed header, an unknown format or type, truncated data (fewer values than the
/// counts declare, or counts the remaining bytes could not hold), a list length that is not a non-negative
/// integer, or trailing data (more than declared), InvalidInput for non-finite coordinates and out-of-range
/// indices.
Mesh parse_ply(const std::string& bytes, const std::string& name, PlyInfo* info = nullptr);

/// Read a PLY file (parse_ply of its bytes, messages name `path`). IoError when it cannot be read.
Mesh read_ply(const std::string& path, PlyInfo* info = nullptr);

}  // namespace sdfkit
