// `sdfkit bench metrics`: speed of the scoring kernels against their baselines, measured in the same run.
//  - exact EMD on n points (default 2048): sparse auction + shortest augmenting paths + dense certificate vs the
//    dense Hungarian method (and DISN's approximate matcher), on surface samples of two different shapes;
//  - Chamfer distance on 100k vs 100k points: the grid evaluator (metrics/grid_nn.h) against the KD-tree evaluator
//    it replaced, both checked against brute force on a subset.
#pragma once

#include "core/json_fwd.h"
#include "metrics/chamfer.h"
#include "metrics/emd.h"

#include <cstdint>
#include <string>

namespace sdfkit {

struct MetricsBenchSettings {
  long emd_points = 2048;   ///< points per set for the EMD timings
  long cd_points = 100000;  ///< points per set for the Chamfer timings
  int repeats = 7;          ///< timed runs per measurement (the median is reported)
  bool hungarian = true;    ///< time the dense O(n^3) Hungarian baseline (slow for n > 2000)
  bool approx = true;       ///< time DISN's approximate matcher (about 2 s per run at 2048 points)
  uint64_t seed = 1;        ///< seed of the sampled point sets
};

/// Times are medians over the repeats; EMD times are CPU seconds of one thread.
struct MetricsBenchResult {
  long emd_points = 0, cd_points = 0;
  int repeats = 0;
  // EMD, one thread.
  EmdResult exact;
  double exact_cpu_seconds_median = 0;
  bool approx_ran = false;
  EmdResult approx;
  double approx_cpu_seconds_median = 0;
  bool hungarian_ran = false;
  EmdResult hungarian;
  double hungarian_cpu_seconds = 0;  ///< one run
  // Chamfer, all threads.
  long threads = 0;
  ChamferResult chamfer;
  double wall_seconds_median = 0, cpu_seconds_median = 0;
  double kdtree_wall_seconds_median = 0, kdtree_cpu_seconds_median = 0;
  double kdtree_max_abs_difference = 0;  ///< KD-tree vs grid squared distances, over all runs
  long brute_force_subset = 0;           ///< query points checked against brute force
  double brute_force_max_abs_error = 0;
  double brute_force_cpu_seconds_extrapolated = 0;  ///< brute force over both full sets
};

MetricsBenchResult run_metrics_bench(const MetricsBenchSettings& settings);

/// What `sdfkit bench metrics` prints: the text report and the JSON object ({"emd": ..., "chamfer": ...}).
std::string metrics_bench_text(const MetricsBenchResult& result);
Json metrics_bench_json(const MetricsBenchResult& result);

}  // namespace sdfkit
