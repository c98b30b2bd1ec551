#include "bench/nets_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/json.h"
#include "core/random.h"
#include "nets/layers.h"

#include <tbb/global_control.h>

#include <cstdio>

namespace sdfkit {
namespace {

template <typename F>
double median_seconds(int reps, F&& f) {
  f();  // warm-up (allocations, caches)
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    // CPU time of the calling thread: the machine is shared, so wall time would measure the other processes too.
    const double t0 = thread_cpu_seconds();
    f();
    t.push_back(thread_cpu_seconds() - t0);
  }
  return median(t);
}

void fill(Tensor& t, uint64_t seed) {
  Rng rng(seed);
  for (auto& v : t.data) v = static_cast<float>(rng.uniform(-1, 1));
}

NetsBenchLayer bench_layer(const std::string& name, Layer<float>& layer, const Shape& in, double fwd_flops, int reps) {
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

}  // namespace

NetsBenchResult run_nets_bench(const NetsBenchSettings& settings) {
  // Everything single-threaded (on this thread): the reference is the single-core GEMM peak.
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  NetsBenchResult out;
  const int n = settings.gemm;
  out.gemm_n = n;
  out.reps = settings.reps;
  Eigen::MatrixXf A = Eigen::MatrixXf::Random(n, n), B = Eigen::MatrixXf::Random(n, n), C(n, n);
  const double tg = median_seconds(settings.reps, [&] { C.noalias() = A * B; });
  out.gemm_peak_gflops = 2.0 * n * n * n / tg * 1e-9;
  const int64_t P = 16384;  // points: 8 shapes x 2048 (DISN)
  for (auto [ci, co] : {std::pair{3, 64}, std::pair{64, 256}, std::pair{256, 512}, std::pair{512, 512},
                        std::pair{1536, 512}}) {
    Linear<float> lin(ci, co);
    out.layers.push_back(bench_layer("point-mlp " + std::to_string(ci) + "->" + std::to_string(co) + " (16384 pts)",
                                     lin, {8, P / 8, ci}, 2.0 * P * ci * co, settings.reps));
  }
  struct ConvCase {
    int n, c, h, o, k, s;
  };
  for (const ConvCase& c : {ConvCase{16, 3, 137, 16, 5, 2}, ConvCase{16, 32, 35, 64, 3, 2},
                            ConvCase{16, 64, 18, 128, 3, 2}, ConvCase{16, 128, 9, 128, 3, 1},
                            ConvCase{8, 64, 56, 64, 3, 1}}) {
    Conv2d<float> conv({c.c, c.o, c.k, c.s, c.k / 2, true});
    const Shape os = conv.output_shape({c.n, c.c, c.h, c.h});
    const double flops = 2.0 * c.n * c.o * static_cast<double>(os[2]) * static_cast<double>(os[3]) * c.c * c.k * c.k;
    char name[128];
    std::snprintf(name, sizeof name, "conv %dx%d/%d %d->%d @%d (batch %d)", c.k, c.k, c.s, c.c, c.o, c.h, c.n);
    out.layers.push_back(bench_layer(name, conv, {c.n, c.c, c.h, c.h}, flops, settings.reps));
  }
  return out;
}

Json nets_bench_json(const NetsBenchResult& r) {
  const double peak = r.gemm_peak_gflops;
  Json j = {{"gemm_n", r.gemm_n},
            {"gemm_peak_gflops", peak},
            {"threads", 1},
            {"reps", r.reps},
            {"layers", Json::array()}};
  for (const auto& l : r.layers)
    j["layers"].push_back({{"name", l.name},
                           {"forward_gflops", l.forward_gflops},
                           {"backward_gflops", l.backward_gflops},
                           {"forward_fraction_of_peak", l.forward_gflops / peak},
                           {"backward_fraction_of_peak", l.backward_gflops / peak}});
  return j;
}

std::string nets_bench_text(const NetsBenchResult& r) {
  using detail::bench_printf;
  const double peak = r.gemm_peak_gflops;
  std::string text = bench_printf(
      "single-core float32 GEMM peak (Eigen %dx%d): %.2f GFLOP/s (median of %d, thread CPU time)\n", r.gemm_n,
      r.gemm_n, peak, r.reps);
  text += bench_printf("%-44s %10s %8s %10s %8s\n", "layer (1 thread)", "fwd GF/s", "of peak", "bwd GF/s", "of peak");
  for (const auto& l : r.layers)
    text += bench_printf("%-44s %10.2f %7.0f%% %10.2f %7.0f%%\n", l.name.c_str(), l.forward_gflops,
                         100 * l.forward_gflops / peak, l.backward_gflops, 100 * l.backward_gflops / peak);
  return text;
}

}  // namespace sdfkit
