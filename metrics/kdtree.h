// Nearest-neighbour queries on a 3D point set: a KD-tree (nanoflann, hidden in kdtree.cpp) over a copy of the
// points, with TBB-parallel batch queries whose results do not depend on the thread count.
#pragma once

#include "core/types.h"

#include <memory>
#include <utility>
#include <vector>

namespace sdfkit::metrics {

class KdTree {
 public:
  /// Builds the tree over a copy of `points` (#P by 3, finite, non-empty; InvalidInput otherwise).
  explicit KdTree(Points points, const std::string& what = "points");
  ~KdTree();
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;

  [[nodiscard]] const Points& points() const { return points_; }
  [[nodiscard]] Eigen::Index size() const { return points_.rows(); }

  /// Index of the nearest point and its squared distance (exact; among equidistant points, whichever the tree
  /// meets first, always the same one for the same data).
  [[nodiscard]] std::pair<int, double> nearest(const Vec3& q) const;
  /// Nearest point of every query row (parallel over queries; each result depends only on its query).
  void nearest(const Points& queries, Eigen::VectorXi& index, Eigen::VectorXd& squared_distance) const;
  /// The k nearest points of q (k clamped to the size), closest first: (index, squared distance).
  [[nodiscard]] std::vector<std::pair<int, double>> knn(const Vec3& q, int k) const;

 private:
  struct Impl;
  Points points_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sdfkit::metrics
