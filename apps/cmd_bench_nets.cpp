// `sdfkit bench nets`: forward/backward throughput of the conv and point-MLP layers as a fraction of the
// machine's single-core float32 GEMM peak, measured in the same run (Eigen GEMM of large square matrices).
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/random.h"
#include "nets/layers.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <ctime>
#include <cstdio>
#include <iostream>

namespace sdfkit::app {
namespace {

// CPU time of the calling thread: the machine is shared, so wall time would measure the other processes too.
// Everything runs on this thread (TBB limited to 1 thread below).
const auto thread_seconds = thread_cpu_seconds;

template <typename F>
double median_seconds(int reps, F&& f) {
  f();  // warm-up (allocations, caches)
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const double t0 = thread_seconds();
    f();
    t.push_back(thread_seconds() - t0);
  }
  return median(t);
}

void fill(Tensor& t, uint64_t seed) {
  Rng rng(seed);
  for (auto& v : t.data) v = static_cast<float>(rng.uniform(-1, 1));
}

struct Row {
  std::string name;
  double fwd_gflops, bwd_gflops;
};

Row bench_layer(const std::string& name, Layer<float>& layer, const Shape& in, double fwd_flops, int reps) {
  ParamStore<float> store;
  store.add(layer);
  store.allocate(true);
  store.init(1);
  Tensor x(in), y, dx;
  fill(x, 2);
  layer.forward(x, y);
  Tensor dy(y.shape);
  fill(dy, 3);
  const double tf = median_seconds(reps, [&] { layer.forward(x, y); });
  const double tb = median_seconds(reps, [&] {
    store.zero_grad();
    layer.backward(x, y, dy, &dx);
  });
  // Backward = input gradient + weight gradient = 2x the forward multiply-adds.
  return {name, fwd_flops / tf * 1e-9, 2 * fwd_flops / tb * 1e-9};
}

std::function<int()> setup_bench_nets(CLI::App& app) {
  struct Opts {
    int reps = 5;
    int gemm = 1024;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--reps", o->reps, "timed repetitions per measurement (median reported)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--gemm", o->gemm, "side of the square GEMM that defines the peak")
      ->capture_default_str()
      ->check(positive());
  app.add_flag("--json", o->json, "print JSON");
  return [o] {
    // Everything single-threaded: the reference is the single-core GEMM peak.
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const int n = o->gemm;
    Eigen::MatrixXf A = Eigen::MatrixXf::Random(n, n), B = Eigen::MatrixXf::Random(n, n), C(n, n);
    const double tg = median_seconds(o->reps, [&] { C.noalias() = A * B; });
    const double peak = 2.0 * n * n * n / tg * 1e-9;
    std::vector<Row> rows;
    const int64_t P = 16384;  // points: 8 shapes x 2048 (DISN)
    for (auto [ci, co] : {std::pair{3, 64}, std::pair{64, 256}, std::pair{256, 512}, std::pair{512, 512},
                          std::pair{1536, 512}}) {
      Linear<float> lin(ci, co);
      rows.push_back(bench_layer("point-mlp " + std::to_string(ci) + "->" + std::to_string(co) + " (16384 pts)", lin,
                                 {8, P / 8, ci}, 2.0 * P * ci * co, o->reps));
    }
    struct ConvCase {
      int n, c, h, o, k, s;
    };
    for (const ConvCase& c : {ConvCase{16, 3, 137, 16, 5, 2}, ConvCase{16, 32, 35, 64, 3, 2},
                              ConvCase{16, 64, 18, 128, 3, 2}, ConvCase{16, 128, 9, 128, 3, 1},
                              ConvCase{8, 64, 56, 64, 3, 1}}) {
      Conv2d<float> conv({c.c, c.o, c.k, c.s, c.k / 2, true});
      const Shape os = conv.output_shape({c.n, c.c, c.h, c.h});
      const double flops = 2.0 * c.n * c.o * os[2] * os[3] * c.c * c.k * c.k;
      char name[128];
      std::snprintf(name, sizeof name, "conv %dx%d/%d %d->%d @%d (batch %d)", c.k, c.k, c.s, c.c, c.o, c.h, c.n);
      rows.push_back(bench_layer(name, conv, {c.n, c.c, c.h, c.h}, flops, o->reps));
    }
    if (o->json) {
      Json j = {{"gemm_n", n}, {"gemm_peak_gflops", peak}, {"threads", 1}, {"reps", o->reps}, {"layers", Json::array()}};
      for (const auto& r : rows)
        j["layers"].push_back({{"name", r.name},
                               {"forward_gflops", r.fwd_gflops},
                               {"backward_gflops", r.bwd_gflops},
                               {"forward_fraction_of_peak", r.fwd_gflops / peak},
                               {"backward_fraction_of_peak", r.bwd_gflops / peak}});
      std::cout << j.dump(2) << '\n';
    } else {
      std::printf("single-core float32 GEMM peak (Eigen %dx%d): %.2f GFLOP/s (median of %d, thread CPU time)\n", n, n, peak, o->reps);
      std::printf("%-44s %10s %8s %10s %8s\n", "layer (1 thread)", "fwd GF/s", "of peak", "bwd GF/s", "of peak");
      for (const auto& r : rows)
        std::printf("%-44s %10.2f %7.0f%% %10.2f %7.0f%%\n", r.name.c_str(), r.fwd_gflops, 100 * r.fwd_gflops / peak,
                    r.bwd_gflops, 100 * r.bwd_gflops / peak);
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench nets", "layer throughput (conv, point MLP) as a fraction of single-core GEMM peak",
                        setup_bench_nets);

}  // namespace
}  // namespace sdfkit::app
