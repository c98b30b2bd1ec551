#include "metrics/assignment.h"

#include "core/error.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <string>

namespace sdfkit::metrics {

std::vector<int> hungarian(const Eigen::MatrixXd& cost, double* total) {
  require(cost.rows() == cost.cols(), "hungarian: cost matrix is " + std::to_string(cost.rows()) + " x " +
                                          std::to_string(cost.cols()) + ", not square");
  require(cost.allFinite(), "hungarian: non-finite cost");
  const int n = static_cast<int>(cost.rows());
  constexpr double inf = std::numeric_limits<double>::infinity();
  // 1-based potentials u (rows), v (columns); p[j] = row matched to column j (0 = none); column 0 is the
  // virtual start of each row's search.
  std::vector<double> u(n + 1, 0.0), v(n + 1, 0.0), minv(n + 1);
  std::vector<int> p(n + 1, 0), way(n + 1, 0);
  std::vector<char> used(n + 1);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::fill(minv.begin(), minv.end(), inf);
    std::fill(used.begin(), used.end(), 0);
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= n; ++j) {
        if (used[j]) continue;
        const double cur = cost(i0 - 1, j - 1) - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= n; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {  // flip the alternating path back to the start
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> match(n);
  for (int j = 1; j <= n; ++j) match[p[j] - 1] = j - 1;
  if (total != nullptr) {
    *total = 0;
    for (int i = 0; i < n; ++i) *total += cost(i, match[i]);
  }
  return match;
}

SparseAssignment::SparseAssignment(int n)
    : n_(n),
      edges_(static_cast<size_t>(n)),
      col_of_row_(static_cast<size_t>(n), -1),
      row_of_col_(static_cast<size_t>(n), -1),
      matched_cost_(static_cast<size_t>(n), 0.0),
      v_(static_cast<size_t>(n), 0.0),
      dist_(static_cast<size_t>(n), std::numeric_limits<double>::infinity()),
      pred_cost_(static_cast<size_t>(n), 0.0),
      pred_row_(static_cast<size_t>(n), -1),
      final_(static_cast<size_t>(n), 0) {
  require(n > 0, "assignment: empty problem");
}

void SparseAssignment::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  auto& e = edges_[static_cast<size_t>(row)];
  for (const auto& [col, c] : edges) {
    require(col >= 0 && col < n_ && std::isfinite(c), "assignment: bad edge");
    e.emplace_back(col, c);
  }
  // Stable sort by column, then drop repeated columns (the first cost stays).
  std::stable_sort(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  e.erase(std::unique(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first == b.first; }), e.end());
}

long SparseAssignment::num_edges() const {
  long m = 0;
  for (const auto& e : edges_) m += static_cast<long>(e.size());
  return m;
}

void SparseAssignment::greedy_start() {
  for (int i = 0; i < n_; ++i) {
    if (col_of_row_[i] >= 0) continue;
    const auto& e = edges_[static_cast<size_t>(i)];
    if (e.empty()) continue;
    // Cheapest reduced cost c - v (prices may be non-zero after an earlier solve).
    int best = -1;
    double best_rc = std::numeric_limits<double>::infinity(), best_c = 0;
    for (const auto& [j, c] : e)
      if (c - v_[j] < best_rc) {
        best_rc = c - v_[j];
        best = j;
        best_c = c;
      }
    if (row_of_col_[best] < 0) {
      col_of_row_[i] = best;
      row_of_col_[best] = i;
      matched_cost_[i] = best_c;
    }
  }
}

void SparseAssignment::unassign(int row) {
  const int j = col_of_row_[static_cast<size_t>(row)];
  if (j < 0) return;
  row_of_col_[j] = -1;
  col_of_row_[row] = -1;
}

double SparseAssignment::row_dual(int row) const {
  const int j = col_of_row_[static_cast<size_t>(row)];
  return j < 0 ? 0.0 : matched_cost_[row] - v_[j];
}

std::vector<int> SparseAssignment::solve() {
  std::vector<int> failed;
  for (int i = 0; i < n_; ++i)
    if (col_of_row_[i] < 0 && !augment(i)) failed.push_back(i);
  return failed;
}

// One Dijkstra from the free row `r` over reduced costs c(i,k) - v(k) - u(i), where u(i) is implied by the
// assignment (the matched edge of an assigned row has reduced cost 0 and all its other edges >= 0). It stops at the
// first free column reached; prices of the columns finalised before it are lowered so that reduced costs stay >= 0
// and the new path has reduced cost 0 (Jonker & Volgenant's update).
bool SparseAssignment::augment(int r) {
  using Item = std::pair<double, int>;
  std::vector<Item> heap;
  auto push = [&](double d, int j) {
    heap.emplace_back(d, j);
    std::push_heap(heap.begin(), heap.end(), std::greater<>());
  };
  // d = distance of the row's entry point, u = the row's dual; reduced costs of rounding-level negative size are
  // clamped to 0 so that Dijkstra's order stays valid.
  auto relax = [&](int row, double d_row, double u, int j, double c) {
    const double d = d_row + std::max(0.0, c - v_[j] - u);
    if (d < dist_[j]) {
      if (dist_[j] == std::numeric_limits<double>::infinity()) touched_.push_back(j);
      dist_[j] = d;
      pred_row_[j] = row;
      pred_cost_[j] = c;
      push(d, j);
    }
  };
  // Start row: its implied u is min_j (c - v), subtracted below so that distances start at >= 0.
  double u_r = std::numeric_limits<double>::infinity();
  for (const auto& [j, c] : edges_[r]) u_r = std::min(u_r, c - v_[j]);
  for (const auto& [j, c] : edges_[r]) relax(r, 0.0, u_r, j, c);
  int found = -1;
  double dmin = 0;
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), std::greater<>());
    const auto [d, j] = heap.back();
    heap.pop_back();
    if (final_[j] || d > dist_[j]) continue;
    final_[j] = 1;
    scanned_.push_back(j);
    const int i = row_of_col_[j];
    if (i < 0) {
      found = j;
      dmin = d;
      break;
    }
    // Leaving row i through any edge (i, k): reduced cost c(i,k) - v(k) - u(i), u(i) = matched - v(j).
    const double u_i = matched_cost_[i] - v_[j];
    for (const auto& [k, c] : edges_[i])
      if (!final_[k]) relax(i, d, u_i, k, c);
  }
  if (found >= 0) {
    for (int k : scanned_) v_[k] += dist_[k] - dmin;
    int j = found;
    while (true) {
      const int i = pred_row_[j];
      const int next = col_of_row_[i];
      col_of_row_[i] = j;
      row_of_col_[j] = i;
      matched_cost_[i] = pred_cost_[j];
      if (i == r) break;
      j = next;
    }
  }
  for (int j : touched_) {
    dist_[j] = std::numeric_limits<double>::infinity();
    final_[j] = 0;
  }
  for (int j : scanned_) final_[j] = 0;
  touched_.clear();
  scanned_.clear();
  return found >= 0;
}

}  // namespace sdfkit::metrics
