// Nearest-neighbour queries on a 3D point set: a KD-tree (nanoflann, hidden in kdtree.cpp) over a copy of the
// points, with TBB-parallel batch queries whose results do not depend on the thread count.
#pragma once

#include "core/types.h"

#include <memory>
#include <utility>
#include <vector>

namespace sdfkit {

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
  /// Nearest point of every query row, in parallel. Queries are visited in `order` when given (e.g. another
  /// tree's leaf_order(): neighbouring queries one after the other) in fixed blocks of 256; within a block each
  /// search starts from the previous query's neighbour as its first candidate, which prunes most of the tree.
  /// Distances are exact either way; results do not depend on the thread count.
  void nearest(const Points& queries, Eigen::VectorXi& index, Eigen::VectorXd& squared_distance,
               const std::vector<uint32_t>* order = nullptr) const;
  /// Indices of the points in the order of the tree's leaves (spatially coherent).
  [[nodiscard]] std::vector<uint32_t> leaf_order() const;
  /// The k nearest points of q (k clamped to the size), closest first: (index, squared distance).
  [[nodiscard]] std::vector<std::pair<int, double>> knn(const Vec3& q, int k) const;
  /// The same into caller buffers of k entries (no allocation); returns how many were found (min(k, size)).
  int knn(const Vec3& q, int k, uint32_t* index, double* squared_distance) const;
  /// k nearest points of every query row (k <= size()): index[q * k + r] is the r-th nearest of query q, the
  /// same as knn(query q, k) gives. Queries are visited in `order` when given (spatially coherent, e.g. another
  /// tree's leaf_order()) in fixed blocks of 256, in parallel; each search after the first of a block starts
  /// with a radius from the previous query (its k-th distance plus the distance between the two queries: it
  /// holds k points, so it bounds this query's k-th distance), which prunes far subtrees before k points are
  /// found. Points within that radius are visited in the same order as without it, so results are the same
  /// (and a query that found fewer than k points inside it would be searched again without one).
  void knn_batch(const Points& queries, int k, std::vector<uint32_t>& index,
                 const std::vector<uint32_t>* order = nullptr) const;

 private:
  struct Impl;
  Points points_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sdfkit
