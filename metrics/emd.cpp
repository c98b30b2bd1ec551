#include "metrics/emd.h"

#include "core/error.h"
#include "metrics/assignment.h"
#include "metrics/kdtree.h"
#include "metrics/sampling.h"
#include "core/simd.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if defined(__x86_64__) || defined(__SSE2__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <tuple>

namespace sdfkit {
namespace {

void check_pair(const Points& a, const Points& b) {
  require_finite_points(a, "EMD: first point set");
  require_finite_points(b, "EMD: second point set");
  require(a.rows() == b.rows(), "EMD needs two sets of the same size, got " + std::to_string(a.rows()) + " and " +
                                    std::to_string(b.rows()) + " points (resample one of them first)");
  require(a.rows() < (Eigen::Index(1) << 30), "EMD: too many points");
}

double distance(const Points& a, Eigen::Index i, const Points& b, Eigen::Index j) {
  const double dx = a(i, 0) - b(j, 0), dy = a(i, 1) - b(j, 1), dz = a(i, 2) - b(j, 2);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

}  // namespace

EmdMethod parse_emd_method(const std::string& name) {
  if (name == "exact") return EmdMethod::kExact;
  if (name == "approx") return EmdMethod::kApprox;
  throw InvalidInput("unknown EMD method '" + name + "' (expected exact or approx)");
}
std::string to_string(EmdMethod m) { return m == EmdMethod::kExact ? "exact" : "approx"; }

EmdResult emd(const Points& a, const Points& b, const EmdSettings& settings) {
  return settings.method == EmdMethod::kExact ? emd_exact(a, b, settings) : emd_approx(a, b);
}

namespace {

// Morton code of a point quantised to 21 bits per axis inside `box` (x in the lowest bit of each triple).
uint64_t morton(const Box3& box, const Vec3& p) {
  const Vec3 ext = box.extent();
  uint64_t code = 0;
  for (int d = 0; d < 3; ++d) {
    const double t = ext[d] > 0 ? (p[d] - box.lo[d]) / ext[d] : 0.0;
    const auto q = static_cast<uint64_t>(std::clamp(t, 0.0, 1.0) * 2097151.0);
    for (int bit = 0; bit < 21; ++bit) code |= ((q >> bit) & 1u) << (3 * bit + d);
  }
  return code;
}

// Indices of the rows of `p` sorted along the Morton curve of `box` (ties by index: deterministic).
std::vector<int> morton_order(const Points& p, const Box3& box) {
  std::vector<std::pair<uint64_t, int>> keyed(static_cast<size_t>(p.rows()));
  for (Eigen::Index i = 0; i < p.rows(); ++i) keyed[i] = {morton(box, p.row(i).transpose()), static_cast<int>(i)};
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> order(keyed.size());
  for (size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

using EdgeList = std::vector<std::pair<int, double>>;

// The distinct locations of a point set and the rows at each (in index order).
struct Sites {
  Points where;               // one row per site
  std::vector<int> start;     // members of site s: rows[start[s] .. start[s + 1])
  std::vector<int> rows;
  explicit Sites(const Points& p) {
    const auto n = static_cast<int>(p.rows());
    rows.resize(static_cast<size_t>(n));
    std::iota(rows.begin(), rows.end(), 0);
    auto key = [&](int i) { return std::make_tuple(p(i, 0), p(i, 1), p(i, 2)); };
    std::sort(rows.begin(), rows.end(), [&](int x, int y) { return std::make_pair(key(x), x) < std::make_pair(key(y), y); });
    for (int k = 0; k < n; ++k)
      if (k == 0 || key(rows[k]) != key(rows[k - 1])) start.push_back(k);
    start.push_back(n);
    where.resize(count(), 3);
    for (int s = 0; s < count(); ++s) where.row(s) = p.row(rows[start[s]]);
  }
  [[nodiscard]] int count() const { return static_cast<int>(start.size()) - 1; }
  [[nodiscard]] int size(int s) const { return start[s + 1] - start[s]; }
  [[nodiscard]] int member(int s, int r) const { return rows[start[s] + r]; }
};

// The dense check of the certificate: for every row i, the slack c_i,s(i) + p_s(i) - min over ALL j of
// (c_ij + p_j), and the pairs with c_ij + p_j < c_i,s(i) + p_s(i) - threshold (the most attractive
// `keep` of them, as (j, c_ij)). The n^2 pass runs in float (vectorised) with a rigorous bound E on the error of
// each c_ij + p_j; every pair the float values cannot rule out (as the row minimum or as a violation) is
// re-evaluated in double, so slacks and violations are those of the double computation.
// w[j] = |b_j - a| + price[j] in float for every j < n, and the minimum of w. The same IEEE operations in the
// same order in every version (no fused multiply-add), so all versions give the same bits; the AVX2 version is
// picked at run time on CPUs that have it (the dense check is most of the exact solver's time).
float row_costs_generic(const float* bx, const float* by, const float* bz, const float* price, int n, float ax,
                        float ay, float az, float* w) {
  float best = std::numeric_limits<float>::infinity();
  int j = 0;
#if defined(__SSE2__)
  const __m128 vx = _mm_set1_ps(ax), vy = _mm_set1_ps(ay), vz = _mm_set1_ps(az);
  __m128 vbest = _mm_set1_ps(best);
  for (; j + 4 <= n; j += 4) {
    const __m128 dx = _mm_sub_ps(_mm_loadu_ps(bx + j), vx), dy = _mm_sub_ps(_mm_loadu_ps(by + j), vy),
                 dz = _mm_sub_ps(_mm_loadu_ps(bz + j), vz);
    const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    const __m128 c = _mm_add_ps(_mm_sqrt_ps(d2), _mm_loadu_ps(price + j));
    _mm_storeu_ps(w + j, c);
    vbest = _mm_min_ps(vbest, c);
  }
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, vbest);
  for (float v : lanes) best = std::min(best, v);
#endif
  for (; j < n; ++j) {
    const float dx = bx[j] - ax, dy = by[j] - ay, dz = bz[j] - az;
    w[j] = std::sqrt((dx * dx + dy * dy) + dz * dz) + price[j];
    best = std::min(best, w[j]);
  }
  return best;
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2"))) float row_costs_avx2(const float* bx, const float* by, const float* bz,
                                                     const float* price, int n, float ax, float ay, float az,
                                                     float* w) {
  float best = std::numeric_limits<float>::infinity();
  const __m256 vx = _mm256_set1_ps(ax), vy = _mm256_set1_ps(ay), vz = _mm256_set1_ps(az);
  __m256 vbest = _mm256_set1_ps(best);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(bx + j), vx), dy = _mm256_sub_ps(_mm256_loadu_ps(by + j), vy),
                 dz = _mm256_sub_ps(_mm256_loadu_ps(bz + j), vz);
    const __m256 d2 =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    const __m256 c = _mm256_add_ps(_mm256_sqrt_ps(d2), _mm256_loadu_ps(price + j));
    _mm256_storeu_ps(w + j, c);
    vbest = _mm256_min_ps(vbest, c);
  }
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, vbest);
  for (float v : lanes) best = std::min(best, v);
  if (j < n) best = std::min(best, row_costs_generic(bx + j, by + j, bz + j, price + j, n - j, ax, ay, az, w + j));
  return best;
}
#endif

float row_costs_f(const float* bx, const float* by, const float* bz, const float* price, int n, float ax, float ay,
                  float az, float* w) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (avx2_enabled()) return row_costs_avx2(bx, by, bz, price, n, ax, ay, az, w);
#endif
  return row_costs_generic(bx, by, bz, price, n, ax, ay, az, w);
}

