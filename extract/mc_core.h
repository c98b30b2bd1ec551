// The per-cell marching cubes engine shared by the dense, sparse (OpenVDB) and adaptive front-ends.
//
// A front-end hands cells to McBuilder in any order; the builder looks the cell's sign configuration up in a
// case table, emits triangles and keeps one vertex per crossed grid edge (keyed by the edge's integer grid
// coordinates, so a vertex is shared by the up to four cells around its edge). Two front-ends that add the
// same cells, with the same values, in the same order produce byte-identical meshes.
//
// Conventions (see docs/extract.md for the reasoning):
//  - s = value - iso. A corner is inside iff s < 0; s == 0 counts as outside.
//  - Face ambiguities are resolved by the asymptotic decider from the face's four values alone (so both cells
//    sharing a face decide alike: no cracks); ties count as "saddle outside" (the same rule as s == 0).
//    Interior ambiguities are always resolved as separate sheets (one disc per boundary loop, no tunnels).
//  - A vertex whose interpolation parameter is exactly 0 or 1 sits on a grid point and is keyed by that point,
//    so all edges snapping to the same point share one vertex; triangles that collapse are dropped.
//  - Padding corners (outside the sampled region, used to close surfaces at the grid boundary) are outside;
//    an edge from an inside grid point to a padding point puts its vertex on the grid point.
//  - Normals (right-hand rule on the face order) point towards increasing values: outward for an SDF that is
//    negative inside.
#pragma once

#include "core/types.h"
#include "extract/marching_cubes.h"

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace sdfkit::detail {

/// Corner c of a cell is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) from its minimum corner.
constexpr int kCorners = 8;
/// Value given to padding corners (finite so the asymptotic decider's products stay finite).
constexpr double kPadValue = 1e30;

/// Open-addressing hash map from 64-bit keys to vertex ids (much faster than std::unordered_map here).
class KeyMap {
 public:
  explicit KeyMap(size_t expected = 1024);
  /// Id stored for `key`, inserting `next_id` when absent; `inserted` tells which happened.
  int32_t find_or_insert(uint64_t key, int32_t next_id, bool& inserted);
  [[nodiscard]] size_t size() const { return size_; }

 private:
  void grow();
  std::vector<uint64_t> keys_;
  std::vector<int32_t> ids_;
  size_t size_ = 0;
  size_t mask_ = 0;
};

struct BuildStats {
  long cells_with_surface = 0;   ///< cells that produced at least one triangle (before collapse)
  long snapped_vertices = 0;     ///< vertices placed exactly on a grid point
  long centre_vertices = 0;      ///< extra vertices at the centre of loops fanned around their centroid
};

/// Accumulates triangles cell by cell. Grid indices may be negative (padding cells) and must satisfy
/// |i| < 2^20.
class McBuilder {
 public:
  McBuilder();
  /// Adds cell (i, j, k) (its minimum corner). `s` holds value - iso per corner; `pad` has bit c set when
  /// corner c is padding (its s is ignored and treated as kPadValue).
  void add_cell(int i, int j, int k, const double s[kCorners], uint32_t pad = 0);
  /// True when the corners straddle the iso value (cheap pre-test; add_cell does nothing otherwise).
  static bool has_crossing(const double s[kCorners], uint32_t pad = 0);
  /// The mesh with vertices mapped from index space (i + t, j, k) to world by `origin + voxel * index`.
  /// `stats`, when given, receives the build's counts and the number of triangles dropped because merging
  /// snapped vertices collapsed them.
  Mesh finish(const Vec3& origin, double voxel, MarchingCubesStats* stats = nullptr) const;
  /// The mesh with an arbitrary index -> world map.
  Mesh finish(const std::function<Vec3(const Vec3&)>& index_to_world, MarchingCubesStats* stats = nullptr) const;
  [[nodiscard]] const BuildStats& stats() const { return stats_; }
  /// Appends the cells another builder received, as if they had been added to this one after its own: vertices
  /// of edges this builder already has are shared, new ones are numbered in `other`'s creation order. So cells
  /// cut into consecutive chunks, built in parallel and appended in chunk order give exactly the serial mesh.
  void append(const McBuilder& other);

 private:
  int32_t vertex_for_edge(int i, int j, int k, int edge, const double s[kCorners], uint32_t pad);
  KeyMap map_;
  std::vector<Vec3> vertices_;  // index space
  std::vector<uint64_t> snap_;  // key of the grid point the vertex sits on, or ~0
  std::vector<uint64_t> key_;   // key of the vertex's grid edge, or ~0 for a loop's centre vertex
  std::vector<std::array<int32_t, 3>> faces_;
  BuildStats stats_;
};

/// Facts about the generated case table (for tests): number of (case, face decision) entries and how many
/// have a loop that any triangulation would cut with a diagonal lying in a cube face (those loops are fanned
/// around an extra centre vertex instead).
struct TableStats {
  int entries = 0;
  int entries_with_centre_vertex = 0;
  int max_loop_length = 0;
};
TableStats table_stats();

}  // namespace sdfkit::detail
