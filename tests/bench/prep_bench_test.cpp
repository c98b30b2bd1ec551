#include "bench/prep_bench.h"

#include "core/error.h"
#include "core/json.h"

#include <doctest/doctest.h>

#include <cmath>
#include <string>

using namespace sdfkit;

TEST_CASE("prep bench of the open box: grid within a voxel of brute force, every sign right, times per thread count") {
  PrepBenchSettings s;
  s.meshes = {std::string(SDFKIT_SOURCE_DIR) + "/data/examples/meshes/open_box.obj"};
  s.only = "open_box";  // drops the built-in 51k torus and soup
  s.repeats = 1;
  s.dense_res = 9;
  s.band_points = 300;
  s.tree_memory = true;
  int seen = 0;
  const PrepBenchResult r = run_prep_bench(s, [&](const PrepBenchRow&) { ++seen; });
  REQUIRE(r.rows.size() == 1);
  CHECK(seen == 1);
  const PrepBenchRow& row = r.rows[0];
  CHECK(row.shape == "open_box.obj");
  CHECK(row.triangles == 640);
  CHECK(row.seconds_1_thread.size() == 1);
  CHECK(row.seconds_2_threads.size() == 1);
  CHECK(row.cpu_seconds_1_thread.size() == 1);
  CHECK(row.status.active_voxels > 0);
  CHECK(row.status.sign == SignMethod::kWindingNumber);  // open: auto falls back to winding numbers
  CHECK(row.lattice_voxels == 257L * 257 * 257);
  CHECK(row.dense_voxels == 9 * 9 * 9);
  CHECK(row.dense_seconds > 0);
  CHECK(row.tree_542_mb > 0);
  CHECK(row.band_points == 300);
  const double voxel = 2.4 / 256;
  CHECK(row.band == doctest::Approx(3 * voxel));
  CHECK(row.band_points_max_abs_sdf == doctest::Approx(2 * voxel));
  CHECK(row.max_abs_error < voxel);
  CHECK(row.mean_abs_error <= row.max_abs_error);
  CHECK(row.sign_ok == 300);
  CHECK(r.dense_res == 9);
  CHECK(r.peak_rss_mb > 0);
}

TEST_CASE("prep bench: an unreadable mesh fails before any shape is timed") {
  PrepBenchSettings s;
  s.meshes = {"/nonexistent/sdfkit_prep_bench.obj"};
  int seen = 0;
  CHECK_THROWS_AS(run_prep_bench(s, [&](const PrepBenchRow&) { ++seen; }), Error);
  CHECK(seen == 0);
}

TEST_CASE("prep bench formatters: header, every row with its stages, the closing line, and the JSON") {
  PrepBenchResult r;
  r.dense_res = 257;
  r.peak_rss_mb = 321;
  PrepBenchRow a;
  a.shape = "closed torus 51k";
  a.triangles = 51200;
  a.seconds_1_thread = {1.5, 1.0, 2.0};
  a.seconds_2_threads = {0.75};
  a.cpu_seconds_1_thread = {1.25};
  a.cpu_seconds_2_threads = {1.5};
  a.status.sign = SignMethod::kPseudoNormal;
  a.status.active_voxels = 169826;
  a.status.grid_bytes = 2500000;
  a.status.gt_source = "input";
  a.status.samples.candidates = 4242;
  a.status.grid.winding_evaluations = 17;
  a.lattice_voxels = 257L * 257 * 257;
  a.dense_voxels = a.lattice_voxels;
  a.dense_seconds = 20;
  a.band_points = 1000;
  a.sign_ok = 999;
  a.mean_abs_error = 0.00001;
  a.max_abs_error = 0.0005;
  a.band = 0.028125;
  PrepBenchRow b = a;
  b.shape = "table_soup.obj";
  b.status.sign = SignMethod::kWindingNumber;
  b.tree_memory = true;
  b.tree_542_mb = 5.25;
  r.rows = {a, b};

  const std::string text = prep_bench_text(r);
  CHECK(text == prep_bench_header() + prep_bench_row_text(a) + prep_bench_row_text(b) + prep_bench_footer(r));
  CHECK(prep_bench_header().rfind("shape                     tris  sign   1thr s", 0) == 0);
  const std::string la = prep_bench_row_text(a);
  CHECK(la.rfind("closed torus 51k         51200    pn    1.500    1.250    0.750    1.500     169826    1.00%     2.50"
                 "      67.9     20.00      0.00   0.00001   0.00050   99.90%\n  stages (wall s, last 1-thread run): ",
                 0) == 0);
  CHECK(la.find("(17 probes)") != std::string::npos);
  CHECK(la.find("(4242 candidates)") != std::string::npos);
  CHECK(la.find("non-standard trees") == std::string::npos);
  const std::string lb = prep_bench_row_text(b);
  CHECK(lb.rfind("table_soup.obj           51200    wn ", 0) == 0);
  CHECK(lb.find("non-standard trees with 4^3 leaves: 5,4,2 5.25 MB") != std::string::npos);
  CHECK(prep_bench_footer(r) ==
        "voxel 0.009375, band 0.028125 (3 voxels), 32768 samples; sign pn = pseudo-normal, wn = winding number; "
        "dense baseline = exact distance + winding sign at 257^3 points; peak RSS of the process 321 MB\n");
  r.band = 0.12;
  CHECK(prep_bench_footer(r).find("band 0.120000 (--band)") != std::string::npos);
  // What a run did not measure reads "-" in the text and null in the JSON, never a zero.
  PrepBenchRow c = a;
  c.dense_seconds = 0;
  c.band_points = 0;
  c.sign_ok = 0;
  const std::string lc = prep_bench_row_text(c);
  CHECK(lc.rfind("closed torus 51k         51200    pn    1.500    1.250    0.750    1.500     169826    1.00%     2.50"
                 "      67.9         -         -         -         -        -\n", 0) == 0);
  PrepBenchResult rc = r;
  rc.rows = {c};
  const Json jc = prep_bench_json(rc);
  CHECK(jc[0]["sign_agreement"].is_null());
  CHECK(jc[0]["mean_abs_error"].is_null());

  const Json j = prep_bench_json(r);
  REQUIRE(j.size() == 2);
  CHECK(j[0]["shape"] == "closed torus 51k");
  CHECK(j[0]["median_1_thread"] == 1.5);
  CHECK(j[0]["seconds_1_thread"] == Json({1.5, 1.0, 2.0}));
  CHECK(j[0]["sign"] == "pseudo_normal");
  CHECK(j[0]["sign_agreement"] == 0.999);
  CHECK(j[0]["dense_bytes"] == 4L * 257 * 257 * 257);
  CHECK(j[0]["stage_seconds_last_run"]["sample_candidates"] == 4242);
  CHECK(j[1]["shape"] == "table_soup.obj");
  CHECK(j[1]["tree_542_mb"] == 5.25);
}
