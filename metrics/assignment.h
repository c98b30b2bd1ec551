// Minimum-cost perfect assignment (the combinatorial core of the exact EMD).
//  - hungarian(): the dense O(n^3) Hungarian method with potentials; the reference and the baseline.
//  - SparseAuction: Bertsekas' auction with epsilon scaling on a sparse candidate graph that can grow; a solve
//    starts from the current prices and assignment (warm start: only rows that break the phase's eps-complementary
//    slackness bid again). Optimal to within n eps on the graph; optimality for the full dense problem is certified
//    by the caller from the prices (metrics/emd.h).
#pragma once

#include <Eigen/Core>

#include <functional>
#include <utility>
#include <vector>

namespace sdfkit {

/// Rows -> columns of a minimum-cost perfect assignment of a square cost matrix (n <= a few thousand: O(n^3)).
/// `total`, when given, receives the summed cost. Throws InvalidInput if the matrix is not square or not finite.
std::vector<int> hungarian(const Eigen::MatrixXd& cost, double* total = nullptr);

/// The candidate edges of a square assignment problem, row by row, in one arena: row i's columns and costs are
/// contiguous (cols(i)[0 .. size(i)), sorted by column, one entry per column), so the solvers' inner loops stream
/// through memory instead of chasing one heap block per row. Rows that outgrow their slot move to the end of
/// the arena with twice the room (edges are only ever added), leaving the old slot unused.
class EdgeRows {
 public:
  explicit EdgeRows(int n);
  /// A whole graph at once, in compressed rows: row i's edges are cols/costs[start[i] .. start[i + 1]), which
  /// must be sorted by column without repeats (InvalidInput otherwise, as for bad columns or costs).
  EdgeRows(int n, std::vector<size_t> start, std::vector<int> cols, std::vector<double> costs);
  /// Adds (column, cost) edges to `row` (validated: column in [0, n), finite cost); a repeated column keeps its
  /// lowest cost. Returns the number of new columns.
  int add(int row, const std::vector<std::pair<int, double>>& edges);
  [[nodiscard]] int rows() const { return n_; }
  [[nodiscard]] int size(int row) const { return size_[static_cast<size_t>(row)]; }
  [[nodiscard]] const int* cols(int row) const { return col_.data() + start_[static_cast<size_t>(row)]; }
  [[nodiscard]] const double* costs(int row) const { return cost_.data() + start_[static_cast<size_t>(row)]; }
  /// Cost of edge (row, col); the edge must exist.
  [[nodiscard]] double cost(int row, int col) const;
  [[nodiscard]] long num_edges() const { return edges_; }

 private:
  int n_;
  long edges_ = 0;
  std::vector<size_t> start_;
  std::vector<int> size_, capacity_;
  std::vector<int> col_;
  std::vector<double> cost_;
  std::vector<std::pair<int, double>> scratch_;
};

/// Forward auction (Bertsekas) with epsilon scaling on a sparse bipartite graph, minimisation form: every free
/// row bids for the column j that minimises c_ij + p_j, raising p_j by the margin to its second-best column
/// plus eps. At the end of a phase every row is assigned and eps-complementary slackness holds on the graph:
/// c_i,s(i) + p_s(i) <= min_j (c_ij + p_j) + eps, so the assignment costs at most n eps more than the graph's
/// optimum. The caller checks the full (dense) problem from the prices (metrics/emd.h).
/// The graph must contain a perfect matching (ensure_perfect_matching(), or add the edges of any permutation).
class SparseAuction {
 public:
  explicit SparseAuction(int n);
  /// Starts from a graph built beforehand (no prices or assignment yet).
  explicit SparseAuction(EdgeRows graph);

  /// Adds candidate edges (column, cost) of `row`; a repeated column keeps its lowest cost. Returns the number
  /// of new edges. A row whose edges change is re-checked (and freed if it breaks eps-CS) at the next solve().
  int add_edges(int row, const std::vector<std::pair<int, double>>& edges);
  /// Makes sure a perfect matching exists in the graph (bipartite augmenting paths, unweighted): rows that cannot
  /// be matched get every column, with costs from `cost_of(row, col)`. Returns how many rows were completed.
  int ensure_perfect_matching(const std::function<double(int, int)>& cost_of);
  /// Runs epsilon-scaling phases from eps_start down to eps_final (dividing by `factor`). Each phase keeps the
  /// prices and the assignment of every row that already satisfies eps-CS at the phase's eps; the others (and
  /// unassigned rows) bid until every row is assigned. A first call therefore solves from scratch, and a call
  /// after add_edges() only re-solves around the rows the new edges made attractive.
  void solve(double eps_start, double eps_final, double factor = 8.0);

