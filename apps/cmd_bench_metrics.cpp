// `sdfkit bench metrics`: exact EMD and Chamfer against their baselines (bench/metrics_bench.h).
#include "apps/command.h"
#include "bench/metrics_bench.h"
#include "core/json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_metrics(CLI::App& app) {
  struct Opts {
    MetricsBenchSettings s;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--emd-points", o->s.emd_points, "points per set for the EMD timings")->check(in_range(2L, 20000L));
  app.add_option("--cd-points", o->s.cd_points, "points per set for the Chamfer timings")
      ->check(in_range(10L, 10000000L));
  app.add_option("--repeats", o->s.repeats, "timed runs per measurement (the median is reported)")
      ->check(in_range(1, 1000));
  app.add_flag("!--no-hungarian", o->s.hungarian, "skip the dense O(n^3) Hungarian baseline (slow for n > 2000)");
  app.add_flag("!--no-approx", o->s.approx, "skip DISN's approximate matcher (about 2 s per run at 2048 points)");
  app.add_option("--seed", o->s.seed, "seed of the sampled point sets");
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    const MetricsBenchResult r = run_metrics_bench(o->s);
    if (o->json)
      std::cout << metrics_bench_json(r).dump(2) << '\n';
    else
      std::fputs(metrics_bench_text(r).c_str(), stdout);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench metrics", "time exact EMD and Chamfer against their baselines", setup_bench_metrics);

}  // namespace
}  // namespace sdfkit::app
