// `sdfkit bench nets`: layer throughput against the single-core GEMM peak (bench/nets_bench.h).
#include "apps/command.h"
#include "bench/nets_bench.h"
#include "core/json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_nets(CLI::App& app) {
  struct Opts {
    NetsBenchSettings s;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--reps", o->s.reps, "timed repetitions per measurement (median reported)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--gemm", o->s.gemm, "side of the square GEMM that defines the peak")
      ->capture_default_str()
      ->check(positive());
  app.add_flag("--json", o->json, "print JSON");
  return [o] {
    const NetsBenchResult r = run_nets_bench(o->s);
    if (o->json)
      std::cout << nets_bench_json(r).dump(2) << '\n';
    else
      std::fputs(nets_bench_text(r).c_str(), stdout);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench nets", "layer throughput (conv, point MLP) as a fraction of single-core GEMM peak",
                        setup_bench_nets);

}  // namespace
}  // namespace sdfkit::app
