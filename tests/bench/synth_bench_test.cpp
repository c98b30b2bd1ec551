#include "bench/synth_bench.h"

#include "core/json.h"
#include "synth/categories.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;

TEST_CASE("synth bench at one shape per category: every category, its triangle counts, bytes written") {
  SynthBenchSettings s;
  s.per_category = 1;
  s.reps = 1;
  s.jobs = 2;
  const SynthBenchResult r = run_synth_bench(s);
  CHECK(r.shapes == categories().size());
  REQUIRE(r.categories.size() == categories().size());
  long lo = 1L << 60, hi = 0;
  for (size_t c = 0; c < r.categories.size(); ++c) {
    const SynthBenchCategory& cat = r.categories[c];
    CAPTURE(cat.name);
    CHECK(cat.name == categories()[c].name);
    CHECK(cat.triangles_min > 0);
    CHECK(cat.triangles_min == cat.triangles_max);  // one shape each
    CHECK(cat.triangles_median == double(cat.triangles_min));
    lo = std::min(lo, cat.triangles_min);
    hi = std::max(hi, cat.triangles_max);
  }
  CHECK(r.triangles_min == lo);
  CHECK(r.triangles_max == hi);
  CHECK(r.triangles_min <= r.triangles_median);
  CHECK(r.triangles_median <= r.triangles_max);
  CHECK(r.write_threads == 2);
  CHECK(r.bytes_written > 0);
  CHECK(r.generate_1_thread_s > 0);
}

TEST_CASE("synth bench formatters: the summary lines, one line and one JSON object per category") {
  SynthBenchResult r;
  r.shapes = 200;
  r.per_category = 100;
  r.reps = 5;
  r.categories = {{"plane", 0.5, 1000, 1384, 2000}, {"watercraft", 0.25, 108, 120, 2820}};
  r.generate_1_thread_s = 2;
  r.write_1_thread_wall_s = 4;
  r.write_1_thread_cpu_s = 3.5;
  r.write_threads = 2;
  r.write_parallel_wall_s = 2.5;
  r.write_parallel_cpu_s = 4.5;
  r.bytes_written = 12345678;
  r.triangles_min = 108;
  r.triangles_max = 2820;
  r.triangles_median = 700;
  r.triangles_mean = 1186.25;
  CHECK(synth_bench_text(r) ==
        "200 shapes (100 per category), 5 runs, medians; baseline = in-memory generation on 1 thread\n"
        "category      ms/shape    tri min tri median    tri max\n"
        "plane            0.500       1000       1384       2000\n"
        "watercraft       0.250        108        120       2820\n"
        "generate only, 1 thread:           2.000 s  (x1.00)\n"
        "write (gen + PLY), 1 thread:       4.000 s wall, 3.500 s cpu  (x2.00)\n"
        "write (gen + PLY), 2 threads:      2.500 s wall, 4.500 s cpu  (x1.25; speed-up x1.60)\n"
        "written: 12.3 MB; triangles per shape min 108, median 700, mean 1186, max 2820\n");
  const Json j = synth_bench_json(r);
  CHECK(j["shapes"] == 200);
  REQUIRE(j["categories"].size() == 2);
  CHECK(j["categories"][0]["category"] == "plane");
  CHECK(j["categories"][1]["category"] == "watercraft");
  CHECK(j["categories"][1]["triangles_max"] == 2820);
  CHECK(j["write_1_thread_over_generate"] == 2.0);
  CHECK(j["parallel_speedup"] == 1.6);
  CHECK(j["bytes_written"] == 12345678);
  CHECK(j["triangles_mean"] == 1186.25);
}
