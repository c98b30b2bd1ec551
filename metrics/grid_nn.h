// Exact nearest-neighbour queries on a 3D point set through a uniform grid of cells (points bucketed by cell,
// compressed row storage): the structure behind Chamfer distances and F-scores.
//
// Why not only the KD-tree (metrics/kdtree.h): scoring compares two clouds that lie close to each other, so a
// query's nearest point is almost always in its own cell or a neighbouring one. The grid is built by one counting
// sort (no recursive median splits) and a query visits a handful of cells, pruned by the exact distance from the
// query to each cell's box. A query whose answer is not found within two rings of cells (an outlier far from the
// set) is answered by a KD-tree over the same points, built once, on first need.
//
// Distances are computed in double exactly as the brute-force reference does ((dx^2 + dy^2) + dz^2), and cell
// pruning keeps a margin for the rounding of cell bounds, so the squared distance returned is the exact minimum.
// Among equidistant points the grid returns the smallest index; results do not depend on the thread count.
#pragma once

#include "core/types.h"
#include "metrics/kdtree.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace sdfkit {

class NearestGrid {
 public:
  /// Buckets a copy of `points` (#P by 3, finite, non-empty; InvalidInput otherwise, naming `what`).
  explicit NearestGrid(const Points& points, const std::string& what = "points");
  ~NearestGrid();
  NearestGrid(const NearestGrid&) = delete;
  NearestGrid& operator=(const NearestGrid&) = delete;

  [[nodiscard]] Eigen::Index size() const { return static_cast<Eigen::Index>(order_.size()); }
  /// Number of cells along each axis and the cell edge length (for reports and tests).
  [[nodiscard]] std::array<int, 3> dims() const { return {dims_[0], dims_[1], dims_[2]}; }
  [[nodiscard]] double cell_size() const { return h_; }

  /// Index of a nearest point of the set and its squared distance to q (exact).
  [[nodiscard]] std::pair<int, double> nearest(const Vec3& q) const;
  /// Nearest point of every query row, in parallel (queries are visited cell by cell for cache locality).
  void nearest(const Points& queries, Eigen::VectorXi& index, Eigen::VectorXd& squared_distance) const;
  /// How many queries so far were handed to the KD-tree fallback (far from the set).
  [[nodiscard]] long fallback_count() const;

 private:
  struct Hit {
    uint32_t slot;  // position in the cell-sorted arrays
    double d2;
  };
  struct CellOffset {
    int d[3];
    int rank;      // sum over axes of max(0, |d| - 1)^2
    double least;  // sqrt(rank): least distance from the centre cell, in cell sizes
  };
  static const std::vector<CellOffset>& block_offsets();
  [[nodiscard]] int cell_coord(double x, int axis) const;
  [[nodiscard]] size_t cell_index(int cx, int cy, int cz) const {
    return static_cast<size_t>(cx) + dims_[0] * (static_cast<size_t>(cy) + dims_[1] * static_cast<size_t>(cz));
  }
  /// Row indices of p sorted by cell (counting sort, stable); start[c] .. start[c + 1] are those of cell c.
  std::vector<uint32_t> bucket(const Points& p, std::vector<uint32_t>& start) const;
  [[nodiscard]] Hit search(const double q[3], uint32_t guess, bool& resolved) const;
  [[nodiscard]] std::pair<int, double> fallback(const double q[3]) const;

  double origin_[3] = {0, 0, 0};
  double h_ = 1, inv_h_ = 1, slack_ = 0;
  int dims_[3] = {1, 1, 1};
  std::vector<uint32_t> cell_start_;  // cells + 1 offsets into x_, y_, z_, order_
  std::vector<double> x_, y_, z_;     // points sorted by cell
  std::vector<uint32_t> order_;       // original index of each sorted point
  mutable std::once_flag tree_once_;
  mutable std::unique_ptr<KdTree> tree_;  // over the sorted points; built on the first far query
  mutable std::atomic<long> fallbacks_{0};
};

}  // namespace sdfkit
