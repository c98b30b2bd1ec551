// Cavities that a surface seals at a grid's resolution: the inside of DISN's polygon-soup ground truth. DISN signs
// its 257^3 grids by flooding the exterior through the cells no triangle touches, so a hollow box closed by doors
// with gaps narrower than a cell is solid; exact signs (pseudo-normals, winding numbers) call its interior outside.
// `prep --sign flood` adds these cavities to the exact inside, so that the grid, the samples and the iso-surface
// ground truth agree with the flood-filled voxels of the IoU protocol.
#pragma once

#include "core/types.h"
#include "sdf/distance.h"

#include <cstdint>
#include <vector>

namespace sdfkit {

class SealedCavities {
 public:
  /// A cell (voxel centre within kWallWidth voxels of the surface: the surface may touch the voxel's cube) is a
  /// wall; the flood cannot pass it. Gaps narrower than about 1.7 voxels between two surfaces are therefore sealed,
  /// and the flood never crosses a surface (of two face neighbours on either side of it, one is a wall).
  static constexpr double kWallWidth = 0.87;

  SealedCavities() = default;
  /// `lo`: index of the lattice voxel at wall[0]; `dims`: the box's voxels per axis (x-major, z fastest); index i
  /// sits at world position h * (i - offset) on each axis. wall[k] != 0 marks a wall voxel. Voxels outside the box
  /// are exterior, and so is every voxel reached from the box's faces through non-wall voxels (6-connected).
  /// Throws InvalidInput when wall.size() does not match dims.
  SealedCavities(const Eigen::Vector3i& lo, const Eigen::Vector3i& dims, int32_t offset, double h,
                 std::vector<uint8_t> wall);

  /// True when p lies in a cavity that the flood did not reach: p's nearest voxel is such a non-wall voxel; or
  /// it is a wall voxel and, among its 26 neighbours that are no walls and that p sees without a surface in
  /// between (`exact`, conservative), none is exterior and at least one is sealed. False elsewhere (the exact sign
  /// then decides: walls inside the material stay inside by it).
  [[nodiscard]] bool contains(const Vec3& p, const MeshDistance& exact) const;

  /// Non-wall voxels the flood did not reach (sealed cavities and the material's own deep inside).
  [[nodiscard]] long sealed_voxels() const { return sealed_; }
  [[nodiscard]] long wall_voxels() const { return walls_; }
  [[nodiscard]] bool empty() const { return state_.empty(); }

 private:
  enum : uint8_t { kSealed = 0, kWall = 1, kExterior = 2 };
  [[nodiscard]] uint8_t state(int32_t x, int32_t y, int32_t z) const;  ///< box-local indices; outside: exterior
  Eigen::Vector3i lo_ = Eigen::Vector3i::Zero(), dims_ = Eigen::Vector3i::Zero();
  int32_t offset_ = 0;
  double h_ = 1;
  std::vector<uint8_t> state_;
  long sealed_ = 0, walls_ = 0;
};

}  // namespace sdfkit
