// `sdfkit bench render`: time per view of the rasteriser for a ~50k-triangle mesh at 137^2 and 512^2, with 1 and
// 2 threads and several supersampling factors, plus a full 24-view set with files. Medians of --reps runs;
// ratios against s = 1 at 137^2 on one thread, measured in the same run. Results: docs/benchmarks/render.md.
#include "apps/command.h"
#include "bench/timing.h"
#include "camera/views.h"
#include "core/error.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <unistd.h>

namespace sdfkit::app {
namespace {

const auto cpu_seconds = process_cpu_seconds;



struct Timing {
  double wall = 0, cpu = 0;  // medians, seconds per view
};

/// Renders `cams` `reps` times inside an arena of `threads` threads; per-view medians.
Timing time_views(const MeshRenderer& r, const std::vector<Camera>& cams, int threads, int reps) {
  std::vector<double> walls, cpus;
  tbb::task_arena arena(threads);
  for (int rep = 0; rep < reps; ++rep) {
    const double c0 = cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    arena.execute([&] {
      for (const Camera& cam : cams) {
        const RenderResult res = r.render(cam);
        if (res.rgba.empty()) throw Error("bench render: empty image");
      }
    });
    walls.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
                    static_cast<double>(cams.size()));
    cpus.push_back((cpu_seconds() - c0) / static_cast<double>(cams.size()));
  }
  return {median(walls), median(cpus)};
}

std::function<int()> setup_bench_render(CLI::App& app) {
  struct Opts {
    std::string mesh;
    int reps = 7;
    int views = 24;
    uint64_t seed = 1;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--mesh", o->mesh,
                 "mesh to render, used as it is (default: a torus of exactly 50,000 triangles in the unit sphere)");
  app.add_option("--reps", o->reps, "repetitions per configuration (medians are reported)")
      ->check(in_range(1, 1000))
      ->capture_default_str();
  app.add_option("--views", o->views, "views per repetition")->check(in_range(1, 1000))->capture_default_str();
  app.add_option("--seed", o->seed, "seed of the view set")->capture_default_str();
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    const Mesh mesh = o->mesh.empty() ? make_torus(Vec3::Zero(), 0.7, 0.3, 250, 100) : read_mesh(o->mesh);
    ViewSetSettings vs;
    vs.views = o->views;
    Json rows = Json::array();
    if (!o->json)
      std::printf("mesh: %s, %ld triangles, %d views per run, %d runs, medians\n",
                  o->mesh.empty() ? "torus (generated)" : o->mesh.c_str(), static_cast<long>(mesh.num_faces()),
                  o->views, o->reps);
    double baseline = 0;
    auto run = [&](int size, int ss, int threads) {
      vs.size = size;
      const auto cams = view_set_cameras(vs, o->seed);
      RenderSettings rs;
      rs.supersampling = ss;
      const MeshRenderer r(mesh, rs);
      const Timing t = time_views(r, cams, threads, o->reps);
      if (baseline == 0) baseline = t.cpu;
      rows.push_back({{"size", size},
                      {"supersampling", ss},
                      {"threads", threads},
                      {"ms_per_view_wall", 1e3 * t.wall},
                      {"ms_per_view_cpu", 1e3 * t.cpu},
                      {"views_24_wall_s", 24 * t.wall},
                      {"cpu_ratio_vs_baseline", t.cpu / baseline}});
      if (!o->json)
        std::printf("%4d^2  s=%d  threads=%d  %8.2f ms/view wall  %8.2f ms/view cpu  24 views %6.3f s wall  "
                    "cpu x%.2f\n",
                    size, ss, threads, 1e3 * t.wall, 1e3 * t.cpu, 24 * t.wall, t.cpu / baseline);
    };
    run(137, 1, 1);  // baseline
    for (int ss : {2, 3, 4}) run(137, ss, 1);
    run(137, 3, 2);
    run(512, 3, 1);
    run(512, 3, 2);

    // Full view set with files (what prep pays per shape): render + PNG + JSON, default settings.
    const std::string dir = (std::filesystem::temp_directory_path() /
                             ("sdfkit_bench_render_" + std::to_string(::getpid())))
                                .string();
    vs.size = 137;
    std::vector<double> set_wall;
    for (int rep = 0; rep < o->reps; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      render_view_set(mesh, dir, vs, o->seed);
      set_wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    const double set_s = median(set_wall);
    if (o->json) {
      std::cout << Json{{"faces", mesh.num_faces()}, {"views", o->views}, {"reps", o->reps}, {"rows", rows},
                        {"view_set_with_files_wall_s", set_s}}
                       .dump(2)
                << '\n';
    } else {
      std::printf("render_view_set (%d views, 137^2, s=3, PNG + JSON, all threads): %.3f s wall\n", o->views, set_s);
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench render", "time the rasteriser: ms per view at 137^2 and 512^2, 1 and 2 threads",
                        setup_bench_render);

}  // namespace
}  // namespace sdfkit::app