// Appends to `out` every j < n with w[j] <= limit, in increasing order. Nearly all entries exceed the limit, so
// 4 (SSE2, part of every x86-64 CPU) or 8 (AVX2) are compared and skipped together.
void collect_at_most_generic(const float* w, int n, float limit, std::vector<int>& out) {
  int j = 0;
#if defined(__SSE2__)
  const __m128 lim = _mm_set1_ps(limit);
  for (; j + 4 <= n; j += 4) {
    auto mask = static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(w + j), lim)));
    while (mask != 0) {
      out.push_back(j + __builtin_ctz(mask));
      mask &= mask - 1;
    }
  }
#endif
  for (; j < n; ++j)
    if (w[j] <= limit) out.push_back(j);
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2"))) void collect_at_most_avx2(const float* w, int n, float limit, std::vector<int>& out) {
  const __m256 lim = _mm256_set1_ps(limit);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    auto mask = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(w + j), lim, _CMP_LE_OQ)));
    while (mask != 0) {
      out.push_back(j + __builtin_ctz(mask));
      mask &= mask - 1;
    }
  }
  for (; j < n; ++j)
    if (w[j] <= limit) out.push_back(j);
}
#endif

void collect_at_most(const float* w, int n, float limit, std::vector<int>& out) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (avx2_enabled()) return collect_at_most_avx2(w, n, limit, out);
#endif
  collect_at_most_generic(w, n, limit, out);
}

