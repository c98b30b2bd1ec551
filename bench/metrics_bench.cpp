#include "bench/metrics_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/json.h"
#include "core/primitives.h"
#include "core/random.h"
#include "metrics/kdtree.h"
#include "metrics/sampling.h"

#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace sdfkit {

MetricsBenchResult run_metrics_bench(const MetricsBenchSettings& settings) {
  // CPU time of the whole process: on a machine shared with other jobs, wall time of a one-thread run mostly
  // measures the queue; CPU time measures the work.
  const auto cpu_seconds = process_cpu_seconds;
  MetricsBenchResult out;
  out.emd_points = settings.emd_points;
  out.cd_points = settings.cd_points;
  out.repeats = settings.repeats;
  // A prediction close to its ground truth, as in scoring (CD x1000 about 1-2, like a good DISN result): two
  // tori of slightly different radii, shifted, tessellated differently.
  const Mesh gt = make_torus(Vec3::Zero(), 0.65, 0.3, 128, 64);
  const Mesh pred = make_torus(Vec3(0.02, -0.01, 0.015), 0.62, 0.32, 96, 48);
  // --- EMD (one thread: the goal is stated per core) ---
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const Points a = sample_surface(pred, settings.emd_points, Rng::derived(settings.seed, 0).next()).points;
    const Points b = sample_surface(gt, settings.emd_points, Rng::derived(settings.seed, 1).next()).points;
    std::vector<double> t_exact, t_approx;
    for (int r = 0; r < settings.repeats; ++r) {
      const double c0 = cpu_seconds();
      out.exact = emd_exact(a, b);
      t_exact.push_back(cpu_seconds() - c0);
    }
    for (int r = 0; r < (settings.approx ? std::min(settings.repeats, 3) : 0); ++r) {
      const double c0 = cpu_seconds();
      out.approx = emd_approx(a, b);
      t_approx.push_back(cpu_seconds() - c0);
    }
    out.exact_cpu_seconds_median = median(t_exact);
    out.approx_ran = settings.approx;
    out.approx_cpu_seconds_median = median(t_approx);
    if (settings.hungarian) {
      const double c0 = cpu_seconds();
      out.hungarian = emd_hungarian(a, b);
      out.hungarian_cpu_seconds = cpu_seconds() - c0;
      out.hungarian_ran = true;
    }
  }
  // --- Chamfer on cd_points vs cd_points (all threads) ---
  {
    const Points a = sample_surface(pred, settings.cd_points, Rng::derived(settings.seed, 2).next()).points;
    const Points b = sample_surface(gt, settings.cd_points, Rng::derived(settings.seed, 3).next()).points;
    std::vector<double> t_cd, c_cd, t_kd, c_kd;
    double kd_max_diff = 0;
    for (int r = 0; r < settings.repeats; ++r) {  // grid evaluator and KD-tree baseline alternate: same noise for both
      auto t0 = BenchClock::now();
      double c0 = cpu_seconds();
      const PairEvaluator pair(a, b);
      out.chamfer = pair.chamfer();
      t_cd.push_back(seconds_since(t0));
      c_cd.push_back(cpu_seconds() - c0);
      // Baseline: the previous evaluator, two nanoflann KD-trees built concurrently, queries in leaf order.
      t0 = BenchClock::now();
      c0 = cpu_seconds();
      std::unique_ptr<KdTree> ta, tb;
      tbb::parallel_invoke([&] { ta = std::make_unique<KdTree>(a); }, [&] { tb = std::make_unique<KdTree>(b); });
      const std::vector<uint32_t> oa = ta->leaf_order(), ob = tb->leaf_order();
      Eigen::VectorXi ia, ib;
      Eigen::VectorXd da, db;
      tb->nearest(a, ia, da, &oa);
      ta->nearest(b, ib, db, &ob);
      t_kd.push_back(seconds_since(t0));
      c_kd.push_back(cpu_seconds() - c0);
      kd_max_diff = std::max({kd_max_diff, (da - pair.pred_to_gt_sq()).cwiseAbs().maxCoeff(),
                              (db - pair.gt_to_pred_sq()).cwiseAbs().maxCoeff()});
    }
    // Brute force on a subset of 1000 query points of each side; per-query time scaled to the full problem.
    const PairEvaluator pair(a, b);
    const long sub = std::min<long>(1000, settings.cd_points);
    double max_err = 0;
    const double c0 = cpu_seconds();
    for (long i = 0; i < sub; ++i) {
      double best = 1e300;
      for (Eigen::Index j = 0; j < b.rows(); ++j) best = std::min(best, (a.row(i) - b.row(j)).squaredNorm());
      max_err = std::max(max_err, std::abs(best - pair.pred_to_gt_sq()(i)));
    }
    const double t_brute_sub = cpu_seconds() - c0;
    out.threads = static_cast<long>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    out.wall_seconds_median = median(t_cd);
    out.cpu_seconds_median = median(c_cd);
    out.kdtree_wall_seconds_median = median(t_kd);
    out.kdtree_cpu_seconds_median = median(c_kd);
    out.kdtree_max_abs_difference = kd_max_diff;
    out.brute_force_subset = sub;
    out.brute_force_max_abs_error = max_err;
    out.brute_force_cpu_seconds_extrapolated =
        t_brute_sub * 2.0 * static_cast<double>(settings.cd_points) / static_cast<double>(sub);
  }
  return out;
}

