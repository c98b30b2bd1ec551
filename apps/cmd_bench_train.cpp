// `sdfkit bench train`: wall time, CPU time and FLOP rate of training steps (the shipped SDF configuration, the
// DISN-size SDF configuration and the pose network) at 1 and 2 threads, against the float32 GEMM peak of 1 and 2
// threads measured in the same run. FLOPs are counted analytically (SdfNet::train_step_flops,
// PoseNet::train_step_flops).
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "nets/pose_train.h"
#include "nets/sdf_train.h"

#include <tbb/global_control.h>

#include <Eigen/Core>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>
#include <unistd.h>

namespace fs = std::filesystem;

namespace sdfkit::app {
namespace {

struct TrainConfig {
  std::string name;
  std::string description;
  bool pose = false;
  SdfNetConfig sdf;
  PoseNetSettings pose_net;
  int batch = 8;
  int points = 2048;
};

std::vector<TrainConfig> all_configs() {
  std::vector<TrainConfig> out;
  TrainConfig shipped;
  shipped.name = "shipped";
  shipped.description =
      "train sdf defaults (the shipped model): encoder 16,32,64,128,192,256 from a full-resolution first map, "
      "global 512, point MLP 64,128, decoder 256,128, 8 x 2048";
  shipped.sdf.encoder_channels = {16, 32, 64, 128, 192, 256};
  shipped.sdf.first_stride = 1;
  shipped.sdf.extra_convs = 0;
  shipped.sdf.global_features = 512;
  shipped.sdf.point_mlp = {64, 128};
  shipped.sdf.decoder = {256, 128};
  out.push_back(shipped);
  TrainConfig disn = shipped;
  disn.name = "disn";
  disn.sdf.first_stride = 2;
  disn.description = "DISN-size: encoder 32,64,128,256,256, global 512, point MLP 64,256,512, decoder 512,256, 8 x 2048";
  disn.sdf.encoder_channels = {32, 64, 128, 256, 256};
  disn.sdf.global_features = 512;
  disn.sdf.point_mlp = {64, 256, 512};
  disn.sdf.decoder = {512, 256};
  out.push_back(disn);
  TrainConfig pose;
  pose.name = "pose";
  pose.description = "train pose defaults: width 32, feature 256, azimuth head 36 bins, batch 16";
  pose.pose = true;
  pose.pose_net = shipped_pose_recipe().net;
  pose.batch = 16;
  pose.points = 512;
  out.push_back(pose);
  return out;
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

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

/// A small prepared dataset (8 shapes, 4 views) made by this executable in `dir`.
void make_dataset(const std::string& dir) {
  const std::string exe = fs::read_symlink("/proc/self/exe").string();
  const std::string synth = dir + "/synth", prep = dir + "/prep";
  const std::string cmd1 = "'" + exe + "' synth -o '" + synth +
                           "' --per-category 1 --seed 5 --categories plane,bench,cabinet,car,chair,lamp,sofa,table "
                           ">/dev/null";
  const std::string cmd2 = "'" + exe + "' prep '" + synth + "' -o '" + prep +
                           "' --voxel 0.0375 --samples 8192 --views 4 -q >/dev/null";
  if (std::system(cmd1.c_str()) != 0 || std::system(cmd2.c_str()) != 0)
    throw Error("bench train: could not make the benchmark dataset in " + dir);
}

struct Run {
  std::string config;
  int threads = 1;
  int steps = 0;
  double seconds_per_step = 0, cpu_seconds_per_step = 0, gflop_per_step = 0;
};

/// Times steps [warmup, warmup + steps) of a training run (the run's last step validates and saves: not timed).
Run time_run(const TrainConfig& c, const std::string& data, const std::string& out_dir, int threads, int warmup,
             int steps) {
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
  Run r;
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

std::function<int()> setup_bench_train(CLI::App& app) {
  struct Opts {
    std::string data, configs = "shipped,disn,pose", threads = "1,2";
    int steps = 5, warmup = 2, gemm = 1024, reps = 5;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--data", o->data,
                 "prepared dataset with views (default: 8 shapes made by this command in a temporary folder)");
  app.add_option("--configs", o->configs, "comma-separated: shipped, disn, pose")->capture_default_str();
  app.add_option("--threads", o->threads, "comma-separated thread counts")->capture_default_str();
  app.add_option("--steps", o->steps, "timed steps per run (median reported)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--warmup", o->warmup, "untimed steps before them")->capture_default_str()->check(non_negative());
  app.add_option("--gemm", o->gemm, "side of the square GEMMs that define the peak")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--reps", o->reps, "GEMM repetitions (median)")->capture_default_str()->check(positive());
  app.add_flag("--json", o->json, "print JSON on stdout");
  return [o] {
    std::vector<TrainConfig> configs;
    const auto known = all_configs();
    for (const auto& name : split_list(o->configs)) {
      auto it = std::find_if(known.begin(), known.end(), [&](const TrainConfig& c) { return c.name == name; });
      if (it == known.end()) throw InvalidInput("--configs: unknown configuration '" + name + "' (shipped, disn, pose)");
      configs.push_back(*it);
    }
    std::vector<int> threads;
    for (const auto& t : split_list(o->threads)) {
      char* end = nullptr;
      const long v = std::strtol(t.c_str(), &end, 10);
      if (end == t.c_str() || *end != '\0' || v < 1 || v > 256)
        throw InvalidInput("--threads: '" + t + "' is not a thread count from 1 to 256");
      threads.push_back(static_cast<int>(v));
    }
    if (configs.empty() || threads.empty()) throw InvalidInput("bench train: nothing to run");
    const fs::path tmp = fs::temp_directory_path() / ("sdfkit_bench_train_" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    struct Cleanup {
      fs::path p;
      ~Cleanup() {
        std::error_code ec;
        fs::remove_all(p, ec);
      }
    } cleanup{tmp};
    std::string data = o->data;
    if (data.empty()) {
      std::fprintf(stderr, "bench train: making a dataset of 8 shapes in %s\n", tmp.c_str());
      make_dataset(tmp.string());
      data = (tmp / "prep").string();
    }
    const int max_threads = *std::max_element(threads.begin(), threads.end());
    std::map<int, double> peak;
    for (int t = 1; t <= std::max(2, max_threads); ++t)
      if (t <= 2 || std::find(threads.begin(), threads.end(), t) != threads.end())
        peak[t] = gemm_peak(o->gemm, t, o->reps);
    auto peak_for = [&](int t) {  // the best GEMM rate with at most t threads
      double best = 0;
      for (const auto& [k, v] : peak)
        if (k <= t) best = std::max(best, v);
      return best;
    };
    std::vector<Run> runs;
    for (const auto& c : configs)
      for (const int t : threads) {
        std::fprintf(stderr, "bench train: %s at %d thread%s...\n", c.name.c_str(), t, t == 1 ? "" : "s");
        runs.push_back(time_run(c, data, tmp.string(), t, o->warmup, o->steps));
      }
    Json j = {{"cpu", cpu_model()},
              {"hardware_threads", std::thread::hardware_concurrency()},
              {"gemm_n", o->gemm},
              {"gemm_peak_gflops", Json::object()},
              {"configs", Json::array()},
              {"runs", Json::array()}};
    for (const auto& [k, v] : peak) j["gemm_peak_gflops"][std::to_string(k)] = v;
    for (const auto& c : configs) j["configs"].push_back({{"config", c.name}, {"description", c.description}});
    for (const Run& r : runs) {
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
    if (o->json) {
      std::cout << j.dump(2) << '\n';
      return int(kOk);
    }
    std::printf("%s, %u hardware threads\n", cpu_model().c_str(), std::thread::hardware_concurrency());
    for (const auto& [k, v] : peak)
      std::printf("float32 GEMM peak, %d thread%s (%d x %d, median of %d, wall): %.1f GFLOP/s\n", k, k == 1 ? "" : "s",
                  o->gemm, o->gemm, o->reps, v);
    std::printf("%-8s %7s %10s %10s %10s %10s %9s %8s\n", "config", "threads", "s/step", "CPU s/step", "cores busy",
                "GFLOP/step", "GFLOP/s", "of peak");
    for (const auto& r : j["runs"])
      std::printf("%-8s %7d %10.3f %10.3f %10.2f %10.1f %9.1f %7.0f%%\n", r["config"].get<std::string>().c_str(),
                  r["threads"].get<int>(), r["seconds_per_step"].get<double>(), r["cpu_seconds_per_step"].get<double>(),
                  r["cores_busy"].get<double>(), r["gflop_per_step"].get<double>(), r["gflops"].get<double>(),
                  100 * r["fraction_of_peak"].get<double>());
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench train",
                        "training steps (shipped, DISN-size, pose) at 1 and 2 threads against the GEMM peak",
                        setup_bench_train);

}  // namespace
}  // namespace sdfkit::app
