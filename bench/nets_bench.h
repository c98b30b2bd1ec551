// `sdfkit bench nets`: forward/backward throughput of the conv and point-MLP layers as a fraction of the
// machine's single-core float32 GEMM peak, measured in the same run (Eigen GEMM of large square matrices).
// Everything runs on one thread and is timed in thread CPU time (the machine is shared).
#pragma once

#include "core/json_fwd.h"

#include <string>
#include <vector>

namespace sdfkit {

struct NetsBenchSettings {
  int reps = 5;     ///< timed repetitions per measurement (median reported)
  int gemm = 1024;  ///< side of the square GEMM that defines the peak
};

struct NetsBenchLayer {
  std::string name;
  double forward_gflops = 0, backward_gflops = 0;
};

struct NetsBenchResult {
  int gemm_n = 0;
  double gemm_peak_gflops = 0;
  int reps = 0;
  std::vector<NetsBenchLayer> layers;  ///< five point MLPs, then five convolutions
};

NetsBenchResult run_nets_bench(const NetsBenchSettings& settings);

/// What `sdfkit bench nets` prints: the peak line and the table, or the JSON object.
std::string nets_bench_text(const NetsBenchResult& result);
Json nets_bench_json(const NetsBenchResult& result);

}  // namespace sdfkit
