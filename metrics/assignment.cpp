#include "metrics/assignment.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <string>

namespace sdfkit::metrics {

namespace {

/// Merges `edges` into one row's candidate list (validated against n columns), keeping it sorted by column with
/// one entry per column (the lowest cost given stays; a first batch already sorted and unique is taken as is).
/// Returns how many entries the row had before.
size_t merge_row_edges(std::vector<std::pair<int, double>>& e, const std::vector<std::pair<int, double>>& edges,
                       int n) {
  const size_t before = e.size();
  for (const auto& [col, c] : edges) {
    if (col < 0 || col >= n || !std::isfinite(c)) throw InvalidInput("assignment: bad edge");
    e.emplace_back(col, c);
  }
  if (before > 0 || !std::is_sorted(e.begin(), e.end())) std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first == b.first; }), e.end());
  return before;
}

}  // namespace


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

SparseAuction::SparseAuction(int n)
    : n_(n),
      edges_(static_cast<size_t>(std::max(n, 0))),
      col_of_row_(static_cast<size_t>(std::max(n, 0)), -1),
      row_of_col_(static_cast<size_t>(std::max(n, 0)), -1),
      price_(static_cast<size_t>(std::max(n, 0)), 0.0),
      bid_eps_(static_cast<size_t>(std::max(n, 0)), std::numeric_limits<double>::infinity()) {
  require(n > 0, "assignment: empty problem");
}

int SparseAuction::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  auto& e = edges_[static_cast<size_t>(row)];
  const size_t before = merge_row_edges(e, edges, n_);
  if (e.size() > before) bid_eps_[static_cast<size_t>(row)] = std::numeric_limits<double>::infinity();
  return static_cast<int>(e.size() - before);
}

long SparseAuction::num_edges() const {
  long m = 0;
  for (const auto& e : edges_) m += static_cast<long>(e.size());
  return m;
}

int SparseAuction::ensure_perfect_matching(const std::function<double(int, int)>& cost_of) {
  // Kuhn's augmenting paths (iterative DFS) from a greedy start; unweighted.
  std::vector<int> match_row(n_, -1), match_col(n_, -1), visited(n_, -1), parent_col(n_, -1);
  for (int i = 0; i < n_; ++i)
    for (const auto& [j, c] : edges_[i])
      if (match_col[j] < 0) {
        match_col[j] = i;
        match_row[i] = j;
        break;
      }
  int completed = 0;
  std::vector<std::pair<int, size_t>> stack;  // (row, next edge index)
  for (int r = 0; r < n_; ++r) {
    if (match_row[r] >= 0) continue;
    bool found = false;
    stack.assign(1, {r, 0});
    // visited[col] = r marks columns seen in this search; parent_col[col] = row that reached it.
    while (!stack.empty() && !found) {
      auto& [i, next] = stack.back();
      if (next == edges_[i].size()) {
        stack.pop_back();
        continue;
      }
      const int j = edges_[i][next++].first;
      if (visited[j] == r) continue;
      visited[j] = r;
      parent_col[j] = i;
      if (match_col[j] < 0) {
        // augment along the stack: each row on it takes the column it reached next
        int col = j;
        for (auto it = stack.rbegin(); it != stack.rend(); ++it) {
          const int row = it->first;
          const int prev = match_row[row];
          match_row[row] = col;
          match_col[col] = row;
          col = prev;
        }
        found = true;
      } else {
        stack.emplace_back(match_col[j], 0);
      }
    }
    if (!found) {
      std::vector<std::pair<int, double>> all(static_cast<size_t>(n_));
      for (int j = 0; j < n_; ++j) all[j] = {j, cost_of(r, j)};
      add_edges(r, all);
      ++completed;
      --r;  // search again from the same row: it now reaches every column
    }
  }
  return completed;
}

double SparseAuction::slack(int row) const {
  const int s = col_of_row_[static_cast<size_t>(row)];
  if (s < 0) return std::numeric_limits<double>::infinity();
  double best = std::numeric_limits<double>::infinity(), mine = best;
  for (const auto& [j, c] : edges_[static_cast<size_t>(row)]) {
    const double w = c + price_[j];
    best = std::min(best, w);
    if (j == s) mine = w;
  }
  return mine - best;
}

