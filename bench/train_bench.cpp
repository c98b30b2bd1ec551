#include "bench/train_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/json.h"
#include "train/pose_train.h"
#include "train/sdf_train.h"

#include <tbb/global_control.h>

#include <Eigen/Core>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

namespace sdfkit {
namespace {
namespace fs = std::filesystem;

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return "unknown CPU";
}

/// Float32 GEMM rate (GFLOP/s, wall time, median of reps) with `threads` independent n x n products at once.
double gemm_peak(int n, int threads, int reps) {
  std::vector<Eigen::MatrixXf> A, B, C;
  for (int t = 0; t < threads; ++t) {
    A.push_back(Eigen::MatrixXf::Random(n, n));
    B.push_back(Eigen::MatrixXf::Random(n, n));
    C.emplace_back(n, n);
  }
  auto once = [&] {
    const auto t0 = BenchClock::now();
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back([&, t] { C[t].noalias() = A[t] * B[t]; });
    for (auto& th : pool) th.join();
    return seconds_since(t0);
  };
  once();
  std::vector<double> times;
  for (int r = 0; r < reps; ++r) times.push_back(once());
  return 2.0 * n * n * n * threads / median(times) * 1e-9;
}

/// A small prepared dataset (8 shapes, 4 views) made by the sdfkit executable `exe` in `dir`.
void make_dataset(const std::string& exe, const std::string& dir) {
  if (exe.empty()) throw InvalidInput("bench train: no dataset given and no sdfkit executable to make one");
  const std::string synth = dir + "/synth", prep = dir + "/prep";
  const std::string cmd1 = "'" + exe + "' synth -o '" + synth +
                           "' --per-category 1 --seed 5 --categories plane,bench,cabinet,car,chair,lamp,sofa,table "
                           ">/dev/null";
  const std::string cmd2 = "'" + exe + "' prep '" + synth + "' -o '" + prep +
                           "' --voxel 0.0375 --samples 8192 --views 4 -q >/dev/null";
  if (std::system(cmd1.c_str()) != 0 || std::system(cmd2.c_str()) != 0)
    throw Error("bench train: could not make the benchmark dataset in " + dir);
}

/// Times steps [warmup, warmup + steps) of a training run (the run's last step validates and saves: not timed).
TrainBenchRun time_run(const TrainBenchConfig& c, const std::string& data, const std::string& out_dir, int threads,
                       int warmup, int steps) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
  const long total = warmup + steps + 1;
  std::vector<double> wall, cpu;
  auto t_last = BenchClock::now();
  double c_last = process_cpu_seconds();
  auto on_step = [&](long step) {
    const auto t = BenchClock::now();
    const double c_now = process_cpu_seconds();
    if (step > warmup && step <= warmup + steps) {
      wall.push_back(std::chrono::duration<double>(t - t_last).count());
      cpu.push_back(c_now - c_last);
    }
    t_last = t;
    c_last = c_now;
  };
  TrainBenchRun r;
  r.config = c.name;
  r.threads = threads;
  r.steps = steps;
  const std::string model = out_dir + "/" + c.name + "_t" + std::to_string(threads) + ".ckpt";
  if (c.pose) {
    PoseTrainSettings s;
    s.data = data;
    s.out = model;
    s.train_split = "";
    s.val_split = "";
    s.steps = total;
    s.batch = c.batch;
    s.points = c.points;
    s.val_every = static_cast<int>(total);
    s.val_items = 8;
    s.net = c.pose_net;
    s.azimuth_weight = shipped_pose_recipe().azimuth_weight;
    t_last = BenchClock::now();
    c_last = process_cpu_seconds();
    train_pose(s, [&](const PoseTrainEvent& e) { on_step(e.step); });
    r.gflop_per_step = PoseNet(c.pose_net, false).train_step_flops(c.batch) * 1e-9;
  } else {
    SdfTrainSettings s;
    s.data = data;
    s.out = model;
    s.train_split = "";
    s.val_split = "";
    s.net = c.sdf;
    s.steps = total;
    s.batch = c.batch;
    s.points = c.points;
    s.val_every = static_cast<int>(total);
    s.val_shapes = 2;
    s.val_points = 1024;
    t_last = BenchClock::now();
    c_last = process_cpu_seconds();
    train_sdf(s, [&](const SdfTrainEvent& e) { on_step(e.step); });
    r.gflop_per_step = SdfNet(c.sdf).train_step_flops(c.batch, c.points) * 1e-9;
  }
  r.seconds_per_step = median(wall);
  // CPU time over the same steps, divided evenly (per-step CPU times are noisy: the loader thread works ahead).
  double cpu_sum = 0, wall_sum = 0;
  for (size_t i = 0; i < wall.size(); ++i) {
    cpu_sum += cpu[i];
    wall_sum += wall[i];
  }
  r.cpu_seconds_per_step = wall_sum > 0 ? cpu_sum / wall_sum * r.seconds_per_step : 0;
  return r;
}

}  // namespace

