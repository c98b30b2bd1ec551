// Generalized winding numbers (Jacobson et al. 2013) with the fast hierarchical evaluation of Barill et al.
// (2018): a BVH over the triangles, far-field Taylor expansion of each node (up to second order), exact
// solid angles near the query. w ~ 1 inside a closed outward-oriented surface, 0 outside, and a smooth, robust
// inside measure for open, self-intersecting and polygon-soup meshes (inside iff w > 0.5).
#pragma once

#include "core/types.h"
#include "sdf/bvh.h"

#include <vector>

namespace sdfkit {

class WindingNumber {
 public:
  /// `beta` is the accuracy parameter: a node is approximated by its expansion when the query is farther
  /// than beta times the node's radius from its centre (larger = more accurate and slower; 2 is Barill's).
  explicit WindingNumber(const Mesh& mesh, double beta = 2.0);

  /// Winding number at p (thread-safe).
  double operator()(const Vec3& p) const;
  /// Winding numbers of every row of P, in parallel (TBB); identical to calling operator() per row.
  [[nodiscard]] Eigen::VectorXd query(const Points& P) const;

  /// The exact sum of triangle solid angles / 4 pi over all triangles (O(#F) per query; reference for tests).
  static double brute_force(const Mesh& mesh, const Vec3& p);

  [[nodiscard]] double beta() const { return beta_; }

 private:
  struct Expansion {
    Vec3 center;       ///< area-weighted centroid of the node's triangles
    Vec3 normal_sum;   ///< sum of area * unit normal (= half cross products)
    Mat3 first;        ///< sum of area * (centroid - center) * normal^T
    Mat3 second[3];    ///< second[i] = sum of normal_i * (integral over the triangle of delta delta^T)
    double radius2 = 0;  ///< (beta * radius)^2: the far-field threshold, squared
  };
  TriangleBvh bvh_;
  std::vector<Expansion> expansion_;  ///< one per BVH node
  double beta_;
};

/// One-off: winding numbers of points against a mesh (builds the hierarchy once).
Eigen::VectorXd winding_numbers(const Mesh& mesh, const Points& P, double beta = 2.0);

}  // namespace sdfkit
