// Minimum-cost perfect assignment (the combinatorial core of the exact EMD).
//  - hungarian(): the dense O(n^3) Hungarian method with potentials; the reference and the baseline.
//  - SparseAssignment: successive shortest augmenting paths (Dijkstra on reduced costs with column prices, the
//    augmentation step of Jonker & Volgenant) on a sparse candidate graph that can grow; rows can be freed and
//    re-augmented (warm start). Exact in exact arithmetic; optimality for the full dense problem is certified by
//    the caller from the duals (metrics/emd.h).
#pragma once

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace sdfkit::metrics {

/// Rows -> columns of a minimum-cost perfect assignment of a square cost matrix (n <= a few thousand: O(n^3)).
/// `total`, when given, receives the summed cost. Throws InvalidInput if the matrix is not square or not finite.
std::vector<int> hungarian(const Eigen::MatrixXd& cost, double* total = nullptr);

class SparseAssignment {
 public:
  explicit SparseAssignment(int n);

  /// Adds candidate edges (column, cost) of `row`; a column already present keeps its first cost. Adding edges
  /// to an assigned row may break the optimality of its assignment: free it (unassign) before re-solving.
  void add_edges(int row, const std::vector<std::pair<int, double>>& edges);
  /// Assigns each row whose cheapest edge's column is still free to it (a valid start: prices are all 0).
  void greedy_start();
  /// Augments every free row. Returns the rows for which no augmenting path exists in the current graph (they
  /// stay free); empty = complete assignment.
  std::vector<int> solve();
  void unassign(int row);

  [[nodiscard]] int size() const { return n_; }
  [[nodiscard]] long num_edges() const;
  [[nodiscard]] const std::vector<int>& col_of_row() const { return col_of_row_; }
  [[nodiscard]] const std::vector<double>& column_prices() const { return v_; }
  /// Row dual u_i = cost(i, col_of_row(i)) - v(col_of_row(i)) (defined for assigned rows).
  [[nodiscard]] double row_dual(int row) const;
  [[nodiscard]] double assigned_cost(int row) const { return matched_cost_[static_cast<size_t>(row)]; }

 private:
  bool augment(int row);

  int n_;
  std::vector<std::vector<std::pair<int, double>>> edges_;  // per row, sorted by column
  std::vector<int> col_of_row_, row_of_col_;
  std::vector<double> matched_cost_, v_;
  // Dijkstra scratch, reset after every augmentation (only the touched entries).
  std::vector<double> dist_, pred_cost_;
  std::vector<int> pred_row_;
  std::vector<char> final_;
  std::vector<int> touched_, scanned_;
};

}  // namespace sdfkit::metrics
