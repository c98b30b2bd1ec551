#include "bench/nets_bench.h"

#include "core/json.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;

TEST_CASE("nets bench formatters: the peak line, one table line and one JSON object per layer") {
  NetsBenchResult r;
  r.gemm_n = 512;
  r.gemm_peak_gflops = 80;
  r.reps = 3;
  r.layers = {{"point-mlp 3->64 (16384 pts)", 20, 40}, {"conv 3x3/1 64->64 @56 (batch 8)", 60, 72}};
  const std::string text = nets_bench_text(r);
  CHECK(text ==
        "single-core float32 GEMM peak (Eigen 512x512): 80.00 GFLOP/s (median of 3, thread CPU time)\n"
        "layer (1 thread)                               fwd GF/s  of peak   bwd GF/s  of peak\n"
        "point-mlp 3->64 (16384 pts)                       20.00      25%      40.00      50%\n"
        "conv 3x3/1 64->64 @56 (batch 8)                   60.00      75%      72.00      90%\n");
  const Json j = nets_bench_json(r);
  CHECK(j["gemm_n"] == 512);
  CHECK(j["gemm_peak_gflops"] == 80.0);
  CHECK(j["threads"] == 1);
  CHECK(j["reps"] == 3);
  REQUIRE(j["layers"].size() == 2);
  CHECK(j["layers"][0]["name"] == "point-mlp 3->64 (16384 pts)");
  CHECK(j["layers"][0]["forward_fraction_of_peak"] == 0.25);
  CHECK(j["layers"][1]["name"] == "conv 3x3/1 64->64 @56 (batch 8)");
  CHECK(j["layers"][1]["backward_gflops"] == 72.0);
  CHECK(j["layers"][1]["backward_fraction_of_peak"] == 0.9);
}
