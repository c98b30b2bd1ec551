// `sdfkit bench metrics`: speed of the scoring kernels against their baselines, measured in the same run.
//  - exact EMD on n points (default 2048): sparse auction + shortest augmenting paths + dense certificate vs the
//    dense Hungarian method
//    (and DISN's approximate matcher), on surface samples of two different shapes;
//  - Chamfer distance on 100k vs 100k points: the grid evaluator (metrics/grid_nn.h) against the KD-tree evaluator
//    it replaced, both checked against brute force on a subset.
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/primitives.h"
#include "core/random.h"
#include "metrics/chamfer.h"
#include "metrics/emd.h"
#include "metrics/kdtree.h"
#include "metrics/sampling.h"

#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {


// CPU time of the whole process: on a machine shared with other jobs, wall time of a one-thread run mostly
// measures the queue; CPU time measures the work.
const auto cpu_seconds = process_cpu_seconds;

std::function<int()> setup_bench_metrics(CLI::App& app) {
  struct Opts {
    long emd_points = 2048;
    long cd_points = 100000;
    int repeats = 7;
    bool hungarian = true;
    bool approx = true;
    bool json = false;
    uint64_t seed = 1;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--emd-points", o->emd_points, "points per set for the EMD timings")->check(in_range(2L, 20000L));
  app.add_option("--cd-points", o->cd_points, "points per set for the Chamfer timings")
      ->check(in_range(10L, 10000000L));
  app.add_option("--repeats", o->repeats, "timed runs per measurement (the median is reported)")
      ->check(in_range(1, 1000));
  app.add_flag("!--no-hungarian", o->hungarian, "skip the dense O(n^3) Hungarian baseline (slow for n > 2000)");
  app.add_flag("!--no-approx", o->approx, "skip DISN's approximate matcher (about 2 s per run at 2048 points)");
  app.add_option("--seed", o->seed, "seed of the sampled point sets");
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    using clock = std::chrono::steady_clock;
    // A prediction close to its ground truth, as in scoring (CD x1000 about 1-2, like a good DISN result): two
    // tori of slightly different radii, shifted, tessellated differently.
    const Mesh gt = make_torus(Vec3::Zero(), 0.65, 0.3, 128, 64);
    const Mesh pred = make_torus(Vec3(0.02, -0.01, 0.015), 0.62, 0.32, 96, 48);
    Json out;
    // --- EMD (one thread: the goal is stated per core) ---
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      const Points a = sample_surface(pred, o->emd_points, Rng::derived(o->seed, 0).next()).points;
      const Points b = sample_surface(gt, o->emd_points, Rng::derived(o->seed, 1).next()).points;
      std::vector<double> t_exact, t_approx;
      EmdResult exact, approx;
      for (int r = 0; r < o->repeats; ++r) {
        const double c0 = cpu_seconds();
        exact = emd_exact(a, b);
        t_exact.push_back(cpu_seconds() - c0);
      }
      for (int r = 0; r < (o->approx ? std::min(o->repeats, 3) : 0); ++r) {
        const double c0 = cpu_seconds();
        approx = emd_approx(a, b);
        t_approx.push_back(cpu_seconds() - c0);
      }
      Json e = {{"points", o->emd_points},
                {"threads", 1},
                {"exact_cpu_seconds_median", median(t_exact)},
                {"exact_bids", exact.bids},
                {"exact_path_scans", exact.path_scans},
                {"exact_total", exact.total},
                {"exact_gap_bound", exact.gap_bound},
                {"exact_rounds", exact.rounds},
                {"exact_edges", exact.edges}};
      if (o->approx) {
        e["approx_cpu_seconds_median"] = median(t_approx);
        e["approx_total"] = approx.total;
        e["approx_over_exact"] = approx.total / exact.total;
      }
      if (o->hungarian) {
        const double c0 = cpu_seconds();
        const EmdResult h = emd_hungarian(a, b);
        const double th = cpu_seconds() - c0;
        e["hungarian_cpu_seconds"] = th;
        e["hungarian_total"] = h.total;
        e["exact_minus_hungarian"] = exact.total - h.total;
        e["speedup_vs_hungarian"] = th / median(t_exact);
      }
      out["emd"] = e;
    }
    // --- Chamfer on cd_points vs cd_points (all threads) ---
    {
      const Points a = sample_surface(pred, o->cd_points, Rng::derived(o->seed, 2).next()).points;
      const Points b = sample_surface(gt, o->cd_points, Rng::derived(o->seed, 3).next()).points;
      std::vector<double> t_cd, c_cd, t_kd, c_kd;
      ChamferResult cd;
      double kd_max_diff = 0;
      for (int r = 0; r < o->repeats; ++r) {  // grid evaluator and KD-tree baseline alternate: same noise for both
        auto t0 = clock::now();
        double c0 = cpu_seconds();
        const PairEvaluator pair(a, b);
        cd = pair.chamfer();
        t_cd.push_back(seconds_since(t0));
        c_cd.push_back(cpu_seconds() - c0);
        // Baseline: the previous evaluator, two nanoflann KD-trees built concurrently, queries in leaf order.
        t0 = clock::now();
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
      const long sub = std::min<long>(1000, o->cd_points);
      double max_err = 0;
      const double c0 = cpu_seconds();
      for (long i = 0; i < sub; ++i) {
        double best = 1e300;
        for (Eigen::Index j = 0; j < b.rows(); ++j) best = std::min(best, (a.row(i) - b.row(j)).squaredNorm());
        max_err = std::max(max_err, std::abs(best - pair.pred_to_gt_sq()(i)));
      }
      const double t_brute_sub = cpu_seconds() - c0;
      const double t_brute_full = t_brute_sub * 2.0 * static_cast<double>(o->cd_points) / static_cast<double>(sub);
      out["chamfer"] = {{"points", o->cd_points},
                        {"threads", static_cast<long>(tbb::global_control::active_value(
                                        tbb::global_control::max_allowed_parallelism))},
                        {"wall_seconds_median", median(t_cd)},
                        {"cpu_seconds_median", median(c_cd)},
                        {"kdtree_wall_seconds_median", median(t_kd)},
                        {"kdtree_cpu_seconds_median", median(c_kd)},
                        {"kdtree_max_abs_difference", kd_max_diff},
                        {"wall_speedup_vs_kdtree", median(t_kd) / median(t_cd)},
                        {"cd_squared", cd.cd_squared()},
                        {"cd_l1", cd.cd_l1()},
                        {"brute_force_subset", sub},
                        {"brute_force_max_abs_error", max_err},
                        {"brute_force_cpu_seconds_extrapolated", t_brute_full},
                        {"cpu_speedup_vs_brute_force", t_brute_full / median(c_cd)}};
    }
    if (o->json) {
      std::cout << out.dump(2) << '\n';
    } else {
      const Json& e = out["emd"];
      std::printf("EMD, %ld vs %ld surface samples (two nearby tori), 1 thread, CPU seconds, median of %d:\n",
                  o->emd_points,
                  o->emd_points, o->repeats);
      std::printf("  exact (auction + shortest paths + certificate) %9.4f s  total %.9g  gap bound %.2e  rounds %d  "
                  "edges %ld  bids %ld  path scans %ld\n",
                  e["exact_cpu_seconds_median"].get<double>(), e["exact_total"].get<double>(),
                  e["exact_gap_bound"].get<double>(), e["exact_rounds"].get<int>(), e["exact_edges"].get<long>(),
                  e["exact_bids"].get<long>(), e["exact_path_scans"].get<long>());
      if (e.contains("hungarian_cpu_seconds"))
        std::printf("  dense Hungarian baseline                       %9.4f s  total %.9g  (exact - Hungarian = %.2e, speed-up %.0fx)\n",
                    e["hungarian_cpu_seconds"].get<double>(), e["hungarian_total"].get<double>(),
                    e["exact_minus_hungarian"].get<double>(), e["speedup_vs_hungarian"].get<double>());
      if (e.contains("approx_total"))
        std::printf("  approx (Fan et al., DISN)                      %9.4f s  total %.9g  (%.4f x exact)\n",
                  e["approx_cpu_seconds_median"].get<double>(), e["approx_total"].get<double>(),
                  e["approx_over_exact"].get<double>());
      const Json& c = out["chamfer"];
      std::printf("Chamfer, %ld vs %ld points, %ld threads, median of %d:\n", o->cd_points, o->cd_points,
                  c["threads"].get<long>(), o->repeats);
      std::printf("  grid evaluator (build + both directions)    %8.4f s wall, %8.4f s CPU  CD^2 %.6g  CD-L1 %.6g\n",
                  c["wall_seconds_median"].get<double>(), c["cpu_seconds_median"].get<double>(),
                  c["cd_squared"].get<double>(), c["cd_l1"].get<double>());
      std::printf("  KD-tree baseline (nanoflann, same run)      %8.4f s wall, %8.4f s CPU  max |difference| %.1e  "
                  "wall speed-up of the grid %.2fx\n",
                  c["kdtree_wall_seconds_median"].get<double>(), c["kdtree_cpu_seconds_median"].get<double>(),
                  c["kdtree_max_abs_difference"].get<double>(), c["wall_speedup_vs_kdtree"].get<double>());
      std::printf("  brute force (%ld queries, extrapolated)  %8.2f s CPU  max |error| %.1e  CPU speed-up %.0fx\n",
                  c["brute_force_subset"].get<long>(), c["brute_force_cpu_seconds_extrapolated"].get<double>(),
                  c["brute_force_max_abs_error"].get<double>(), c["cpu_speedup_vs_brute_force"].get<double>());
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench metrics", "time exact EMD and Chamfer against their baselines", setup_bench_metrics);

}  // namespace
}  // namespace sdfkit::app
