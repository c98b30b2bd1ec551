// Minimum-cost perfect assignment (the combinatorial core of the exact EMD).
//  - hungarian(): the dense O(n^3) Hungarian method with potentials; the reference and the baseline.
//  - SparseAuction: Bertsekas' auction with epsilon scaling on a sparse candidate graph that can grow; rows can
//    re-solved from the current prices (warm start). Optimal to within n eps; optimality for the full dense problem is
//    certified by the caller from the prices (metrics/emd.h).
#pragma once

#include <Eigen/Core>

#include <functional>
#include <utility>
#include <vector>

namespace sdfkit::metrics {

/// Rows -> columns of a minimum-cost perfect assignment of a square cost matrix (n <= a few thousand: O(n^3)).
/// `total`, when given, receives the summed cost. Throws InvalidInput if the matrix is not square or not finite.
std::vector<int> hungarian(const Eigen::MatrixXd& cost, double* total = nullptr);

/// Forward auction (Bertsekas) with epsilon scaling on a sparse bipartite graph, minimisation form: every free
/// row bids for the column j that minimises c_ij + p_j, raising p_j by the margin to its second-best column
/// plus eps. At the end of a phase every row is assigned and eps-complementary slackness holds on the graph:
/// c_i,s(i) + p_s(i) <= min_j (c_ij + p_j) + eps, so the assignment costs at most n eps more than the graph's
/// optimum. The caller checks the full (dense) problem from the prices (metrics/emd.h).
class SparseAuction {
 public:
  explicit SparseAuction(int n);

  /// Adds candidate edges (column, cost) of `row`; a column already present keeps its first cost. Returns the
  /// number of new edges.
  int add_edges(int row, const std::vector<std::pair<int, double>>& edges);
  /// Makes sure a perfect matching exists in the graph (bipartite augmenting paths, unweighted): rows that cannot
  /// be matched get every column, with costs from `cost_of(row, col)`. Returns how many rows were completed.
  int ensure_perfect_matching(const std::function<double(int, int)>& cost_of);
  /// Runs epsilon-scaling phases from eps_start down to eps_final (dividing by `factor`), each phase starting
  /// from the previous prices with every row free.
  void solve(double eps_start, double eps_final, double factor = 8.0);

  [[nodiscard]] int size() const { return n_; }
  [[nodiscard]] long num_edges() const;
  [[nodiscard]] long num_bids() const { return bids_; }
  [[nodiscard]] double eps() const { return eps_; }
  [[nodiscard]] const std::vector<int>& col_of_row() const { return col_of_row_; }
  [[nodiscard]] const std::vector<double>& prices() const { return price_; }

 private:
  void bid_until_assigned(std::vector<int> queue);

  int n_;
  double eps_ = 0;
  long bids_ = 0;
  std::vector<std::vector<std::pair<int, double>>> edges_;  // per row, sorted by column
  std::vector<int> col_of_row_, row_of_col_;
  std::vector<double> price_;
};

}  // namespace sdfkit::metrics