  /// c_i,s(i) + p_s(i) - min over the row's edges of (c_ij + p_j) (>= 0; infinity for an unassigned row).
  [[nodiscard]] double slack(int row) const;
  [[nodiscard]] int size() const { return n_; }
  [[nodiscard]] long num_edges() const;
  [[nodiscard]] long num_bids() const { return bids_; }
  [[nodiscard]] double eps() const { return eps_; }
  [[nodiscard]] const std::vector<int>& col_of_row() const { return col_of_row_; }
  [[nodiscard]] const std::vector<double>& prices() const { return price_; }
  [[nodiscard]] const EdgeRows& graph() const { return edges_; }

 private:
  void bid_until_assigned(std::vector<int>& queue);

  int n_;
  double eps_ = 0;
  long bids_ = 0;
  EdgeRows edges_;
  std::vector<int> col_of_row_, row_of_col_;
  std::vector<double> price_;
  std::vector<double> bid_eps_;  // eps of each row's last bid (infinity: never, or edges added since)
};

}  // namespace sdfkit

namespace sdfkit {

/// Exact minimum-cost perfect assignment on a sparse bipartite graph by successive shortest augmenting paths
/// (Dijkstra on reduced costs with column potentials, as in Jonker-Volgenant). Invariant, with the prices
/// p_j (the negated column potentials): every assigned row's edge attains min over its edges of (c_ij + p_j)
/// (complementary slackness holds exactly on the graph), so when every row is assigned the assignment is optimal
/// for the graph. Rows can be freed and edges added at any time; solve() then re-augments only the free rows,
/// from the current prices (warm start). The graph must contain a perfect matching (add the edges of any
/// permutation); a free row that cannot reach a free column throws InvalidInput.
class SparseShortestPath {
 public:
  explicit SparseShortestPath(int n);
  /// Starts from a graph built beforehand (every row free, zero prices until reset()).
  explicit SparseShortestPath(EdgeRows graph);

  /// Adds candidate edges (column, cost) of `row`; a repeated column keeps its lowest cost. Returns the number
  /// of new edges. If a new edge undercuts the row's assigned one, the row is freed (solve() re-assigns
  /// it).
  int add_edges(int row, const std::vector<std::pair<int, double>>& edges);
  /// Assigns every free row by a shortest augmenting path.
  void solve();
  /// Frees every row and starts from the given prices (e.g. an auction's): good prices make the paths short.
  void reset(const std::vector<double>& prices);

  /// c_i,s(i) + p_s(i) - min over the row's edges of (c_ij + p_j): 0 up to rounding after solve().
  [[nodiscard]] double slack(int row) const;
  [[nodiscard]] int size() const { return n_; }
  [[nodiscard]] long num_edges() const;
  /// Columns settled by Dijkstra over all augmentations (the work done).
  [[nodiscard]] long num_scanned() const { return scanned_total_; }
  [[nodiscard]] long num_augmentations() const { return augmentations_; }
  [[nodiscard]] const std::vector<int>& col_of_row() const { return col_of_row_; }
  /// p_j = -v_j: c_ij + p_j >= c_i,s(i) + p_s(i) on every graph edge of row i.
  [[nodiscard]] std::vector<double> prices() const;

 private:
  void augment(int row);
  void assign(int row, int col);

  int n_;
  long scanned_total_ = 0, augmentations_ = 0;
  EdgeRows edges_;
  std::vector<int> col_of_row_, row_of_col_;
  std::vector<double> v_;  // column potentials
  // Dijkstra workspace (reused; stamp_ marks the entries valid in the current search)
  std::vector<double> dist_;
  std::vector<int> pred_row_, stamp_, done_;
  std::vector<double> assigned_cost_;  // c_i,s(i)
  std::vector<std::pair<double, int>> heap_;
  std::vector<int> settled_;
  int search_ = 0;
};

}  // namespace sdfkit
