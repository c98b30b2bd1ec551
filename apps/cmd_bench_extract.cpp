// `sdfkit bench extract`: dense vs sparse vs adaptive marching cubes on analytic shapes (bench/extract_bench.h).
#include "apps/command.h"
#include "bench/extract_bench.h"
#include "core/json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_extract(CLI::App& app) {
  struct Opts {
    ExtractBenchSettings s;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--res", o->s.resolutions, "final grid points per axis (2^k + 1), e.g. --res 129 257")
      ->check(in_range(3, 2049));
  app.add_option("--shapes", o->s.shapes, "analytic shapes: sphere, chair")->check(CLI::IsMember({"sphere", "chair"}));
  app.add_option("--coarse", o->s.coarse, "coarse grid points per axis of the adaptive method")
      ->check(in_range(2, 2049));
  app.add_option("--runs", o->s.runs, "timed runs per method (the median is reported)")->check(in_range(1, 100));
  app.add_option("--band", o->s.band, "half width (voxels) of the sparse band grid")->check(in_range(1.0, 100.0));
  app.add_option("--samples", o->s.samples, "surface samples per mesh for the distance to the analytic surface")
      ->check(in_range(1000L, 10000000L));
  app.add_option("-o,--out", o->s.out, "folder to write the extracted meshes to (<shape>_<res>_<method>.ply)");
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    if (!o->json) std::fputs(extract_bench_header().c_str(), stdout);
    const ExtractBenchResult r = run_extract_bench(o->s, [&](const ExtractBenchRow& row) {
      if (o->json) return;
      std::fputs(extract_bench_row_text(row).c_str(), stdout);
      std::fflush(stdout);
    });
    if (o->json) std::cout << extract_bench_json(r).dump(2) << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench extract",
                        "dense vs sparse vs adaptive marching cubes: evaluations, time, identical meshes, CD",
                        setup_bench_extract);

}  // namespace
}  // namespace sdfkit::app
