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

SparseAuction::SparseAuction(int n)
    : n_(n),
      edges_(static_cast<size_t>(std::max(n, 0))),
      col_of_row_(static_cast<size_t>(std::max(n, 0)), -1),
      row_of_col_(static_cast<size_t>(std::max(n, 0)), -1),
      price_(static_cast<size_t>(std::max(n, 0)), 0.0) {
  require(n > 0, "assignment: empty problem");
}

int SparseAuction::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  auto& e = edges_[static_cast<size_t>(row)];
  const size_t before = e.size();
  for (const auto& [col, c] : edges) {
    require(col >= 0 && col < n_ && std::isfinite(c), "assignment: bad edge");
    e.emplace_back(col, c);
  }
  // Stable sort by column, then drop repeated columns (the first cost stays).
  std::stable_sort(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  e.erase(std::unique(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first == b.first; }), e.end());
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

void SparseAuction::bid_until_assigned(std::vector<int> queue) {
  // FIFO of free rows (deterministic order).
  size_t head = 0;
  while (head < queue.size()) {
    const int i = queue[head++];
    const auto& e = edges_[i];
    double best = std::numeric_limits<double>::infinity(), second = best, best_c = 0;
    int best_j = -1;
    for (const auto& [j, c] : e) {
      const double w = c + price_[j];
      if (w < best) {
        second = best;
        best = w;
        best_j = j;
        best_c = c;
      } else if (w < second) {
        second = w;
      }
    }
    (void)best_c;
    // A row with one edge has no second choice: it may raise the price by anything; a large finite step
    // (a few times the eps of the first phase would do) keeps prices finite.
    const double margin = std::isfinite(second) ? second - best : 1.0 + std::abs(best);
    price_[best_j] += margin + eps_;
    ++bids_;
    const int previous = row_of_col_[best_j];
    row_of_col_[best_j] = i;
    col_of_row_[i] = best_j;
    if (previous >= 0) {
      col_of_row_[previous] = -1;
      queue.push_back(previous);
    }
    if (head > 4096 && head * 2 > queue.size()) {  // keep the queue small
      queue.erase(queue.begin(), queue.begin() + static_cast<std::ptrdiff_t>(head));
      head = 0;
    }
  }
}

void SparseAuction::solve(double eps_start, double eps_final, double factor) {
  require(eps_final > 0 && eps_start >= eps_final && factor > 1, "auction: bad epsilon schedule");
  eps_ = eps_start;
  while (true) {
    std::fill(col_of_row_.begin(), col_of_row_.end(), -1);
    std::fill(row_of_col_.begin(), row_of_col_.end(), -1);
    std::vector<int> queue(static_cast<size_t>(n_));
    for (int i = 0; i < n_; ++i) queue[i] = i;
    bid_until_assigned(std::move(queue));
    if (eps_ <= eps_final) break;
    eps_ = std::max(eps_ / factor, eps_final);
  }
}

}  // namespace sdfkit::metrics
