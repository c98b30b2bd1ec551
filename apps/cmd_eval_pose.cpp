// `sdfkit eval-pose --model M --data DIR [--split test]`: d3D and d2D (DISN Table 3) of a pose model on a split.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "nets/pose_train.h"

#include <chrono>
#include <cstdio>
#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_eval_pose(CLI::App& app) {
  struct Opts {
    std::string model, data, split = "test";
    PoseEvalSettings e;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--model", o->model, "pose model written by `sdfkit train pose`")->required();
  app.add_option("--data", o->data, "prepared dataset folder")->required();
  app.add_option("--split", o->split,
                 "split: a name (DATA/NAME.lst or DATA/../NAME.lst) or a list file; \"\" = every shape")
      ->capture_default_str();
  app.add_option("--points", o->e.points, "seeded sample points per shape (DISN: 2048)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--views", o->e.views, "first N views of each shape (-1 = all)")->capture_default_str();
  app.add_option("--seed", o->e.seed, "seed of the point draw")->capture_default_str();
  app.add_flag("--json", o->json, "print JSON (overall + per category) instead of text");
  return [o] {
    const auto t0 = std::chrono::steady_clock::now();
    auto net = load_pose_model(o->model);
    DatasetSettings ds;
    ds.root = o->data;
    ds.split = o->split;
    const Dataset data(ds);
    std::map<std::string, PoseScores> per;
    ProgressBar bar("eval-pose", 1);
    const PoseScores all = evaluate_pose(*net, data, o->e, &per, [&](long done, long total) {
      (void)total;
      bar.update(done);
    });
    bar.finish();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o->json) {
      Json cats = Json::object();
      for (const auto& [k, v] : per) cats[k] = {{"d3d", v.d3d}, {"d2d", v.d2d}, {"loss", v.loss}, {"items", v.items}};
      std::cout << Json{{"model", o->model},     {"data", o->data},   {"split", o->split},
                        {"d3d", all.d3d},        {"d2d", all.d2d},    {"loss", all.loss},
                        {"items", all.items},    {"shapes", data.size()}, {"points", o->e.points},
                        {"seconds", seconds},    {"per_category", cats}}
                       .dump(2)
                << '\n';
    } else {
      std::printf("%-14s %8s %10s %10s\n", "category", "items", "d3D", "d2D(px)");
      for (const auto& [k, v] : per) std::printf("%-14s %8ld %10.4f %10.3f\n", k.c_str(), v.items, v.d3d, v.d2d);
      std::printf("%-14s %8ld %10.4f %10.3f\n", "mean", all.items, all.d3d, all.d2d);
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("eval-pose", "score a pose model on a split: d3D and d2D (DISN Table 3)", setup_eval_pose);

}  // namespace
}  // namespace sdfkit::app