std::vector<TrainBenchConfig> train_bench_configs() {
  std::vector<TrainBenchConfig> out;
  TrainBenchConfig shipped;
  shipped.name = "shipped";
  shipped.description =
      "the shipped model's network (its last stage): encoder 16,32,64,128,192,256 from a full-resolution first "
      "map, RGB + missing-data mask input, global 512, point MLP 64,128, decoder 256,128, mirror features, 8 x 2048";
  shipped.sdf.encoder_channels = {16, 32, 64, 128, 192, 256};
  shipped.sdf.first_stride = 1;
  shipped.sdf.extra_convs = 0;
  shipped.sdf.global_features = 512;
  shipped.sdf.point_mlp = {64, 128};
  shipped.sdf.decoder = {256, 128};
  shipped.sdf.input_channels = 4;
  shipped.sdf.mirror_features = true;
  out.push_back(shipped);
  TrainBenchConfig disn = shipped;
  disn.name = "disn";
  disn.sdf.first_stride = 2;
  disn.sdf.input_channels = 3;
  disn.sdf.mirror_features = false;
  disn.description =
      "DISN-size: encoder 32,64,128,256,256, global 512, point MLP 64,256,512, decoder 512,256, 8 x 2048";
  disn.sdf.encoder_channels = {32, 64, 128, 256, 256};
  disn.sdf.global_features = 512;
  disn.sdf.point_mlp = {64, 256, 512};
  disn.sdf.decoder = {512, 256};
  out.push_back(disn);
  TrainBenchConfig pose;
  pose.name = "pose";
  pose.description = "train pose defaults: width 32, feature 256, azimuth head 36 bins, batch 16";
  pose.pose = true;
  pose.pose_net = shipped_pose_recipe().net;
  pose.batch = 16;
  pose.points = 512;
  out.push_back(pose);
  return out;
}

std::optional<TrainBenchConfig> find_train_bench_config(const std::string& name) {
  for (TrainBenchConfig& c : train_bench_configs())
    if (c.name == name) return std::move(c);
  return std::nullopt;
}

