#include "bench/extract_bench.h"

#include "core/json.h"

#include <doctest/doctest.h>

#include <cmath>
#include <string>

using namespace sdfkit;

TEST_CASE("extract bench at 33^3: every method gives the dense mesh, adaptive evaluates fewer points than dense") {
  ExtractBenchSettings s;
  s.resolutions = {33};
  s.runs = 1;
  s.samples = 1000;
  int seen = 0;
  const ExtractBenchResult r = run_extract_bench(s, [&](const ExtractBenchRow&) { ++seen; });
  REQUIRE(r.rows.size() == 8);  // 2 shapes x 4 methods
  CHECK(seen == 8);
  const char* methods[] = {"dense", "sparse", "adaptive", "signchange"};
  for (size_t i = 0; i < r.rows.size(); ++i) {
    const ExtractBenchRow& row = r.rows[i];
    CAPTURE(row.shape);
    CAPTURE(row.method);
    CHECK(row.shape == (i < 4 ? "sphere" : "chair"));
    CHECK(row.method == methods[i % 4]);
    CHECK(row.resolution == 33);
    CHECK(row.dense_evaluations == 33.0 * 33 * 33);
    CHECK(row.identical);
    CHECK(row.faces > 0);
    CHECK(row.faces == r.rows[i - i % 4].faces);
    CHECK(row.cd_to_dense_x1000 < 1e-12);
    CHECK(row.mean_abs_sdf < 0.02);  // a voxel is 2.1 / 32 = 0.066
  }
  for (size_t base : {size_t(0), size_t(4)}) {
    const ExtractBenchRow& dense = r.rows[base];
    const ExtractBenchRow& adaptive = r.rows[base + 2];
    CHECK(dense.evaluations == 33.0 * 33 * 33);
    CHECK(adaptive.evaluations < dense.evaluations);
    CHECK(r.rows[base + 1].evaluations < dense.evaluations);  // the band's active voxels
    CHECK(adaptive.coarse_resolution == 17);
    CHECK(adaptive.level_cells.size() == 2);  // 17 -> 33
    CHECK(std::isnan(adaptive.eval_seconds));
    CHECK(std::abs(r.rows[base + 3].area_ratio_to_dense - 1.0) < 1e-12);
  }
}

TEST_CASE("extract bench formatters: the text table and the JSON hold every row") {
  ExtractBenchResult r;
  ExtractBenchRow a;
  a.shape = "sphere";
  a.resolution = 65;
  a.method = "dense";
  a.evaluations = a.dense_evaluations = 65.0 * 65 * 65;
  a.eval_seconds = 0.25;
  a.mc_seconds = 0.5;
  a.total_seconds = 0.75;
  a.identical = true;
  a.cd_to_dense_x1000 = 0;
  a.mean_abs_sdf = 0.00125;
  a.faces = 1234;
  a.vertices = 619;
  a.runs = 3;
  ExtractBenchRow b = a;
  b.shape = "chair";
  b.method = "adaptive";
  b.evaluations = 27462;
  b.eval_seconds = b.mc_seconds = std::nan("");
  b.total_seconds = 0.125;
  b.identical = false;
  b.cd_to_dense_x1000 = std::nan("");
  b.level_cells = {4096, 1200};
  b.level_evaluations = {4913, 22549};
  b.coarse_resolution = 17;
  b.speedup_vs_dense = 6.0;
  r.rows = {a, b};

  const std::string text = extract_bench_text(r);
  CHECK(text.rfind(extract_bench_header(), 0) == 0);
  CHECK(text == extract_bench_header() + extract_bench_row_text(a) + extract_bench_row_text(b));
  CHECK(extract_bench_row_text(a) ==
        "sphere     65 dense            274625  100.00%     0.2500     0.5000     0.7500       yes           0"
        "      0.00125\n");
  CHECK(extract_bench_row_text(b) ==
        "chair      65 adaptive          27462   10.00%        nan        nan     0.1250        NO         nan"
        "      0.00125\n");

  const Json j = extract_bench_json(r);
  REQUIRE(j.is_array());
  REQUIRE(j.size() == 2);
  CHECK(j[0]["shape"] == "sphere");
  CHECK(j[0]["method"] == "dense");
  CHECK(j[0]["eval_seconds_median"] == 0.25);
  CHECK(j[0]["mc_seconds_median"] == 0.5);
  CHECK(j[0]["seconds_median"] == 0.75);
  CHECK(j[0]["faces"] == 1234);
  CHECK(j[0]["cd_to_dense_x1000"] == 0.0);
  CHECK(!j[0].contains("level_cells"));
  CHECK(j[1]["shape"] == "chair");
  CHECK(j[1]["method"] == "adaptive");
  CHECK(j[1]["evaluation_fraction"] == doctest::Approx(27462 / 274625.0));
  CHECK(j[1]["cd_to_dense_x1000"].is_null());
  CHECK(!j[1].contains("eval_seconds_median"));
  CHECK(j[1]["level_cells"] == Json({4096, 1200}));
  CHECK(j[1]["coarse_resolution"] == 17);
  CHECK(j[1]["speedup_vs_dense"] == 6.0);
  CHECK(j[1]["identical_to_dense"] == false);
}
