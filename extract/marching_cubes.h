// Marching cubes on a dense grid of samples -> an indexed triangle mesh with shared vertices.
//
// One vertex per crossed grid edge (shared by the cells around it), consistent orientation (normals point
// towards increasing values, i.e. outward for an SDF that is negative inside), face ambiguities resolved by the
// asymptotic decider on the face's own four values (both cells sharing a face decide alike, so there are no
// cracks), values equal to the iso value count as outside, vertices that land exactly on a grid point are merged
// and the triangles that collapse are dropped. With `close_boundary` the grid is surrounded by a virtual layer
// of outside points, so a field that is inside at the grid boundary is capped there and the output is closed.
// docs/extract.md explains the choices; extract/mc_core.h holds the per-cell engine.
#pragma once

#include "core/types.h"

#include <cstddef>
#include <vector>

namespace sdfkit {

/// Samples on a regular grid: point (i, j, k) is at origin + voxel * (i, j, k); values are stored x fastest,
/// index i + nx * (j + ny * k).
struct DenseGrid {
  Vec3 origin = Vec3::Zero();
  double voxel = 1.0;
  int nx = 0, ny = 0, nz = 0;
  std::vector<float> values;

  DenseGrid() = default;
  DenseGrid(const Vec3& grid_origin, double voxel_size, int size_x, int size_y, int size_z, float fill = 0.0f)
      : origin(grid_origin), voxel(voxel_size), nx(size_x), ny(size_y), nz(size_z),
        values(size_t(size_x) * size_y * size_z, fill) {}

  [[nodiscard]] size_t index(int i, int j, int k) const { return size_t(i) + size_t(nx) * (size_t(j) + size_t(ny) * k); }
  [[nodiscard]] float at(int i, int j, int k) const { return values[index(i, j, k)]; }
  float& at(int i, int j, int k) { return values[index(i, j, k)]; }
  [[nodiscard]] Vec3 point(int i, int j, int k) const { return origin + voxel * Vec3(i, j, k); }
  [[nodiscard]] size_t size() const { return size_t(nx) * ny * nz; }
};

struct MarchingCubesSettings {
  double iso = 0.0;            ///< extract the level set value == iso (values < iso are inside)
  bool close_boundary = true;  ///< treat points beyond the grid as outside, capping the surface at the boundary
};

/// What the extraction did (besides the mesh).
struct MarchingCubesStats {
  long cells_with_surface = 0;   ///< cells that produced triangles
  long collapsed_triangles = 0;  ///< dropped because two vertices snapped to the same grid point
  long snapped_vertices = 0;     ///< vertices exactly on a grid point (value == iso, or boundary caps)
  long centre_vertices = 0;      ///< extra vertices fanning loops no triangulation of their own could cover
};

/// Marching cubes of `grid` at `settings.iso`. Throws InvalidInput for a grid whose size does not match its
/// values, with fewer than 2 points per axis, more than 500000 points per axis, a non-positive voxel or a
/// non-finite value (NaN/inf in a sample would silently tear the surface).
Mesh marching_cubes(const DenseGrid& grid, const MarchingCubesSettings& settings = {},
                    MarchingCubesStats* stats = nullptr);

}  // namespace sdfkit
