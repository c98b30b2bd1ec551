// `sdfkit bench render`: the rasteriser's ms per view at 137^2 and 512^2, 1 and 2 threads (bench/render_bench.h).
#include "apps/command.h"
#include "bench/render_bench.h"
#include "core/json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_render(CLI::App& app) {
  struct Opts {
    RenderBenchSettings s;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--mesh", o->s.mesh,
                 "mesh to render, used as it is (default: a torus of exactly 50,000 triangles in the unit sphere)");
  app.add_option("--reps", o->s.reps, "repetitions per configuration (medians are reported)")
      ->check(in_range(1, 1000))
      ->capture_default_str();
  app.add_option("--views", o->s.views, "views per repetition")->check(in_range(1, 1000))->capture_default_str();
  app.add_option("--seed", o->s.seed, "seed of the view set")->capture_default_str();
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    const RenderBenchResult r = run_render_bench(o->s);
    if (o->json)
      std::cout << render_bench_json(r).dump(2) << '\n';
    else
      std::fputs(render_bench_text(r).c_str(), stdout);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench render", "time the rasteriser: ms per view at 137^2 and 512^2, 1 and 2 threads",
                        setup_bench_render);

}  // namespace
}  // namespace sdfkit::app