Json metrics_bench_json(const MetricsBenchResult& r) {
  Json out;
  Json e = {{"points", r.emd_points},
            {"threads", 1},
            {"exact_cpu_seconds_median", r.exact_cpu_seconds_median},
            {"exact_bids", r.exact.bids},
            {"exact_path_scans", r.exact.path_scans},
            {"exact_total", r.exact.total},
            {"exact_gap_bound", r.exact.gap_bound},
            {"exact_rounds", r.exact.rounds},
            {"exact_edges", r.exact.edges}};
  if (r.approx_ran) {
    e["approx_cpu_seconds_median"] = r.approx_cpu_seconds_median;
    e["approx_total"] = r.approx.total;
    e["approx_over_exact"] = r.approx.total / r.exact.total;
  }
  if (r.hungarian_ran) {
    e["hungarian_cpu_seconds"] = r.hungarian_cpu_seconds;
    e["hungarian_total"] = r.hungarian.total;
    e["exact_minus_hungarian"] = r.exact.total - r.hungarian.total;
    e["speedup_vs_hungarian"] = r.hungarian_cpu_seconds / r.exact_cpu_seconds_median;
  }
  out["emd"] = e;
  out["chamfer"] = {{"points", r.cd_points},
                    {"threads", r.threads},
                    {"wall_seconds_median", r.wall_seconds_median},
                    {"cpu_seconds_median", r.cpu_seconds_median},
                    {"kdtree_wall_seconds_median", r.kdtree_wall_seconds_median},
                    {"kdtree_cpu_seconds_median", r.kdtree_cpu_seconds_median},
                    {"kdtree_max_abs_difference", r.kdtree_max_abs_difference},
                    {"wall_speedup_vs_kdtree", r.kdtree_wall_seconds_median / r.wall_seconds_median},
                    {"cd_squared", r.chamfer.cd_squared()},
                    {"cd_l1", r.chamfer.cd_l1()},
                    {"brute_force_subset", r.brute_force_subset},
                    {"brute_force_max_abs_error", r.brute_force_max_abs_error},
                    {"brute_force_cpu_seconds_extrapolated", r.brute_force_cpu_seconds_extrapolated},
                    {"cpu_speedup_vs_brute_force", r.brute_force_cpu_seconds_extrapolated / r.cpu_seconds_median}};
  return out;
}

std::string metrics_bench_text(const MetricsBenchResult& r) {
  using detail::bench_printf;
  const Json out = metrics_bench_json(r);
  const Json& e = out["emd"];
  std::string text =
      bench_printf("EMD, %ld vs %ld surface samples (two nearby tori), 1 thread, CPU seconds, median of %d:\n",
                   r.emd_points, r.emd_points, r.repeats);
  text += bench_printf("  exact (auction + shortest paths + certificate) %9.4f s  total %.9g  gap bound %.2e  "
                       "rounds %d  edges %ld  bids %ld  path scans %ld\n",
                       e["exact_cpu_seconds_median"].get<double>(), e["exact_total"].get<double>(),
                       e["exact_gap_bound"].get<double>(), e["exact_rounds"].get<int>(), e["exact_edges"].get<long>(),
                       e["exact_bids"].get<long>(), e["exact_path_scans"].get<long>());
  if (e.contains("hungarian_cpu_seconds"))
    text += bench_printf("  dense Hungarian baseline                       %9.4f s  total %.9g  (exact - Hungarian = "
                         "%.2e, speed-up %.0fx)\n",
                         e["hungarian_cpu_seconds"].get<double>(), e["hungarian_total"].get<double>(),
                         e["exact_minus_hungarian"].get<double>(), e["speedup_vs_hungarian"].get<double>());
  if (e.contains("approx_total"))
    text += bench_printf("  approx (Fan et al., DISN)                      %9.4f s  total %.9g  (%.4f x exact)\n",
                         e["approx_cpu_seconds_median"].get<double>(), e["approx_total"].get<double>(),
                         e["approx_over_exact"].get<double>());
  const Json& c = out["chamfer"];
  text += bench_printf("Chamfer, %ld vs %ld points, %ld threads, median of %d:\n", r.cd_points, r.cd_points,
                       c["threads"].get<long>(), r.repeats);
  text += bench_printf(
      "  grid evaluator (build + both directions)    %8.4f s wall, %8.4f s CPU  CD^2 %.6g  CD-L1 %.6g\n",
      c["wall_seconds_median"].get<double>(), c["cpu_seconds_median"].get<double>(), c["cd_squared"].get<double>(),
      c["cd_l1"].get<double>());
  text += bench_printf("  KD-tree baseline (nanoflann, same run)      %8.4f s wall, %8.4f s CPU  max |difference| "
                       "%.1e  wall speed-up of the grid %.2fx\n",
                       c["kdtree_wall_seconds_median"].get<double>(), c["kdtree_cpu_seconds_median"].get<double>(),
                       c["kdtree_max_abs_difference"].get<double>(), c["wall_speedup_vs_kdtree"].get<double>());
  text += bench_printf("  brute force (%ld queries, extrapolated)  %8.2f s CPU  max |error| %.1e  CPU speed-up %.0fx\n",
                       c["brute_force_subset"].get<long>(), c["brute_force_cpu_seconds_extrapolated"].get<double>(),
                       c["brute_force_max_abs_error"].get<double>(), c["cpu_speedup_vs_brute_force"].get<double>());
  return text;
}

}  // namespace sdfkit
