// `sdfkit bench render`: time per view of the rasteriser for a ~50k-triangle mesh at 137^2 and 512^2, with 1 and
// 2 threads and several supersampling factors, plus a full 24-view set with files. Medians of `reps` runs; ratios
// against s = 1 at 137^2 on one thread, measured in the same run. Results: docs/benchmarks/render.md.
#pragma once

#include "core/json_fwd.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct RenderBenchSettings {
  std::string mesh;   ///< mesh to render, used as it is (empty: a torus of exactly 50,000 triangles)
  int reps = 7;       ///< repetitions per configuration (medians are reported)
  int views = 24;     ///< views per repetition
  uint64_t seed = 1;  ///< seed of the view set
};

/// One configuration: seconds per view, medians over the repetitions.
struct RenderBenchRow {
  int size = 0, supersampling = 0, threads = 0;
  double wall = 0, cpu = 0;
  double cpu_ratio = 0;  ///< cpu over the first configuration's (s = 1 at 137^2, one thread)
};

struct RenderBenchResult {
  std::string mesh;  ///< as set ("" = the generated torus)
  long faces = 0;
  int views = 0, reps = 0;
  std::vector<RenderBenchRow> rows;
  double view_set_with_files_wall_s = 0;  ///< render_view_set with PNG + JSON files, all threads
};

RenderBenchResult run_render_bench(const RenderBenchSettings& settings);

/// What `sdfkit bench render` prints: the text report, or the JSON object.
std::string render_bench_text(const RenderBenchResult& result);
Json render_bench_json(const RenderBenchResult& result);

}  // namespace sdfkit