class DenseCheck {
 public:
  // Float coordinates are taken relative to `centre` (the middle of both sets' box), so their rounding is
  // relative to the sets' extent, not to their distance from the origin.
  DenseCheck(const Points& a, const Points& b, const Vec3& centre)
      : a_(a), b_(b), n_(static_cast<int>(a.rows())), centre_(centre),
        bx_((b.col(0).array() - centre.x()).cast<float>()), by_((b.col(1).array() - centre.y()).cast<float>()),
        bz_((b.col(2).array() - centre.z()).cast<float>()), price_f_(n_), slack_(n_), violations_(n_),
        checked_col_(n_, -1), checked_price_(n_, 0.0) {
    max_coord_ = std::max((a.rowwise() - centre.transpose()).cwiseAbs().maxCoeff(),
                          (b.rowwise() - centre.transpose()).cwiseAbs().maxCoeff());
  }

  /// Forget which rows were checked (the next run checks all of them).
  void reset() { std::fill(checked_col_.begin(), checked_col_.end(), -1); }

  /// Checks the rows of assignment s with prices p; returns the number of rows with violations.
  /// Incremental: prices only rise in both solvers, so a row whose column and that column's price are those of
  /// its last check (which found no violation, at the same threshold) cannot have a violation now: its
  /// c_is + p_s is the same, every other c_ij + p_j the same or higher, and its slack can only have shrunk
  /// (the value from the last check stays an upper bound). Such rows are skipped.
  int run(const std::vector<int>& s, const std::vector<double>& p, double threshold, size_t keep) {
    // Prices are shifted by their minimum before the float conversion (slacks are shift-invariant).
    const double p0 = *std::min_element(p.begin(), p.end());
    double max_price = 0;
    for (int j = 0; j < n_; ++j) {
      price_f_[j] = static_cast<float>(p[j] - p0);
      max_price = std::max(max_price, p[j] - p0);
    }
    // |float - double| of sqrt(dx^2+dy^2+dz^2) + p: coordinate and price roundings (2^-24 relative each) and a
    // few roundings of the distance (<= 2 sqrt(3) max_coord) and of the sum; 4e-6 x (coordinates + prices)
    // covers them several times over.
    const double E = 4e-6 * (max_coord_ + max_price) + 1e-300;
    tbb::parallel_for(tbb::blocked_range<int>(0, n_, 32), [&](const tbb::blocked_range<int>& r) {
      Eigen::ArrayXf w(n_);
      std::vector<int> cand;
      for (int i = r.begin(); i != r.end(); ++i) {
        auto& v = violations_[i];
        if (checked_col_[i] == s[i] && checked_price_[i] == p[s[i]] && v.empty()) continue;
        checked_col_[i] = s[i];
        checked_price_[i] = p[s[i]];
        const auto ax = static_cast<float>(a_(i, 0) - centre_.x()), ay = static_cast<float>(a_(i, 1) - centre_.y()),
                   az = static_cast<float>(a_(i, 2) - centre_.z());
        const double best_f = row_costs_f(bx_.data(), by_.data(), bz_.data(), price_f_.data(), n_, ax, ay, az, w.data());
        const double mine = distance(a_, i, b_, s[i]) + (p[s[i]] - p0);
        // Candidates: pairs that may be the row minimum, or may undercut mine by more than the threshold.
        const auto limit = static_cast<float>(std::max(best_f + 2 * E, mine - threshold + E));
        cand.clear();
        collect_at_most(w.data(), n_, limit, cand);
        double best = mine;
        v.clear();
        for (int j : cand) {
          const double c = distance(a_, i, b_, j), wj = c + (p[j] - p0);
          best = std::min(best, wj);
          if (wj < mine - threshold) v.emplace_back(j, wj);
        }
        slack_[i] = mine - best;
        if (v.size() > keep) {
          std::partial_sort(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(keep), v.end(),
                            [](const auto& x, const auto& y) { return std::tie(x.second, x.first) < std::tie(y.second, y.first); });
          v.resize(keep);
        }
        for (auto& [j, c] : v) c = distance(a_, i, b_, j);  // back to the cost
      }
    });
    int rows = 0;
    for (const auto& v : violations_) rows += v.empty() ? 0 : 1;
    return rows;
  }

