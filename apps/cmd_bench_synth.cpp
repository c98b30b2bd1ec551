// `sdfkit bench synth`: generating and writing the procedural benchmark with 1 and N threads
// (bench/synth_bench.h).
#include "apps/command.h"
#include "bench/synth_bench.h"
#include "core/json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_synth(CLI::App& app) {
  struct Opts {
    SynthBenchSettings s;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("-n,--per-category", o->s.per_category, "shapes per category (100 = the full preset)")
      ->check(in_range(1, 100000))
      ->capture_default_str();
  app.add_option("--reps", o->s.reps, "repetitions (medians are reported)")
      ->check(in_range(1, 1000))
      ->capture_default_str();
  app.add_option("-j,--jobs", o->s.jobs, "threads of the parallel run (0 = all cores)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--seed", o->s.seed, "benchmark seed")->capture_default_str();
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    const SynthBenchResult r = run_synth_bench(o->s);
    if (o->json)
      std::cout << synth_bench_json(r).dump(2) << '\n';
    else
      std::fputs(synth_bench_text(r).c_str(), stdout);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench synth", "time generating and writing the procedural benchmark (1 and N threads)",
                        setup_bench_synth);

}  // namespace
}  // namespace sdfkit::app
