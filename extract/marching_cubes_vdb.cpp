#include "extract/marching_cubes_vdb.h"

#include "core/error.h"
#include "extract/band_grid.h"
#include "extract/mc_core.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

namespace sdfkit {
namespace {

struct BandCell {
  uint64_t order;
  int i, j, k;
  std::array<float, detail::kCorners> v;
};

constexpr int kMaxIndex = (1 << 19) - 4;

std::string str(const openvdb::Coord& c) {
  return "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " + std::to_string(c.z()) + ")";
}

uint64_t order_key(int i, int j, int k) {
  const uint64_t o = 1u << 20;
  return ((uint64_t(k) + o) << 42) | ((uint64_t(j) + o) << 21) | (uint64_t(i) + o);
}

void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

}  // namespace

Mesh marching_cubes(const openvdb::FloatGrid& grid_in, const MarchingCubesSettings& settings,
                    MarchingCubesStats* stats) {
  require(std::isfinite(settings.iso), "marching_cubes (vdb): the iso value must be finite");
  const openvdb::FloatGrid* grid = &grid_in;
  openvdb::FloatGrid::Ptr voxelised;
  if (grid_in.tree().activeTileCount() > 0) {
    voxelised = grid_in.deepCopy();
    voxelised->tree().voxelizeActiveTiles();
    grid = voxelised.get();
  }
  const double iso = settings.iso;
  auto acc = grid->getConstAccessor();
  std::vector<BandCell> cells;
  for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf)
    for (auto it = leaf->cbeginValueOn(); it; ++it) {
      const openvdb::Coord c = it.getCoord();
      if (std::abs(c.x()) > kMaxIndex || std::abs(c.y()) > kMaxIndex || std::abs(c.z()) > kMaxIndex)
        throw InvalidInput("marching_cubes (vdb): active voxel " + str(c) + " is beyond index 2^19");
      BandCell cell{order_key(c.x(), c.y(), c.z()), c.x(), c.y(), c.z(), {}};
      bool known = true;
      int inside = 0;
      for (int corner = 0; corner < detail::kCorners && known; ++corner) {
        const openvdb::Coord q = c.offsetBy(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        float v;
        known = acc.probeValue(q, v);
        if (!std::isfinite(v))
          throw InvalidInput("marching_cubes (vdb): voxel " + str(q) + " holds a non-finite value");
        cell.v[corner] = v;
        inside += (double(v) - iso < 0) ? 1 : 0;
      }
      if (known && inside != 0 && inside != detail::kCorners) cells.push_back(cell);
    }
  std::sort(cells.begin(), cells.end(), [](const BandCell& a, const BandCell& b) { return a.order < b.order; });
  detail::McBuilder builder;
  double s[detail::kCorners];
  for (const BandCell& cell : cells) {
    for (int corner = 0; corner < detail::kCorners; ++corner) s[corner] = double(cell.v[corner]) - iso;
    builder.add_cell(cell.i, cell.j, cell.k, s, 0);
  }
  const openvdb::math::Transform& xf = grid->transform();
  return builder.finish(
      [&](const Vec3& p) -> Vec3 {
        const openvdb::Vec3d w = xf.indexToWorld(openvdb::Vec3d(p.x(), p.y(), p.z()));
        return Vec3(w.x(), w.y(), w.z());
      },
      stats);
}

openvdb::FloatGrid::Ptr dense_to_band(const DenseGrid& grid, double half_width_voxels, double iso) {
  init_openvdb();
  require(grid.nx >= 1 && grid.ny >= 1 && grid.nz >= 1 && grid.values.size() == grid.size(),
          "dense_to_band: the grid's size does not match its values");
  require(half_width_voxels > 0, "dense_to_band: the half width must be positive");
  const float background = static_cast<float>(half_width_voxels * grid.voxel);
  auto band = openvdb::FloatGrid::create(background);
  band->setTransform(openvdb::math::Transform::createLinearTransform(grid.voxel));
  band->transform().postTranslate(openvdb::Vec3d(grid.origin.x(), grid.origin.y(), grid.origin.z()));
  band->setGridClass(openvdb::GRID_LEVEL_SET);
  band->setName("sdf");
  auto acc = band->getAccessor();
  for (int k = 0; k < grid.nz; ++k)
    for (int j = 0; j < grid.ny; ++j)
      for (int i = 0; i < grid.nx; ++i) {
        const float v = grid.at(i, j, k);
        if (!std::isfinite(v))
          throw InvalidInput("dense_to_band: grid value at (" + std::to_string(i) + ", " + std::to_string(j) +
                             ", " + std::to_string(k) + ") is not finite");
        if (std::abs(double(v) - iso) <= half_width_voxels * grid.voxel) acc.setValue(openvdb::Coord(i, j, k), v);
      }
  // Inactive values: +-background by the sign of the region they are in.
  if (iso == 0.0) openvdb::tools::signedFloodFill(band->tree());
  return band;
}

// ---- BandGrid -----------------------------------------------------------------------------------------------

BandGrid BandGrid::from_dense(const DenseGrid& grid, double half_width_voxels, double iso) {
  BandGrid b;
  b.grid_ = dense_to_band(grid, half_width_voxels, iso);
  return b;
}

BandGrid BandGrid::read(const std::string& path, const std::string& name) {
  init_openvdb();
  BandGrid b;
  try {
    openvdb::io::File file(path);
    file.open();
    openvdb::GridBase::Ptr base;
    if (!name.empty()) {
      if (!file.hasGrid(name)) throw IoError(path + ": no grid named '" + name + "'");
      base = file.readGrid(name);
    } else {
      for (auto it = file.beginName(); it != file.endName() && !base; ++it) {
        auto g = file.readGrid(it.gridName());
        if (g->isType<openvdb::FloatGrid>()) base = g;
      }
    }
    file.close();
    auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!fg) throw IoError(path + ": no float grid" + (name.empty() ? std::string() : " named '" + name + "'"));
    b.grid_ = fg;
  } catch (const openvdb::Exception& e) {
    throw IoError(path + ": cannot read OpenVDB file (" + e.what() + ")");
  }
  return b;
}

long BandGrid::active_voxels() const {
  return grid_ ? static_cast<long>(std::static_pointer_cast<const openvdb::FloatGrid>(grid_)->activeVoxelCount()) : 0;
}

double BandGrid::voxel_size() const {
  return grid_ ? std::static_pointer_cast<const openvdb::FloatGrid>(grid_)->voxelSize()[0] : 0.0;
}

Mesh BandGrid::extract(const MarchingCubesSettings& settings, MarchingCubesStats* stats) const {
  require(grid_ != nullptr, "BandGrid::extract: empty band grid");
  return marching_cubes(*std::static_pointer_cast<const openvdb::FloatGrid>(grid_), settings, stats);
}

}  // namespace sdfkit
