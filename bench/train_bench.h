// `sdfkit bench train`: wall time, CPU time and FLOP rate of training steps (the shipped SDF configuration, the
// DISN-size SDF configuration and the pose network) at 1 and 2 threads, against the float32 GEMM peak of 1 and 2
// threads measured in the same run. FLOPs are counted analytically (SdfNet::train_step_flops,
// PoseNet::train_step_flops).
#pragma once

#include "core/json_fwd.h"
#include "models/pose_net.h"
#include "models/sdf_net.h"

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sdfkit {

/// A network configuration whose training steps are timed.
struct TrainBenchConfig {
  std::string name;
  std::string description;
  bool pose = false;  ///< the pose network (pose_net) instead of the SDF network (sdf)
  SdfNetConfig sdf;
  PoseNetSettings pose_net;
  int batch = 8;
  int points = 2048;
};

/// The known configurations: "shipped", "disn", "pose" (in that order).
std::vector<TrainBenchConfig> train_bench_configs();
/// The known configuration called `name`, or nothing.
std::optional<TrainBenchConfig> find_train_bench_config(const std::string& name);

struct TrainBenchSettings {
  /// Prepared dataset with views; empty: 8 shapes made in a temporary folder by running `sdfkit_exe` (synth, prep).
  std::string data;
  std::string sdfkit_exe;                                        ///< the sdfkit executable (used without `data`)
  std::vector<TrainBenchConfig> configs = train_bench_configs();  ///< default: all
  std::vector<int> threads = {1, 2};                             ///< thread counts, each from 1 to 256
  int steps = 5;    ///< timed steps per run (median reported)
  int warmup = 2;   ///< untimed steps before them
  int gemm = 1024;  ///< side of the square GEMMs that define the peak
  int reps = 5;     ///< GEMM repetitions (median)
};

/// One configuration at one thread count.
struct TrainBenchRun {
  std::string config;
  int threads = 1;
  int steps = 0;
  double seconds_per_step = 0;      ///< median wall time
  double cpu_seconds_per_step = 0;  ///< process CPU time over the same steps, divided evenly
  double gflop_per_step = 0;        ///< counted analytically
};

struct TrainBenchResult {
  std::string cpu;                           ///< model name from /proc/cpuinfo
  unsigned hardware_threads = 0;
  int gemm_n = 0, reps = 0;
  std::map<int, double> gemm_peak_gflops;    ///< by thread count: 1, 2 and every larger count timed
  std::vector<TrainBenchConfig> configs;
  std::vector<TrainBenchRun> runs;           ///< per configuration, per thread count
};

/// Runs the benchmark; `log` (may be empty) gets its progress lines ("bench train: pose at 1 thread...").
/// Throws InvalidInput when there is no configuration or thread count to run.
TrainBenchResult run_train_bench(const TrainBenchSettings& settings,
                                 const std::function<void(const std::string& line)>& log = {});

/// What `sdfkit bench train` prints: the text report, or the JSON object.
std::string train_bench_text(const TrainBenchResult& result);
Json train_bench_json(const TrainBenchResult& result);

}  // namespace sdfkit