  [[nodiscard]] const EdgeList& violations(int i) const { return violations_[i]; }
  [[nodiscard]] double slack(int i) const { return slack_[i]; }
  [[nodiscard]] double worst_slack_of_violating_rows() const {
    double worst = 0;
    for (int i = 0; i < n_; ++i)
      if (!violations_[i].empty()) worst = std::max(worst, slack_[i]);
    return worst;
  }
  [[nodiscard]] double total_slack() const {
    double t = 0;
    for (double x : slack_) t += x;
    return t;
  }

 private:
  const Points& a_;
  const Points& b_;
  int n_;
  Vec3 centre_;
  Eigen::ArrayXf bx_, by_, bz_, price_f_;
  double max_coord_ = 0;
  std::vector<double> slack_;
  std::vector<EdgeList> violations_;
  std::vector<int> checked_col_;
  std::vector<double> checked_price_;
};

// The first candidate graph of the exact EMD, between SITES (distinct locations; vertex sampling with
// replacement repeats points many times, and the k nearest points would then be copies of one or two
// locations): every site's k nearest sites in the other set, both directions. The r-th copy of a site with m
// copies is joined to copies r c, ..., r c + c - 1 (mod w) of a neighbouring site with w copies,
// c = min(4, ceil(w / m)), so the copies on both sides are spread over each other. Without repeated points this
// is the plain k-NN graph. Plus the pairs of equal rank along a Morton curve through both sets: a permutation,
// so the graph always holds a perfect matching, and one whose edges cross between regions where the two sets
// have unequal mass (which k-NN edges do not). Built in flat arrays (a counting pass, then a filling pass;
// each row's columns sorted and made unique, and only then their distances computed): no per-row allocation.
// Queries run in parallel into fixed slots and rows are finished independently: the graph does not depend on
// the thread count.
EdgeRows candidate_graph(const Points& a, const Points& b, const Box3& box, int k) {
  const int n = static_cast<int>(a.rows());
  const Sites sa(a), sb(b);
  const int na = sa.count(), nb = sb.count();
  const int kf = std::min(k, nb), kb = std::min(k, na);
  std::vector<uint32_t> fwd, bwd;  // fwd[s * kf + e]: e-th nearest site of b to site s of a; bwd the reverse
  {
    const KdTree tb(sb.where, "EMD: second point set"), ta(sa.where, "EMD: first point set");
    const std::vector<uint32_t> order_a = ta.leaf_order(), order_b = tb.leaf_order();
    tb.knn_batch(sa.where, kf, fwd, &order_a);
    ta.knn_batch(sb.where, kb, bwd, &order_b);
  }
  const std::vector<int> oa = morton_order(a, box), ob = morton_order(b, box);
  // copies of `from` (m of them) against copies of `to` (w): the r-th copy gets c consecutive copies of `to`
  auto spread = [](int m, int w, int r, int q) {
    const int c = std::min({4, w, (w + m - 1) / m});
    return q < c ? static_cast<int>((static_cast<long>(r) * c + q) % w) : -1;
  };
  auto for_each_pair = [&](auto&& emit) {  // emit(row of a, column of b), every candidate, repeats included
    for (int s = 0; s < na; ++s)
      for (int e = 0; e < kf; ++e) {
        const auto t = static_cast<int>(fwd[static_cast<size_t>(s) * kf + e]);
        const int m = sa.size(s), w = sb.size(t);
        if (m == 1 && w == 1) {  // no copies (the common case): skip the divisions of spread()
          emit(sa.member(s, 0), sb.member(t, 0));
          continue;
        }
        for (int r = 0; r < m; ++r)
          for (int q = 0, x; (x = spread(m, w, r, q)) >= 0; ++q) emit(sa.member(s, r), sb.member(t, x));
      }
    for (int t = 0; t < nb; ++t)
      for (int e = 0; e < kb; ++e) {
        const auto s = static_cast<int>(bwd[static_cast<size_t>(t) * kb + e]);
        const int w = sb.size(t), m = sa.size(s);
        if (m == 1 && w == 1) {
          emit(sa.member(s, 0), sb.member(t, 0));
          continue;
        }
        for (int r = 0; r < w; ++r)
          for (int q = 0, x; (x = spread(w, m, r, q)) >= 0; ++q) emit(sa.member(s, x), sb.member(t, r));
      }
    for (int r = 0; r < n; ++r) emit(oa[r], ob[r]);
  };
  std::vector<size_t> start(static_cast<size_t>(n) + 1, 0);
  for_each_pair([&](int i, int) { ++start[i + 1]; });
  for (int i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<int> cand(start[n]);
  {
    std::vector<size_t> fill(start.begin(), start.end() - 1);
    for_each_pair([&](int i, int j) { cand[fill[i]++] = j; });
  }
  std::vector<int> kept(static_cast<size_t>(n));
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) {
      int* first = cand.data() + start[i];
      int* last = cand.data() + start[i + 1];
      std::sort(first, last);
      kept[i] = static_cast<int>(std::unique(first, last) - first);
    }
  });
  std::vector<size_t> row_start(static_cast<size_t>(n) + 1, 0);
  for (int i = 0; i < n; ++i) row_start[i + 1] = row_start[i] + static_cast<size_t>(kept[i]);
  std::vector<int> cols(row_start[n]);
  std::vector<double> costs(row_start[n]);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i)
      for (int q = 0; q < kept[i]; ++q) {
        const int j = cand[start[i] + q];
        cols[row_start[i] + q] = j;
        costs[row_start[i] + q] = distance(a, i, b, j);
      }
  });
  return EdgeRows(n, std::move(row_start), std::move(cols), std::move(costs));
}

}  // namespace

