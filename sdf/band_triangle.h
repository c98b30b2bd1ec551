// A triangle prepared for many exact point distances along lattice rows: the inner loop of the sparse SDF's
// band (sdf/sparse_sdf.cpp), where every voxel of a triangle's grown box takes min(best, distance^2).
//
// The distance is split into the offset from the triangle's plane and the in-plane offset: when the projection
// of p falls inside the triangle (every edge's outward in-plane distance <= 0), the distance is the plane
// distance; else the closest point lies on an edge whose outward side holds the projection, and
// plane^2 + (largest outward edge distance)^2 is a lower bound that rejects most such voxels before the exact
// point-segment distances. Along a row of constant (x, y), every one of these quantities is affine in z (the
// squared corner distances quadratic), so a row costs a few multiply-adds per voxel.
#pragma once

#include "core/types.h"

#include <array>
#include <limits>

namespace sdfkit {

struct BandTriangle {
  std::array<Vec3, 3> v;       ///< corners a, b, c
  Vec3 n = Vec3::Zero();       ///< unit normal of (b - a) x (c - a)
  double offset = 0;           ///< n . a
  std::array<Vec3, 3> m;       ///< unit outward in-plane normal of edge k (v[k] -> v[k+1])
  std::array<double, 3> m_offset{};  ///< m[k] . v[k]
  std::array<Vec3, 3> dir;     ///< v[k+1] - v[k]
  std::array<double, 3> len2{}, inv_len2{};
  /// False for (near-)degenerate triangles (zero area or a sliver whose normal is not well defined): these
  /// fall back to closest_point_on_triangle (sdf/bvh.h) for every point.
  bool regular = false;

  static BandTriangle make(const Vec3& a, const Vec3& b, const Vec3& c);

  /// Exact squared distance from p to the triangle.
  [[nodiscard]] double squared_distance(const Vec3& p) const;

  /// For the lattice row p_k = (px, py, (z_begin + k - index_offset) * h), k = 0..count-1:
  /// best[k] = min(best[k], squared distance of p_k), skipping points whose lower bound is >= best[k], and
  /// the whole row when a bound over it is >= `limit2` (pass the largest best[k] or more; inf = no row test).
  void row_min(double px, double py, int32_t z_begin, int32_t count, int32_t index_offset, double h,
               double* best, double limit2 = std::numeric_limits<double>::infinity()) const;
};

}  // namespace sdfkit
