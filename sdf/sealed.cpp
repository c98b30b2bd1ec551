#include "sdf/sealed.h"

#include "core/error.h"

#include <array>
#include <cmath>

namespace sdfkit {

SealedCavities::SealedCavities(const Eigen::Vector3i& lo, const Eigen::Vector3i& dims, int32_t offset, double h,
                               std::vector<uint8_t> wall)
    : lo_(lo), dims_(dims), offset_(offset), h_(h), state_(std::move(wall)) {
  require((dims.array() > 0).all(), "sealed cavities: the box must have voxels on every axis");
  require(h > 0 && std::isfinite(h), "sealed cavities: voxel size must be positive");
  const int64_t nx = dims.x(), ny = dims.y(), nz = dims.z();
  require(static_cast<int64_t>(state_.size()) == nx * ny * nz, "sealed cavities: wall mask size does not match the box");
  for (uint8_t& s : state_) s = s ? kWall : kSealed;
  // Flood the exterior from the box's faces, 6-connected, depth first with an explicit stack.
  std::vector<int64_t> stack;
  auto push = [&](int64_t x, int64_t y, int64_t z) {
    const int64_t k = (x * ny + y) * nz + z;
    if (state_[static_cast<size_t>(k)] != kSealed) return;
    state_[static_cast<size_t>(k)] = kExterior;
    stack.push_back(k);
  };
  for (int64_t x = 0; x < nx; ++x)
    for (int64_t y = 0; y < ny; ++y)
      for (int64_t z = 0; z < nz; ++z)
        if (x == 0 || y == 0 || z == 0 || x == nx - 1 || y == ny - 1 || z == nz - 1) push(x, y, z);
  while (!stack.empty()) {
    const int64_t k = stack.back();
    stack.pop_back();
    const int64_t z = k % nz, y = (k / nz) % ny, x = k / (nz * ny);
    if (x > 0) push(x - 1, y, z);
    if (x + 1 < nx) push(x + 1, y, z);
    if (y > 0) push(x, y - 1, z);
    if (y + 1 < ny) push(x, y + 1, z);
    if (z > 0) push(x, y, z - 1);
    if (z + 1 < nz) push(x, y, z + 1);
  }
  for (uint8_t s : state_) {
    sealed_ += s == kSealed;
    walls_ += s == kWall;
  }
}

uint8_t SealedCavities::state(int32_t x, int32_t y, int32_t z) const {
  if (x < 0 || y < 0 || z < 0 || x >= dims_.x() || y >= dims_.y() || z >= dims_.z()) return kExterior;
  return state_[(static_cast<size_t>(x) * static_cast<size_t>(dims_.y()) + static_cast<size_t>(y)) *
                    static_cast<size_t>(dims_.z()) +
                static_cast<size_t>(z)];
}

bool SealedCavities::contains(const Vec3& p, const MeshDistance& exact) const {
  if (state_.empty()) return false;
  const Eigen::Vector3i c(static_cast<int32_t>(std::lround(p.x() / h_)) + offset_ - lo_.x(),
                          static_cast<int32_t>(std::lround(p.y() / h_)) + offset_ - lo_.y(),
                          static_cast<int32_t>(std::lround(p.z() / h_)) + offset_ - lo_.z());
  const uint8_t s = state(c.x(), c.y(), c.z());
  if (s != kWall) return s == kSealed;
  // Near the surface: what p reaches without crossing it. A visible exterior neighbour decides "no", so the
  // exterior neighbours are tried first, then the sealed ones until one is visible; without a sealed neighbour the
  // answer is "no" without a query. The result does not depend on this order, only the number of segment queries.
  std::array<Vec3, 26> exterior, cavity;
  int n_exterior = 0, n_cavity = 0;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const uint8_t n = state(c.x() + dx, c.y() + dy, c.z() + dz);
        if (n == kWall) continue;  // also the centre voxel itself
        const Vec3 q(h_ * (c.x() + dx + lo_.x() - offset_), h_ * (c.y() + dy + lo_.y() - offset_),
                     h_ * (c.z() + dz + lo_.z() - offset_));
        if (n == kExterior)
          exterior[static_cast<size_t>(n_exterior++)] = q;
        else
          cavity[static_cast<size_t>(n_cavity++)] = q;
      }
  if (n_cavity == 0) return false;
  for (int k = 0; k < n_exterior; ++k)
    if (!exact.segment_may_cross(p, exterior[static_cast<size_t>(k)])) return false;
  for (int k = 0; k < n_cavity; ++k)
    if (!exact.segment_may_cross(p, cavity[static_cast<size_t>(k)])) return true;
  return false;
}

}  // namespace sdfkit