void SparseAuction::bid_until_assigned(std::vector<int>& queue) {
  // FIFO of free rows (deterministic order).
  size_t head = 0;
  while (head < queue.size()) {
    const int i = queue[head++];
    double best = std::numeric_limits<double>::infinity(), second = best;
    int best_j = -1;
    for (const auto& [j, c] : edges_[i]) {
      const double w = c + price_[j];
      if (w < second) {  // rarely true after the first few edges: one well-predicted branch per edge
        if (w < best) {
          second = best;
          best = w;
          best_j = j;
        } else {
          second = w;
        }
      }
    }
    // A row with one edge has no second choice: it may raise the price by anything; a large finite step
    // keeps prices finite.
    const double margin = std::isfinite(second) ? second - best : 1.0 + std::abs(best);
    price_[best_j] += margin + eps_;
    ++bids_;
    const int previous = row_of_col_[best_j];
    row_of_col_[best_j] = i;
    col_of_row_[i] = best_j;
    bid_eps_[i] = eps_;
    if (previous >= 0) {
      col_of_row_[previous] = -1;
      queue.push_back(previous);
    }
    if (head > 4096 && head * 2 > queue.size()) {  // keep the queue small
      queue.erase(queue.begin(), queue.begin() + static_cast<std::ptrdiff_t>(head));
      head = 0;
    }
  }
  queue.clear();
}

void SparseAuction::solve(double eps_start, double eps_final, double factor) {
  require(eps_final > 0 && eps_start >= eps_final && factor > 1, "auction: bad epsilon schedule");
  eps_ = eps_start;
  std::vector<int> queue;
  while (true) {
    // Free the rows that break eps-CS at this eps (all of them on a first call); the others keep their column.
    // Prices only rise, so a kept row's slack can only shrink until its column is taken from it.
    // A row's slack right after its bid is the eps of that bid, and only shrinks while it keeps its column; so
    // rows that last bid at an eps <= this one need no check (bid_eps_ is infinite for rows given new edges).
    for (int i = 0; i < n_; ++i) {
      if (col_of_row_[i] >= 0 && (bid_eps_[i] <= eps_ || slack(i) <= eps_)) continue;
      if (col_of_row_[i] >= 0) {
        row_of_col_[col_of_row_[i]] = -1;
        col_of_row_[i] = -1;
      }
      queue.push_back(i);
    }
    bid_until_assigned(queue);
    if (eps_ <= eps_final) break;
    eps_ = std::max(eps_ / factor, eps_final);
  }
}

}  // namespace sdfkit::metrics

namespace sdfkit::metrics {

SparseShortestPath::SparseShortestPath(int n)
    : n_(n),
      edges_(static_cast<size_t>(std::max(n, 0))),
      col_of_row_(static_cast<size_t>(std::max(n, 0)), -1),
      row_of_col_(static_cast<size_t>(std::max(n, 0)), -1),
      v_(static_cast<size_t>(std::max(n, 0)), 0.0),
      dist_(static_cast<size_t>(std::max(n, 0)), 0.0),
      pred_row_(static_cast<size_t>(std::max(n, 0)), -1),
      stamp_(static_cast<size_t>(std::max(n, 0)), -1),
      done_(static_cast<size_t>(std::max(n, 0)), -1),
      assigned_cost_(static_cast<size_t>(std::max(n, 0)), 0.0) {
  require(n > 0, "assignment: empty problem");
}

int SparseShortestPath::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  auto& e = edges_[static_cast<size_t>(row)];
  const size_t before = merge_row_edges(e, edges, n_);
  const int s = col_of_row_[static_cast<size_t>(row)];
  if (e.size() > before && s >= 0) {
    // Still tight? (the assigned edge must attain the row minimum of c_ij - v_j)
    double mine = 0, best = std::numeric_limits<double>::infinity();
    for (const auto& [j, c] : e) {
      best = std::min(best, c - v_[j]);
      if (j == s) mine = c - v_[j];
    }
    if (best < mine) {
      col_of_row_[static_cast<size_t>(row)] = -1;
      row_of_col_[static_cast<size_t>(s)] = -1;
    }
  }
  return static_cast<int>(e.size() - before);
}