TrainBenchResult run_train_bench(const TrainBenchSettings& settings,
                                 const std::function<void(const std::string& line)>& log) {
  const std::vector<TrainBenchConfig>& configs = settings.configs;
  const std::vector<int>& threads = settings.threads;
  if (configs.empty() || threads.empty()) throw InvalidInput("bench train: nothing to run");
  for (const int t : threads)
    if (t < 1 || t > 256)
      throw InvalidInput("bench train: " + std::to_string(t) + " is not a thread count from 1 to 256");
  const fs::path tmp = fs::temp_directory_path() / ("sdfkit_bench_train_" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{tmp};
  std::string data = settings.data;
  if (data.empty()) {
    if (log) log("bench train: making a dataset of 8 shapes in " + tmp.string());
    make_dataset(settings.sdfkit_exe, tmp.string());
    data = (tmp / "prep").string();
  }
  TrainBenchResult result;
  result.cpu = cpu_model();
  result.hardware_threads = std::thread::hardware_concurrency();
  result.gemm_n = settings.gemm;
  result.reps = settings.reps;
  result.configs = configs;
  const int max_threads = *std::max_element(threads.begin(), threads.end());
  for (int t = 1; t <= std::max(2, max_threads); ++t)
    if (t <= 2 || std::find(threads.begin(), threads.end(), t) != threads.end())
      result.gemm_peak_gflops[t] = gemm_peak(settings.gemm, t, settings.reps);
  for (const auto& c : configs)
    for (const int t : threads) {
      if (log) log("bench train: " + c.name + " at " + std::to_string(t) + (t == 1 ? " thread..." : " threads..."));
      result.runs.push_back(time_run(c, data, tmp.string(), t, settings.warmup, settings.steps));
    }
  return result;
}

Json train_bench_json(const TrainBenchResult& result) {
  auto peak_for = [&](int t) {  // the best GEMM rate with at most t threads
    double best = 0;
    for (const auto& [k, v] : result.gemm_peak_gflops)
      if (k <= t) best = std::max(best, v);
    return best;
  };
  Json j = {{"cpu", result.cpu},
            {"hardware_threads", result.hardware_threads},
            {"gemm_n", result.gemm_n},
            {"gemm_peak_gflops", Json::object()},
            {"configs", Json::array()},
            {"runs", Json::array()}};
  for (const auto& [k, v] : result.gemm_peak_gflops) j["gemm_peak_gflops"][std::to_string(k)] = v;
  for (const auto& c : result.configs) j["configs"].push_back({{"config", c.name}, {"description", c.description}});
  for (const TrainBenchRun& r : result.runs) {
    const double gflops = r.gflop_per_step / r.seconds_per_step, pk = peak_for(r.threads);
    j["runs"].push_back({{"config", r.config},
                         {"threads", r.threads},
                         {"steps", r.steps},
                         {"seconds_per_step", r.seconds_per_step},
                         {"cpu_seconds_per_step", r.cpu_seconds_per_step},
                         {"cores_busy", r.cpu_seconds_per_step / r.seconds_per_step},
                         {"gflop_per_step", r.gflop_per_step},
                         {"gflops", gflops},
                         {"peak_gflops", pk},
                         {"fraction_of_peak", gflops / pk}});
  }
  return j;
}

std::string train_bench_text(const TrainBenchResult& result) {
  using detail::bench_printf;
  const Json j = train_bench_json(result);
  std::string text = bench_printf("%s, %u hardware threads\n", result.cpu.c_str(), result.hardware_threads);
  for (const auto& [k, v] : result.gemm_peak_gflops)
    text += bench_printf("float32 GEMM peak, %d thread%s (%d x %d, median of %d, wall): %.1f GFLOP/s\n", k,
                         k == 1 ? "" : "s", result.gemm_n, result.gemm_n, result.reps, v);
  text += bench_printf("%-8s %7s %10s %10s %10s %10s %9s %8s\n", "config", "threads", "s/step", "CPU s/step",
                       "cores busy", "GFLOP/step", "GFLOP/s", "of peak");
  for (const auto& r : j["runs"])
    text += bench_printf("%-8s %7d %10.3f %10.3f %10.2f %10.1f %9.1f %7.0f%%\n",
                         r["config"].get<std::string>().c_str(), r["threads"].get<int>(),
                         r["seconds_per_step"].get<double>(), r["cpu_seconds_per_step"].get<double>(),
                         r["cores_busy"].get<double>(), r["gflop_per_step"].get<double>(), r["gflops"].get<double>(),
                         100 * r["fraction_of_peak"].get<double>());
  return text;
}

}  // namespace sdfkit