EmdResult emd_exact(const Points& a, const Points& b, const EmdSettings& settings) {
  check_pair(a, b);
  require(settings.candidates >= 1, "EMD: candidates must be >= 1");
  require(settings.tolerance > 0, "EMD: tolerance must be > 0");
  const int n = static_cast<int>(a.rows());
  const int k = std::min(settings.candidates, n);
  Box3 box;
  for (int i = 0; i < n; ++i) {
    box.extend(a.row(i).transpose());
    box.extend(b.row(i).transpose());
  }
  const double diag = box.extent().norm();
  EmdResult result;
  result.n = n;
  result.method = EmdMethod::kExact;
  if (!(diag > 0)) {  // every point at the same place
    result.match.resize(n);
    for (int i = 0; i < n; ++i) result.match[i] = i;
    result.rounds = 1;
    return result;
  }
  // A row may keep a slack up to tol_row: the certificate then bounds total - optimum by n tol_row.
  const double tol_row = settings.tolerance * diag / n;

  // 1. Candidate graph (candidate_graph above).
  EdgeRows graph = candidate_graph(a, b, box, k);
  double longest = 0;
  for (int i = 0; i < n; ++i)
    for (int q = 0; q < graph.size(i); ++q) longest = std::max(longest, graph.costs(i)[q]);
  DenseCheck check(a, b, box.center());
  const auto keep = static_cast<size_t>(4 * settings.candidates);

  // 2. Coarse prices: auction with eps-scaling down to eps_coarse, then one dense check at that eps adds the
  //    pairs the k-NN graph missed (long-range transport), and the auction settles them (warm, from a start eps
  //    well below the largest violation: a restart at the violation's size would disturb every price).
  const double eps_coarse = std::max(1e-4 * diag, tol_row);
  SparseAuction auction(std::move(graph));
  auction.solve(std::max(longest / 4, eps_coarse), eps_coarse, 8.0);
  if (check.run(auction.col_of_row(), auction.prices(), 2 * eps_coarse, keep) > 0) {
    for (int i = 0; i < n; ++i)
      if (!check.violations(i).empty()) auction.add_edges(i, check.violations(i));
    auction.solve(std::max(check.worst_slack_of_violating_rows() / 64, eps_coarse), eps_coarse, 8.0);
  }
  result.bids = auction.num_bids();

  // 3. Exact shortest augmenting paths on the graph from the auction's prices (short paths: the prices are
  //    already nearly optimal), then the certificate on the full problem: with the final prices p,
  //    u_i = min over ALL j of (c_ij + p_j) and v_j = -p_j are feasible duals, so the optimum is at least
  //    sum(u) + sum(v) and  total - optimum <= gap = sum_i [c_i,s(i) + p_s(i) - u_i]. Rows with a slack above
  //    tol_row get their violating pairs (the assignment frees them) and are re-augmented; repeat until no row
  //    has one. Then gap <= n tol_row = tolerance x diagonal.
  SparseShortestPath sap(auction.graph());  // the auction's graph, with the pairs its check added
  sap.reset(auction.prices());
  sap.solve();
  check.reset();
  for (int round = 1;; ++round) {
    const int violating = check.run(sap.col_of_row(), sap.prices(), tol_row, keep);
    bool added = false;
    for (int i = 0; i < n && violating > 0; ++i)
      if (!check.violations(i).empty() && sap.add_edges(i, check.violations(i)) > 0) added = true;
    if (!added) {  // certified (or, after rounding trouble, nothing new to add: the bound holds either way)
      result.rounds = round;
      break;
    }
    sap.solve();
  }
  result.gap_bound = check.total_slack();
  result.match = sap.col_of_row();
  for (int i = 0; i < n; ++i) result.total += distance(a, i, b, result.match[i]);
  result.edges = sap.num_edges();
  result.path_scans = sap.num_scanned();
  return result;
}