long SparseShortestPath::num_edges() const {
  long m = 0;
  for (const auto& e : edges_) m += static_cast<long>(e.size());
  return m;
}

std::vector<double> SparseShortestPath::prices() const {
  std::vector<double> p(v_.size());
  for (size_t j = 0; j < v_.size(); ++j) p[j] = -v_[j];
  return p;
}

double SparseShortestPath::slack(int row) const {
  const int s = col_of_row_[static_cast<size_t>(row)];
  if (s < 0) return std::numeric_limits<double>::infinity();
  double best = std::numeric_limits<double>::infinity(), mine = best;
  for (const auto& [j, c] : edges_[static_cast<size_t>(row)]) {
    const double w = c - v_[j];
    best = std::min(best, w);
    if (j == s) mine = w;
  }
  return mine - best;
}

void SparseShortestPath::augment(int f) {
  // Dijkstra over columns from free row f. dist_[j] = length of the shortest alternating path f -> j in
  // reduced costs c_ij - v_j - u_i (u_i = c_i,s(i) - v_s(i) for assigned rows; for f, the raw c_fj - v_j).
  // Settled columns (done_ == search_) are in settled_, in order. Ties: smaller (dist, column) first.
  ++search_;
  heap_.clear();
  settled_.clear();
  const auto cmp = std::greater<>();
  auto relax = [&](int row, double base) {
    for (const auto& [j, c] : edges_[row]) {
      if (done_[j] == search_) continue;
      const double d = base + c - v_[j];
      if (stamp_[j] != search_ || d < dist_[j]) {
        stamp_[j] = search_;
        dist_[j] = d;
        pred_row_[j] = row;
        heap_.emplace_back(d, j);
        std::push_heap(heap_.begin(), heap_.end(), cmp);
      }
    }
  };
  relax(f, 0.0);
  int end = -1;
  double D = 0;
  while (!heap_.empty()) {
    const auto [d, j] = heap_.front();
    std::pop_heap(heap_.begin(), heap_.end(), cmp);
    heap_.pop_back();
    if (done_[j] == search_ || d > dist_[j]) continue;
    done_[j] = search_;
    settled_.push_back(j);
    const int i = row_of_col_[j];
    if (i < 0) {
      end = j;
      D = d;
      break;
    }
    // through row i (assigned to j): the path continues with i's other edges, reduced by u_i = c_ij - v_j
    relax(i, d - (assigned_cost_[i] - v_[j]));
  }
  require(end >= 0, "assignment: the candidate graph has no perfect matching");
  scanned_total_ += static_cast<long>(settled_.size());
  ++augmentations_;
  // Potentials: every settled column j gets v_j += dist_j - D (<= 0: prices only rise), which keeps every
  // reduced cost >= 0 and makes the path's edges tight.
  for (int j : settled_) v_[j] += dist_[j] - D;
  // Flip the path.
  int j = end;
  while (true) {
    const int i = pred_row_[j];
    const int next = col_of_row_[i];
    assign(i, j);
    if (i == f) break;
    j = next;
  }
}

void SparseShortestPath::assign(int i, int j) {
  col_of_row_[i] = j;
  row_of_col_[j] = i;
  const auto& e = edges_[i];
  const auto it = std::lower_bound(e.begin(), e.end(), j, [](const auto& x, int col) { return x.first < col; });
  assigned_cost_[i] = it->second;
}

void SparseShortestPath::reset(const std::vector<double>& prices) {
  require(prices.size() == v_.size(), "assignment: price vector of the wrong size");
  for (size_t j = 0; j < v_.size(); ++j) v_[j] = -prices[j];
  std::fill(col_of_row_.begin(), col_of_row_.end(), -1);
  std::fill(row_of_col_.begin(), row_of_col_.end(), -1);
}

void SparseShortestPath::solve() {
  for (int i = 0; i < n_; ++i)
    if (col_of_row_[i] < 0) augment(i);
}

}  // namespace sdfkit::metrics
