// `sdfkit bench synth`: time to generate the procedural benchmark (in memory, per category) and to write it
// (generate + binary PLY + lists) with 1 and all threads; triangle counts and bytes. Medians of `reps` runs,
// ratios against in-memory generation on one thread measured in the same run. Results: docs/benchmarks/synth.md.
#pragma once

#include "core/json_fwd.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct SynthBenchSettings {
  int per_category = 100;  ///< shapes per category (100 = the full preset)
  int reps = 5;            ///< repetitions (medians are reported)
  int jobs = 0;            ///< threads of the parallel run (0 = all cores)
  uint64_t seed = 0;       ///< benchmark seed
};

struct SynthBenchCategory {
  std::string name;
  double ms_per_shape = 0;  ///< in-memory generation, one thread
  long triangles_min = 0;
  double triangles_median = 0;
  long triangles_max = 0;
};

/// Times in seconds (medians over the repetitions).
struct SynthBenchResult {
  size_t shapes = 0;
  int per_category = 0, reps = 0;
  std::vector<SynthBenchCategory> categories;  ///< the categories with shapes, in categories() order
  double generate_1_thread_s = 0;              ///< in-memory generation of every shape, one thread (the baseline)
  double write_1_thread_wall_s = 0, write_1_thread_cpu_s = 0;
  int write_threads = 0;
  double write_parallel_wall_s = 0, write_parallel_cpu_s = 0;
  uintmax_t bytes_written = 0;
  long triangles_min = 0, triangles_max = 0;   ///< over all shapes
  double triangles_median = 0, triangles_mean = 0;
};

SynthBenchResult run_synth_bench(const SynthBenchSettings& settings);

/// What `sdfkit bench synth` prints: the text report, or the JSON object.
std::string synth_bench_text(const SynthBenchResult& result);
Json synth_bench_json(const SynthBenchResult& result);

}  // namespace sdfkit
