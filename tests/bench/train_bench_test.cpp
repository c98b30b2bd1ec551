#include "bench/train_bench.h"

#include "core/error.h"
#include "core/json.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;

TEST_CASE("train bench configurations: shipped, disn and pose, found by name") {
  const std::vector<TrainBenchConfig> all = train_bench_configs();
  REQUIRE(all.size() == 3);
  CHECK(all[0].name == "shipped");
  CHECK(all[1].name == "disn");
  CHECK(all[2].name == "pose");
  CHECK(!all[0].pose);
  CHECK(all[2].pose);
  CHECK(all[2].batch == 16);
  CHECK(all[1].sdf.first_stride == 2);
  // `shipped` is the shipped model's last-stage network (mask channel, mirror features); `disn` is DISN's (RGB).
  CHECK(all[0].sdf.input_channels == 4);
  CHECK(all[0].sdf.mirror_features);
  CHECK(all[1].sdf.input_channels == 3);
  CHECK_FALSE(all[1].sdf.mirror_features);
  CHECK(TrainBenchSettings().configs.size() == 3);
  CHECK(TrainBenchSettings().threads == std::vector<int>{1, 2});
  REQUIRE(find_train_bench_config("disn").has_value());
  CHECK(find_train_bench_config("disn")->description == all[1].description);
  CHECK(!find_train_bench_config("bogus").has_value());
}

TEST_CASE("train bench refuses an empty run and thread counts outside 1 to 256 before any work") {
  TrainBenchSettings s;
  s.data = "/nonexistent/sdfkit_train_bench";
  s.configs.clear();
  CHECK_THROWS_AS(run_train_bench(s), InvalidInput);
  s = TrainBenchSettings();
  s.data = "/nonexistent/sdfkit_train_bench";
  s.threads = {0};
  CHECK_THROWS_AS(run_train_bench(s), InvalidInput);
}

TEST_CASE("train bench formatters: the peaks, one table line and one JSON object per run") {
  TrainBenchResult r;
  r.cpu = "Test CPU";
  r.hardware_threads = 4;
  r.gemm_n = 256;
  r.reps = 3;
  r.gemm_peak_gflops = {{1, 50.0}, {2, 100.0}};
  r.configs = {train_bench_configs()[2]};
  TrainBenchRun a;
  a.config = "pose";
  a.threads = 1;
  a.steps = 5;
  a.seconds_per_step = 0.5;
  a.cpu_seconds_per_step = 0.25;
  a.gflop_per_step = 10;
  TrainBenchRun b = a;
  b.threads = 2;
  b.seconds_per_step = 0.25;
  b.cpu_seconds_per_step = 0.5;
  r.runs = {a, b};
  CHECK(train_bench_text(r) ==
        "Test CPU, 4 hardware threads\n"
        "float32 GEMM peak, 1 thread (256 x 256, median of 3, wall): 50.0 GFLOP/s\n"
        "float32 GEMM peak, 2 threads (256 x 256, median of 3, wall): 100.0 GFLOP/s\n"
        "config   threads     s/step CPU s/step cores busy GFLOP/step   GFLOP/s  of peak\n"
        "pose           1      0.500      0.250       0.50       10.0      20.0      40%\n"
        "pose           2      0.250      0.500       2.00       10.0      40.0      40%\n");
  const Json j = train_bench_json(r);
  CHECK(j["cpu"] == "Test CPU");
  CHECK(j["hardware_threads"] == 4);
  CHECK(j["gemm_n"] == 256);
  CHECK(j["gemm_peak_gflops"]["1"] == 50.0);
  CHECK(j["gemm_peak_gflops"]["2"] == 100.0);
  REQUIRE(j["configs"].size() == 1);
  CHECK(j["configs"][0]["config"] == "pose");
  REQUIRE(j["runs"].size() == 2);
  CHECK(j["runs"][0]["peak_gflops"] == 50.0);
  CHECK(j["runs"][1]["peak_gflops"] == 100.0);
  CHECK(j["runs"][1]["gflops"] == 40.0);
  CHECK(j["runs"][1]["fraction_of_peak"] == 0.4);
  CHECK(j["runs"][1]["cores_busy"] == 2.0);
}
