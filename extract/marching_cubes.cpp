#include "extract/marching_cubes.h"

#include "core/error.h"
#include "extract/mc_core.h"

#include <cmath>
#include <string>

namespace sdfkit {

Mesh marching_cubes(const DenseGrid& grid, const MarchingCubesSettings& settings, MarchingCubesStats* stats) {
  require(grid.nx >= 2 && grid.ny >= 2 && grid.nz >= 2,
          "marching_cubes: the grid needs at least 2 points per axis, got " + std::to_string(grid.nx) + " x " +
              std::to_string(grid.ny) + " x " + std::to_string(grid.nz));
  require(grid.nx <= 500000 && grid.ny <= 500000 && grid.nz <= 500000,
          "marching_cubes: at most 500000 points per axis");
  require(grid.values.size() == grid.size(), "marching_cubes: the grid holds " +
                                                 std::to_string(grid.values.size()) + " values for " +
                                                 std::to_string(grid.size()) + " points");
  require(grid.voxel > 0 && std::isfinite(grid.voxel) && grid.origin.allFinite(),
          "marching_cubes: the voxel size must be positive and the origin finite");
  require(std::isfinite(settings.iso), "marching_cubes: the iso value must be finite");
  for (size_t n = 0; n < grid.values.size(); ++n)
    if (!std::isfinite(grid.values[n]))
      throw InvalidInput("marching_cubes: grid value " + std::to_string(n) + " is not finite");

  const double iso = settings.iso;
  const int lo = settings.close_boundary ? -1 : 0;
  const int hx = grid.nx - 1, hy = grid.ny - 1, hz = grid.nz - 1;  // last cell index + 1 when padded
  detail::McBuilder builder;
  double s[detail::kCorners];
  for (int k = lo; k < (settings.close_boundary ? hz + 1 : hz); ++k)
    for (int j = lo; j < (settings.close_boundary ? hy + 1 : hy); ++j)
      for (int i = lo; i < (settings.close_boundary ? hx + 1 : hx); ++i) {
        const bool interior = i >= 0 && j >= 0 && k >= 0 && i < hx && j < hy && k < hz;
        uint32_t pad = 0;
        if (interior) {
          const size_t base = grid.index(i, j, k);
          const size_t dy = size_t(grid.nx), dz = size_t(grid.nx) * grid.ny;
          const float* v = grid.values.data();
          s[0] = double(v[base]) - iso;
          s[1] = double(v[base + 1]) - iso;
          s[2] = double(v[base + dy]) - iso;
          s[3] = double(v[base + dy + 1]) - iso;
          s[4] = double(v[base + dz]) - iso;
          s[5] = double(v[base + dz + 1]) - iso;
          s[6] = double(v[base + dz + dy]) - iso;
          s[7] = double(v[base + dz + dy + 1]) - iso;
        } else {
          for (int c = 0; c < detail::kCorners; ++c) {
            const int ci = i + (c & 1), cj = j + ((c >> 1) & 1), ck = k + ((c >> 2) & 1);
            if (ci < 0 || cj < 0 || ck < 0 || ci >= grid.nx || cj >= grid.ny || ck >= grid.nz) {
              pad |= 1u << c;
              s[c] = detail::kPadValue;
            } else {
              s[c] = double(grid.at(ci, cj, ck)) - iso;
            }
          }
        }
        if (!detail::McBuilder::has_crossing(s, pad)) continue;
        builder.add_cell(i, j, k, s, pad);
      }
  return builder.finish(grid.origin, grid.voxel, stats);
}

}  // namespace sdfkit
