#include "bench/render_bench.h"

#include "core/json.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;

TEST_CASE("render bench of a small mesh: seven configurations in order, ratios against the first") {
  RenderBenchSettings s;
  s.mesh = std::string(SDFKIT_SOURCE_DIR) + "/data/examples/meshes/open_box.obj";
  s.reps = 1;
  s.views = 2;
  const RenderBenchResult r = run_render_bench(s);
  CHECK(r.faces == 640);
  CHECK(r.views == 2);
  CHECK(r.reps == 1);
  const int expected[7][3] = {{137, 1, 1}, {137, 2, 1}, {137, 3, 1}, {137, 4, 1},
                              {137, 3, 2}, {512, 3, 1}, {512, 3, 2}};
  REQUIRE(r.rows.size() == 7);
  for (int i = 0; i < 7; ++i) {
    CAPTURE(i);
    CHECK(r.rows[i].size == expected[i][0]);
    CHECK(r.rows[i].supersampling == expected[i][1]);
    CHECK(r.rows[i].threads == expected[i][2]);
    CHECK(r.rows[i].wall > 0);
    CHECK(r.rows[i].cpu > 0);
    CHECK(r.rows[i].cpu_ratio == r.rows[i].cpu / r.rows[0].cpu);
  }
  CHECK(r.rows[0].cpu_ratio == 1.0);
  CHECK(r.view_set_with_files_wall_s > 0);
}

TEST_CASE("render bench formatters: the mesh line, one line and one JSON object per configuration") {
  RenderBenchResult r;
  r.faces = 50000;
  r.views = 24;
  r.reps = 7;
  r.rows = {{137, 1, 1, 0.004, 0.004, 1.0}, {512, 3, 2, 0.025, 0.05, 12.5}};
  r.view_set_with_files_wall_s = 0.5;
  CHECK(render_bench_text(r) ==
        "mesh: torus (generated), 50000 triangles, 24 views per run, 7 runs, medians\n"
        " 137^2  s=1  threads=1      4.00 ms/view wall      4.00 ms/view cpu  24 views  0.096 s wall  cpu x1.00\n"
        " 512^2  s=3  threads=2     25.00 ms/view wall     50.00 ms/view cpu  24 views  0.600 s wall  cpu x12.50\n"
        "render_view_set (24 views, 137^2, s=3, PNG + JSON, all threads): 0.500 s wall\n");
  r.mesh = "chair.obj";
  CHECK(render_bench_text(r).rfind("mesh: chair.obj, 50000 triangles", 0) == 0);
  const Json j = render_bench_json(r);
  CHECK(j["faces"] == 50000);
  CHECK(j["views"] == 24);
  CHECK(j["reps"] == 7);
  CHECK(j["view_set_with_files_wall_s"] == 0.5);
  REQUIRE(j["rows"].size() == 2);
  CHECK(j["rows"][0]["size"] == 137);
  CHECK(j["rows"][0]["ms_per_view_wall"] == doctest::Approx(4.0));
  CHECK(j["rows"][1]["supersampling"] == 3);
  CHECK(j["rows"][1]["threads"] == 2);
  CHECK(j["rows"][1]["views_24_wall_s"] == doctest::Approx(0.6));
  CHECK(j["rows"][1]["cpu_ratio_vs_baseline"] == 12.5);
}