EmdResult emd_hungarian(const Points& a, const Points& b) {
  check_pair(a, b);
  const Eigen::Index n = a.rows();
  Eigen::MatrixXd cost(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) cost(i, j) = distance(a, i, b, j);
  EmdResult r;
  r.n = n;
  r.match = hungarian(cost, &r.total);
  r.total = 0;
  for (Eigen::Index i = 0; i < n; ++i) r.total += cost(i, r.match[i]);
  r.edges = n * n;
  r.rounds = 1;
  return r;
}

EmdResult emd_approx(const Points& a, const Points& b) {
  check_pair(a, b);
  const Eigen::Index n = a.rows();
  // Remaining mass of every point (1 each: equal sizes), the plan w (n x n, row-major) and one round's weights.
  std::vector<double> left_a(n, 1.0), left_b(n, 1.0), col_scale(n), col_used(n);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plan = decltype(plan)::Zero(n, n),
                                                                         w(n, n);
  Eigen::VectorXd row_used(n);
  for (int level = 8; level >= -2; --level) {
    const double sharpness = level == -2 ? 0.0 : std::pow(4.0, level);
    // 1. Each a_i spreads its remaining mass over b in proportion to exp(-sharpness d^2) x b's remaining mass.
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 32), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
        double s = 1e-9;
        for (Eigen::Index j = 0; j < n; ++j) {
          const double d = distance(a, i, b, j);
          w(i, j) = std::exp(-sharpness * d * d) * left_b[j];
          s += w(i, j);
        }
        w.row(i) *= left_a[i] / s;
      }
    });
    // 2. b_j accepts at most its remaining mass: scale its column down when it is offered more. Column sums run
    //    over rows in order (one task per column block): deterministic.
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 32), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index j = r.begin(); j != r.end(); ++j) {
        double s = 1e-9;
        for (Eigen::Index i = 0; i < n; ++i) s += w(i, j);
        col_scale[j] = std::min(left_b[j] / s, 1.0);
      }
    });
    // 3. Accept, and take the accepted mass off both sides.
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 32), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
        double s = 0;
        for (Eigen::Index j = 0; j < n; ++j) {
          w(i, j) *= col_scale[j];
          s += w(i, j);
          plan(i, j) += w(i, j);
        }
        row_used(i) = s;
      }
    });
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 32), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index j = r.begin(); j != r.end(); ++j) {
        double s = 0;
        for (Eigen::Index i = 0; i < n; ++i) s += w(i, j);
        col_used[j] = s;
      }
    });
    for (Eigen::Index i = 0; i < n; ++i) left_a[i] = std::max(left_a[i] - row_used(i), 0.0);
    for (Eigen::Index j = 0; j < n; ++j) left_b[j] = std::max(left_b[j] - col_used[j], 0.0);
  }
  EmdResult r;
  r.n = n;
  r.method = EmdMethod::kApprox;
  Eigen::VectorXd row_cost(n);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 32), [&](const tbb::blocked_range<Eigen::Index>& rr) {
    for (Eigen::Index i = rr.begin(); i != rr.end(); ++i) {
      double s = 0;
      for (Eigen::Index j = 0; j < n; ++j) s += plan(i, j) * distance(a, i, b, j);
      row_cost(i) = s;
    }
  });
  for (Eigen::Index i = 0; i < n; ++i) r.total += row_cost(i);
  return r;
}

}  // namespace sdfkit
