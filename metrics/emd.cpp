#include "metrics/emd.h"

#include "core/error.h"
#include "metrics/assignment.h"
#include "metrics/kdtree.h"
#include "metrics/sampling.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace sdfkit::metrics {
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
  if (name == "exact") return EmdMethod::exact;
  if (name == "approx") return EmdMethod::approx;
  throw InvalidInput("unknown EMD method '" + name + "' (expected exact or approx)");
}
std::string to_string(EmdMethod m) { return m == EmdMethod::exact ? "exact" : "approx"; }

EmdResult emd(const Points& a, const Points& b, const EmdSettings& settings) {
  return settings.method == EmdMethod::exact ? emd_exact(a, b, settings) : emd_approx(a, b);
}

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
  result.method = EmdMethod::exact;
  if (!(diag > 0)) {  // every point at the same place
    result.match.resize(n);
    for (int i = 0; i < n; ++i) result.match[i] = i;
    result.rounds = 1;
    return result;
  }
  // eps-CS bounds the excess cost by n eps: eps_final = tolerance x diag / n bounds it by tolerance x diag.
  const double eps_final = settings.tolerance * diag / n;

  // Candidate graph: a_i's k nearest in b, and b_j's k nearest in a (as edges (i, j)). Queried in parallel into
  // per-point slots, inserted sequentially: the graph does not depend on the thread count.
  SparseAuction auction(n);
  {
    const KdTree tb(b, "EMD: second point set"), ta(a, "EMD: first point set");
    std::vector<std::vector<std::pair<int, double>>> fwd(n), bwd(n);
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i) {
        fwd[i] = tb.knn(a.row(i).transpose(), k);
        bwd[i] = ta.knn(b.row(i).transpose(), k);
      }
    });
    std::vector<std::vector<std::pair<int, double>>> rows(n);
    for (int i = 0; i < n; ++i)
      for (const auto& [j, d2] : fwd[i]) rows[i].emplace_back(j, distance(a, i, b, j));
    for (int j = 0; j < n; ++j)
      for (const auto& [i, d2] : bwd[j]) rows[i].emplace_back(j, distance(a, i, b, j));
    for (int i = 0; i < n; ++i) auction.add_edges(i, rows[i]);
  }
  auction.ensure_perfect_matching([&](int i, int j) { return distance(a, i, b, j); });
  auction.solve(std::max(diag / 4, eps_final), eps_final, 8.0);

  // Certificate on the full problem: u_i = min over ALL j of (c_ij + p_j) and v_j = -p_j are feasible duals, so
  // the optimum is >= sum(u) + sum(v) and the excess of the assignment is at most
  //   gap = sum_i [c_i,s(i) + p_s(i) - min_j (c_ij + p_j)].
  // Rows whose slack exceeds 2 eps (eps-CS broken by a pair outside the graph; the factor 2 keeps rounding in
  // the price updates from reporting edges already in the graph) get those pairs, and the auction runs again
  // (warm: prices kept). The loop also ends when no new pair could be added; the bound is exact either way.
  // The dense distance matrix, once (row-major; rows filled in parallel, each by one task).
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cost(n, n);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 16), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i)
      for (int j = 0; j < n; ++j) cost(i, j) = distance(a, i, b, j);
  });
  std::vector<std::vector<std::pair<int, double>>> violations(n);
  std::vector<double> slack(n);
  for (int round = 1;; ++round) {
    const auto& p = auction.prices();
    const auto& s = auction.col_of_row();
    const double eps = auction.eps();
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 16), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i) {
        const double mine = cost(i, s[i]) + p[s[i]];
        double best = mine;
        violations[i].clear();
        for (int j = 0; j < n; ++j) {
          const double c = cost(i, j);
          const double w = c + p[j];
          best = std::min(best, w);
          if (w < mine - 2 * eps) violations[i].emplace_back(j, c);
        }
        slack[i] = mine - best;
      }
    });
    bool any = false;
    double worst = 0;
    for (int i = 0; i < n; ++i)
      if (!violations[i].empty()) {
        // Only the most attractive few: the auction finds out whether it wants more (next round).
        auto& v = violations[i];
        const size_t keep = std::min<size_t>(v.size(), static_cast<size_t>(4 * settings.candidates));
        std::partial_sort(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(keep), v.end(),
                          [&](const auto& x, const auto& y) {
                            return x.second + p[x.first] < y.second + p[y.first] ||
                                   (x.second + p[x.first] == y.second + p[y.first] && x.first < y.first);
                          });
        v.resize(keep);
        if (auction.add_edges(i, v) > 0) {
          any = true;
          worst = std::max(worst, slack[i]);
        }
      }
    if (!any) {
      result.rounds = round;
      for (int i = 0; i < n; ++i) result.gap_bound += slack[i];
      break;
    }
    // Re-run the scaling from the size of the worst violation, warm-started from the current prices: bidding
    // directly at eps_final would need (price change / eps_final) bids.
    auction.solve(std::max(worst, eps_final), eps_final, 8.0);
  }
  result.match = auction.col_of_row();
  for (int i = 0; i < n; ++i) result.total += distance(a, i, b, result.match[i]);
  result.edges = auction.num_edges();
  result.bids = auction.num_bids();
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
  r.method = EmdMethod::approx;
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

}  // namespace sdfkit::metrics
