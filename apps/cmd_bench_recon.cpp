// `sdfkit bench recon`: seconds per image against CD/IoU, adaptive vs dense extraction (bench/recon_bench.h).
#include "apps/command.h"
#include "bench/recon_bench.h"
#include "core/json.h"

#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_recon(CLI::App& app) {
  struct Opts {
    ReconBenchSettings s;
    std::string out;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  o->s.model = default_model_path("sdf.ckpt");
  o->s.pose_model = default_model_path("pose.ckpt");
  app.add_option("--data", o->s.data, "prepared dataset with views and gt.obj")->required();
  app.add_option("--split", o->s.split, "split name or list file")->capture_default_str();
  app.add_option("--shapes", o->s.shapes, "shapes (view 0 of each) to reconstruct")->capture_default_str();
  app.add_option("--model", o->s.model, "SDF network model")->capture_default_str();
  app.add_option("--pose-model", o->s.pose_model, "pose network (with --cam est)")->capture_default_str();
  app.add_option("--cam", o->s.cam, "gt = the view's true camera, est = the pose network's estimate")
      ->capture_default_str();
  app.add_option("--res", o->s.resolutions, "effective resolutions (grid points per axis), comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--dense-max-res", o->s.dense_max, "run the dense baseline only up to this resolution")
      ->capture_default_str();
  app.add_option("--safety", o->s.safety,
                 "safety factor of the adaptive extraction (default: the model's, 2 for an SDF model, 10 for a binary "
                 "one)");
  app.add_option("--repeats", o->s.repeats, "timed runs per (shape, setting); the median is reported")
      ->capture_default_str();
  app.add_option("-o,--out", o->out, "also write the table as CSV to OUT.csv and a plot to OUT.svg");
  app.add_flag("--json", o->json, "print JSON instead of the Markdown table");
  return [o] {
    ReconBenchSettings s = o->s;
    s.model = require_model_path(s.model, "--model");
    if (s.cam == "est") s.pose_model = require_model_path(s.pose_model, "--pose-model");
    std::unique_ptr<ProgressBar> bar;
    const ReconBenchResult r = run_recon_bench(s, [&](long done, long total) {
      if (!bar) bar = std::make_unique<ProgressBar>("bench recon", total);
      if (done > 0) bar->update(done);
    });
    if (bar) bar->finish();
    if (!o->out.empty()) write_recon_bench_files(r, o->out);
    if (o->json)
      std::cout << recon_bench_json(r).dump(2) << '\n';
    else
      std::cout << recon_bench_text(r);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench recon",
                        "seconds per image against CD/IoU for adaptive vs dense extraction at 65/129/257",
                        setup_bench_recon);

}  // namespace
}  // namespace sdfkit::app
