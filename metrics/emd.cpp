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
  require(settings.tolerance >= 0, "EMD: tolerance must be >= 0");
  const int n = static_cast<int>(a.rows());
  const int k = std::min(settings.candidates, n);
  Box3 box;
  for (int i = 0; i < n; ++i) {
    box.extend(a.row(i).transpose());
    box.extend(b.row(i).transpose());
  }
  const double tol = settings.tolerance * std::max(box.extent().norm(), 1e-300);

  // Candidate graph: a_i's k nearest in b, and b_j's k nearest in a (as edges (i, j)). Queried in parallel into
  // per-point slots, inserted sequentially: the graph does not depend on the thread count.
  SparseAssignment solver(n);
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
    for (int i = 0; i < n; ++i) solver.add_edges(i, rows[i]);
  }
  solver.greedy_start();

  EmdResult result;
  result.n = n;
  result.method = EmdMethod::exact;
  std::vector<std::vector<std::pair<int, double>>> violations(n);
  std::vector<double> slack(n);
  for (int round = 1;; ++round) {
    // Rows without an augmenting path in the sparse graph get every column (then a path always exists).
    for (int i : solver.solve()) {
      std::vector<std::pair<int, double>> all(n);
      for (int j = 0; j < n; ++j) all[j] = {j, distance(a, i, b, j)};
      solver.add_edges(i, all);
      solver.unassign(i);
    }
    if (!solver.solve().empty()) throw Error("EMD: assignment failed on a dense row (internal error)");
    // Certificate: reduced costs of all n^2 pairs.
    const auto& v = solver.column_prices();
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 16), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i) {
        const double u = solver.row_dual(i);
        double worst = 0;
        violations[i].clear();
        for (int j = 0; j < n; ++j) {
          const double c = distance(a, i, b, j);
          const double rc = c - u - v[j];
          if (rc < -tol) violations[i].emplace_back(j, c);
          worst = std::min(worst, rc);
        }
        slack[i] = worst;
      }
    });
    bool any = false;
    for (int i = 0; i < n; ++i)
      if (!violations[i].empty()) {
        any = true;
        solver.add_edges(i, violations[i]);
        solver.unassign(i);
      }
    if (!any) {
      result.rounds = round;
      double worst = 0;
      for (int i = 0; i < n; ++i) worst = std::min(worst, slack[i]);
      result.gap_bound = -worst * n;
      break;
    }
  }
  result.match = solver.col_of_row();
  for (int i = 0; i < n; ++i) {
    const int j = result.match[i];
    // Matched edges have reduced cost 0 up to rounding; add what rounding left to the bound.
    result.gap_bound += std::abs(solver.assigned_cost(i) - solver.row_dual(i) - solver.column_prices()[j]);
    result.total += distance(a, i, b, j);
  }
  result.edges = solver.num_edges();
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
