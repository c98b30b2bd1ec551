#include "metrics/assignment.h"

#include "core/error.h"
#include "core/simd.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <string>

namespace sdfkit {

namespace {

/// How much more row `row`'s own column `s` costs than its best edge, an edge's cost being its c_q + price(col_q):
/// 0 when the assignment is optimal for the row. Infinity for an unassigned row (s < 0).
template <typename Price>
double row_slack(const EdgeRows& edges, int row, int s, Price price) {
  if (s < 0) return std::numeric_limits<double>::infinity();
  double best = std::numeric_limits<double>::infinity(), mine = best;
  const int* cols = edges.cols(row);
  const double* costs = edges.costs(row);
  for (int q = 0, m = edges.size(row); q < m; ++q) {
    const double w = costs[q] + price(cols[q]);
    best = std::min(best, w);
    if (cols[q] == s) mine = w;
  }
  return mine - best;
}

// The best and second-best value of c_q + price[col_q] over one row's edges q = 0 .. m-1, and the column of the
// best (the first one in edge order among equal values). `best`/`second`/`best_j` hold the state of the edges
// before (infinity/infinity/-1 to start), so a row can be scanned in pieces: the state after a prefix is
// (minimum, second-smallest value counted with multiplicity, first argmin) of that prefix, whatever the order
// of evaluation inside it. That is what makes the 4-lane version give the same result as this loop.
void best_two_generic(const int* cols, const double* costs, int m, const double* price, double& best,
                      double& second, int& best_j) {
  for (int q = 0; q < m; ++q) {
    const double w = costs[q] + price[cols[q]];
    if (w < second) {  // rarely true after the first few edges
      if (w < best) {
        second = best;
        best = w;
        best_j = cols[q];
      } else {
        second = w;
      }
    }
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
// Four lanes (edges q = l mod 4), branch-free: the scalar loop's data-dependent branch mispredicts several times
// per row (the bidding loop was a third of the exact EMD's time). Lanes are merged into the prefix state, the
// remainder goes through the scalar loop. The prices are loaded one by one: an AVX2 gather was slower
// (measured 45 against 38.5 ms for the whole 2048-point EMD), probably because each bid reads prices that the
// previous bids have just written, which gathers do not take from the store buffer as plain loads do.
__attribute__((target("avx2"))) void best_two_avx2(const int* cols, const double* costs, int m, const double* price,
                                                   double& best, double& second, int& best_j) {
  const int m4 = m & ~3;
  if (m4 > 0) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    __m256d vbest = _mm256_set1_pd(kInf), vsecond = vbest;
    __m256i vj = _mm256_set1_epi64x(-1);
    for (int q = 0; q < m4; q += 4) {
      const __m128i c = _mm_loadu_si128(reinterpret_cast<const __m128i*>(cols + q));
      const __m256d pr = _mm256_set_pd(price[cols[q + 3]], price[cols[q + 2]], price[cols[q + 1]], price[cols[q]]);
      const __m256d w = _mm256_add_pd(_mm256_loadu_pd(costs + q), pr);
      const __m256d lt = _mm256_cmp_pd(w, vbest, _CMP_LT_OQ);
      vsecond = _mm256_min_pd(vsecond, _mm256_max_pd(vbest, w));
      vbest = _mm256_blendv_pd(vbest, w, lt);
      vj = _mm256_castpd_si256(_mm256_blendv_pd(_mm256_castsi256_pd(vj),
                                                _mm256_castsi256_pd(_mm256_cvtepi32_epi64(c)), lt));
    }
    alignas(32) double b[4], s2[4];
    alignas(32) int64_t j[4];
    _mm256_store_pd(b, vbest);
    _mm256_store_pd(s2, vsecond);
    _mm256_store_si256(reinterpret_cast<__m256i*>(j), vj);
    // Merge lanes and the earlier state: minimum (ties: the smallest column, which is the first in edge
    // order since a row's columns ascend), and the second-smallest value with multiplicity.
    for (int l = 0; l < 4; ++l) {
      const double v = b[l];
      if (v < best || (v == best && j[l] < best_j)) {
        second = std::min(best, second);
        best = v;
        best_j = static_cast<int>(j[l]);
      } else {
        second = std::min(second, v);
      }
      second = std::min(second, s2[l]);
    }
  }
  best_two_generic(cols + m4, costs + m4, m - m4, price, best, second, best_j);
}
#endif

void best_two(const int* cols, const double* costs, int m, const double* price, double& best, double& second,
              int& best_j) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (avx2_enabled()) return best_two_avx2(cols, costs, m, price, best, second, best_j);
#endif
  best_two_generic(cols, costs, m, price, best, second, best_j);
}

}  // namespace

EdgeRows::EdgeRows(int n)
    : n_(std::max(n, 0)),
      start_(static_cast<size_t>(n_), 0),
      size_(static_cast<size_t>(n_), 0),
      capacity_(static_cast<size_t>(n_), 0) {}

EdgeRows::EdgeRows(int n, std::vector<size_t> start, std::vector<int> cols, std::vector<double> costs)
    : n_(std::max(n, 0)), col_(std::move(cols)), cost_(std::move(costs)) {
  require(start.size() == static_cast<size_t>(n_) + 1 && start.front() == 0 && start.back() == col_.size() &&
              cost_.size() == col_.size(),
          "assignment: inconsistent compressed rows");
  start_.assign(start.begin(), start.end() - 1);
  size_.resize(static_cast<size_t>(n_));
  for (int i = 0; i < n_; ++i) {
    require(start[i + 1] >= start[i], "assignment: inconsistent compressed rows");
    size_[i] = static_cast<int>(start[i + 1] - start[i]);
    for (size_t q = start[i]; q < start[i + 1]; ++q)
      if (col_[q] < 0 || col_[q] >= n_ || !std::isfinite(cost_[q]) || (q > start[i] && col_[q] <= col_[q - 1]))
        throw InvalidInput("assignment: bad edge");
  }
  capacity_ = size_;
  edges_ = static_cast<long>(col_.size());
}

int EdgeRows::add(int row, const std::vector<std::pair<int, double>>& edges) {
  require(row >= 0 && row < n_, "assignment: bad row");
  for (const auto& [col, c] : edges)
    if (col < 0 || col >= n_ || !std::isfinite(c)) throw InvalidInput("assignment: bad edge");
  // The row's edges and the new ones, sorted by (column, cost): the first of each column is its lowest cost.
  const auto r = static_cast<size_t>(row);
  const int before = size_[r];
  scratch_.clear();
  for (int q = 0; q < before; ++q) scratch_.emplace_back(col_[start_[r] + q], cost_[start_[r] + q]);
  scratch_.insert(scratch_.end(), edges.begin(), edges.end());
  if (before > 0 || !std::is_sorted(scratch_.begin(), scratch_.end())) std::sort(scratch_.begin(), scratch_.end());
  scratch_.erase(std::unique(scratch_.begin(), scratch_.end(), [](const auto& x, const auto& y) { return x.first == y.first; }),
                 scratch_.end());
  const auto m = static_cast<int>(scratch_.size());
  if (m > capacity_[r]) {  // move to the end of the arena
    const int cap = before == 0 ? m : std::max(m, 2 * capacity_[r]);
    start_[r] = col_.size();
    capacity_[r] = cap;
    col_.resize(col_.size() + static_cast<size_t>(cap));
    cost_.resize(cost_.size() + static_cast<size_t>(cap));
  }
  for (int q = 0; q < m; ++q) {
    col_[start_[r] + q] = scratch_[q].first;
    cost_[start_[r] + q] = scratch_[q].second;
  }
  size_[r] = m;
  edges_ += m - before;
  return m - before;
}

double EdgeRows::cost(int row, int col) const {
  const int* c = cols(row);
  const int* it = std::lower_bound(c, c + size(row), col);
  require(it != c + size(row) && *it == col, "assignment: no such edge");
  return costs(row)[it - c];
}


std::vector<int> hungarian(const Eigen::MatrixXd& cost, double* total) {
  require(cost.rows() == cost.cols(), "hungarian: cost matrix is " + std::to_string(cost.rows()) + " x " +
                                          std::to_string(cost.cols()) + ", not square");
  require(cost.allFinite(), "hungarian: non-finite cost");
  const int n = static_cast<int>(cost.rows());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // 1-based potentials u (rows), v (columns); p[j] = row matched to column j (0 = none); column 0 is the
  // virtual start of each row's search.
  std::vector<double> u(n + 1, 0.0), v(n + 1, 0.0), minv(n + 1);
  std::vector<int> p(n + 1, 0), way(n + 1, 0);
  std::vector<char> used(n + 1);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::fill(minv.begin(), minv.end(), kInf);
    std::fill(used.begin(), used.end(), 0);
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = kInf;
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

SparseAuction::SparseAuction(int n) : SparseAuction(EdgeRows(n)) {}

SparseAuction::SparseAuction(EdgeRows graph)
    : n_(graph.rows()),
      edges_(std::move(graph)),
      col_of_row_(static_cast<size_t>(n_), -1),
      row_of_col_(static_cast<size_t>(n_), -1),
      price_(static_cast<size_t>(n_), 0.0),
      bid_eps_(static_cast<size_t>(n_), std::numeric_limits<double>::infinity()) {
  require(n_ > 0, "assignment: empty problem");
}

int SparseAuction::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  const int added = edges_.add(row, edges);
  if (added > 0) bid_eps_[static_cast<size_t>(row)] = std::numeric_limits<double>::infinity();
  return added;
}

long SparseAuction::num_edges() const { return edges_.num_edges(); }

int SparseAuction::ensure_perfect_matching(const std::function<double(int, int)>& cost_of) {
  // Kuhn's augmenting paths (iterative DFS) from a greedy start; unweighted.
  std::vector<int> match_row(n_, -1), match_col(n_, -1), visited(n_, -1), parent_col(n_, -1);
  for (int i = 0; i < n_; ++i)
    for (int q = 0; q < edges_.size(i); ++q)
      if (const int j = edges_.cols(i)[q]; match_col[j] < 0) {
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
      if (next == static_cast<size_t>(edges_.size(i))) {
        stack.pop_back();
        continue;
      }
      const int j = edges_.cols(i)[next++];
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
  return row_slack(edges_, row, col_of_row_[static_cast<size_t>(row)], [&](int j) { return price_[j]; });
}

void SparseAuction::bid_until_assigned(std::vector<int>& queue) {
  // FIFO of free rows (deterministic order).
  size_t head = 0;
  while (head < queue.size()) {
    const int i = queue[head++];
    double best = std::numeric_limits<double>::infinity(), second = best;
    int best_j = -1;
    best_two(edges_.cols(i), edges_.costs(i), edges_.size(i), price_.data(), best, second, best_j);
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

}  // namespace sdfkit

namespace sdfkit {

SparseShortestPath::SparseShortestPath(int n) : SparseShortestPath(EdgeRows(n)) {}

SparseShortestPath::SparseShortestPath(EdgeRows graph)
    : n_(graph.rows()),
      edges_(std::move(graph)),
      col_of_row_(static_cast<size_t>(n_), -1),
      row_of_col_(static_cast<size_t>(n_), -1),
      v_(static_cast<size_t>(n_), 0.0),
      dist_(static_cast<size_t>(n_), 0.0),
      pred_row_(static_cast<size_t>(n_), -1),
      stamp_(static_cast<size_t>(n_), -1),
      done_(static_cast<size_t>(n_), -1),
      assigned_cost_(static_cast<size_t>(n_), 0.0) {
  require(n_ > 0, "assignment: empty problem");
}

int SparseShortestPath::add_edges(int row, const std::vector<std::pair<int, double>>& edges) {
  const int added = edges_.add(row, edges);
  const int s = col_of_row_[static_cast<size_t>(row)];
  if (added > 0 && s >= 0) {
    // Still tight? (the assigned edge must attain the row minimum of c_ij - v_j)
    double mine = 0, best = std::numeric_limits<double>::infinity();
    const int* cols = edges_.cols(row);
    const double* costs = edges_.costs(row);
    for (int q = 0, m = edges_.size(row); q < m; ++q) {
      best = std::min(best, costs[q] - v_[cols[q]]);
      if (cols[q] == s) mine = costs[q] - v_[cols[q]];
    }
    if (best < mine) {
      col_of_row_[static_cast<size_t>(row)] = -1;
      row_of_col_[static_cast<size_t>(s)] = -1;
    }
  }
  return added;
}

long SparseShortestPath::num_edges() const { return edges_.num_edges(); }

std::vector<double> SparseShortestPath::prices() const {
  std::vector<double> p(v_.size());
  for (size_t j = 0; j < v_.size(); ++j) p[j] = -v_[j];
  return p;
}

double SparseShortestPath::slack(int row) const {
  return row_slack(edges_, row, col_of_row_[static_cast<size_t>(row)], [&](int j) { return -v_[j]; });
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
    const int* cols = edges_.cols(row);
    const double* costs = edges_.costs(row);
    for (int q = 0, m = edges_.size(row); q < m; ++q) {
      const int j = cols[q];
      const double c = costs[q];
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
  assigned_cost_[i] = edges_.cost(i, j);
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

}  // namespace sdfkit
