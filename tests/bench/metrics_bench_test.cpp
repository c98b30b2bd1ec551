#include "bench/metrics_bench.h"

#include "core/json.h"

#include <doctest/doctest.h>

#include <cmath>
#include <string>

using namespace sdfkit;

TEST_CASE("metrics bench at 120 points: exact EMD total equals the Hungarian total, Chamfer matches brute force") {
  MetricsBenchSettings s;
  s.emd_points = 120;
  s.cd_points = 400;
  s.repeats = 1;
  s.approx = false;
  const MetricsBenchResult r = run_metrics_bench(s);
  REQUIRE(r.hungarian_ran);
  CHECK(!r.approx_ran);
  CHECK(r.exact.n == 120);
  CHECK(r.exact.total > 0);
  CHECK(std::abs(r.exact.total - r.hungarian.total) <= 1e-9 * r.hungarian.total);
  CHECK(r.exact.gap_bound <= 1e-9 * r.exact.total);
  CHECK(r.brute_force_subset == 400);
  CHECK(r.brute_force_max_abs_error == 0.0);
  CHECK(r.kdtree_max_abs_difference == 0.0);
  CHECK(r.chamfer.cd_squared() > 0);
  const Json j = metrics_bench_json(r);
  CHECK(j["emd"]["points"] == 120);
  CHECK(j["emd"].contains("hungarian_total"));
  CHECK(!j["emd"].contains("approx_total"));
  CHECK(j["chamfer"]["points"] == 400);
}

TEST_CASE("metrics bench formatters: every measurement is in the text and the JSON, optional parts only when run") {
  MetricsBenchResult r;
  r.emd_points = 2048;
  r.cd_points = 100000;
  r.repeats = 7;
  r.exact.total = 12.5;
  r.exact.gap_bound = 1e-14;
  r.exact.rounds = 2;
  r.exact.edges = 98765;
  r.exact.bids = 4321;
  r.exact.path_scans = 321;
  r.exact_cpu_seconds_median = 0.5;
  r.threads = 2;
  r.chamfer.accuracy_sq = 0.001;
  r.chamfer.completeness_sq = 0.002;
  r.chamfer.accuracy = 0.01;
  r.chamfer.completeness = 0.03;
  r.wall_seconds_median = 0.1;
  r.cpu_seconds_median = 0.2;
  r.kdtree_wall_seconds_median = 0.4;
  r.kdtree_cpu_seconds_median = 0.6;
  r.brute_force_subset = 1000;
  r.brute_force_cpu_seconds_extrapolated = 200;

  std::string text = metrics_bench_text(r);
  CHECK(text.find("EMD, 2048 vs 2048 surface samples (two nearby tori), 1 thread, CPU seconds, median of 7:\n") == 0);
  CHECK(text.find("0.5000 s  total 12.5  gap bound 1.00e-14  rounds 2  edges 98765  bids 4321  path scans 321\n") !=
        std::string::npos);
  CHECK(text.find("Chamfer, 100000 vs 100000 points, 2 threads, median of 7:\n") != std::string::npos);
  CHECK(text.find("0.1000 s wall,   0.2000 s CPU  CD^2 0.003  CD-L1 0.02\n") != std::string::npos);
  CHECK(text.find("wall speed-up of the grid 4.00x\n") != std::string::npos);
  CHECK(text.find("brute force (1000 queries, extrapolated)    200.00 s CPU") != std::string::npos);
  CHECK(text.find("CPU speed-up 1000x\n") != std::string::npos);
  CHECK(text.find("Hungarian") == std::string::npos);
  CHECK(text.find("approx") == std::string::npos);
  Json j = metrics_bench_json(r);
  CHECK(j["emd"]["exact_edges"] == 98765);
  CHECK(j["emd"]["threads"] == 1);
  CHECK(!j["emd"].contains("hungarian_total"));
  CHECK(j["chamfer"]["cd_squared"] == doctest::Approx(0.003));
  CHECK(j["chamfer"]["wall_speedup_vs_kdtree"] == doctest::Approx(4.0));

  r.hungarian_ran = r.approx_ran = true;
  r.hungarian.total = 12.5;
  r.hungarian_cpu_seconds = 50;
  r.approx.total = 15;
  r.approx_cpu_seconds_median = 1.5;
  text = metrics_bench_text(r);
  CHECK(text.find("dense Hungarian baseline                         50.0000 s  total 12.5  (exact - Hungarian = "
                  "0.00e+00, speed-up 100x)\n") != std::string::npos);
  CHECK(text.find("approx (Fan et al., DISN)                         1.5000 s  total 15  (1.2000 x exact)\n") !=
        std::string::npos);
  j = metrics_bench_json(r);
  CHECK(j["emd"]["speedup_vs_hungarian"] == 100.0);
  CHECK(j["emd"]["approx_over_exact"] == 1.2);
}
