#include "bench/render_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "camera/views.h"
#include "core/error.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <tbb/task_arena.h>

#include <unistd.h>

#include <filesystem>

namespace sdfkit {
namespace {

struct Timing {
  double wall = 0, cpu = 0;  // medians, seconds per view
};

/// Renders `cams` `reps` times inside an arena of `threads` threads; per-view medians.
Timing time_views(const MeshRenderer& r, const std::vector<Camera>& cams, int threads, int reps) {
  std::vector<double> walls, cpus;
  tbb::task_arena arena(threads);
  for (int rep = 0; rep < reps; ++rep) {
    const double c0 = process_cpu_seconds();
    const auto t0 = BenchClock::now();
    arena.execute([&] {
      for (const Camera& cam : cams) {
        const RenderResult res = r.render(cam);
        if (res.rgba.empty()) throw Error("bench render: empty image");
      }
    });
    walls.push_back(seconds_since(t0) / static_cast<double>(cams.size()));
    cpus.push_back((process_cpu_seconds() - c0) / static_cast<double>(cams.size()));
  }
  return {median(walls), median(cpus)};
}

}  // namespace

RenderBenchResult run_render_bench(const RenderBenchSettings& settings) {
  const Mesh mesh =
      settings.mesh.empty() ? make_torus(Vec3::Zero(), 0.7, 0.3, 250, 100) : read_mesh(settings.mesh);
  RenderBenchResult out;
  out.mesh = settings.mesh;
  out.faces = static_cast<long>(mesh.num_faces());
  out.views = settings.views;
  out.reps = settings.reps;
  ViewSetSettings vs;
  vs.views = settings.views;
  double baseline = 0;
  auto run = [&](int size, int ss, int threads) {
    vs.size = size;
    const auto cams = view_set_cameras(vs, settings.seed);
    RenderSettings rs;
    rs.supersampling = ss;
    const MeshRenderer r(mesh, rs);
    const Timing t = time_views(r, cams, threads, settings.reps);
    if (baseline == 0) baseline = t.cpu;
    out.rows.push_back({size, ss, threads, t.wall, t.cpu, t.cpu / baseline});
  };
  run(137, 1, 1);  // baseline
  for (int ss : {2, 3, 4}) run(137, ss, 1);
  run(137, 3, 2);
  run(512, 3, 1);
  run(512, 3, 2);

  // Full view set with files (what prep pays per shape): render + PNG + JSON, default settings.
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("sdfkit_bench_render_" + std::to_string(::getpid()))).string();
  vs.size = 137;
  std::vector<double> set_wall;
  for (int rep = 0; rep < settings.reps; ++rep) {
    const auto t0 = BenchClock::now();
    render_view_set(mesh, dir, vs, settings.seed);
    set_wall.push_back(seconds_since(t0));
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  out.view_set_with_files_wall_s = median(set_wall);
  return out;
}

std::string render_bench_text(const RenderBenchResult& r) {
  using detail::bench_printf;
  std::string text = bench_printf("mesh: %s, %ld triangles, %d views per run, %d runs, medians\n",
                                  r.mesh.empty() ? "torus (generated)" : r.mesh.c_str(), r.faces, r.views, r.reps);
  for (const RenderBenchRow& row : r.rows)
    text += bench_printf("%4d^2  s=%d  threads=%d  %8.2f ms/view wall  %8.2f ms/view cpu  24 views %6.3f s wall  "
                         "cpu x%.2f\n",
                         row.size, row.supersampling, row.threads, 1e3 * row.wall, 1e3 * row.cpu, 24 * row.wall,
                         row.cpu_ratio);
  text += bench_printf("render_view_set (%d views, 137^2, s=3, PNG + JSON, all threads): %.3f s wall\n", r.views,
                       r.view_set_with_files_wall_s);
  return text;
}

Json render_bench_json(const RenderBenchResult& r) {
  Json rows = Json::array();
  for (const RenderBenchRow& row : r.rows)
    rows.push_back({{"size", row.size},
                    {"supersampling", row.supersampling},
                    {"threads", row.threads},
                    {"ms_per_view_wall", 1e3 * row.wall},
                    {"ms_per_view_cpu", 1e3 * row.cpu},
                    {"views_24_wall_s", 24 * row.wall},
                    {"cpu_ratio_vs_baseline", row.cpu_ratio}});
  return {{"faces", r.faces},
          {"views", r.views},
          {"reps", r.reps},
          {"rows", rows},
          {"view_set_with_files_wall_s", r.view_set_with_files_wall_s}};
}

}  // namespace sdfkit
