// `sdfkit bench prep`: seconds per shape of the full preparation (sparse grid + samples + gt mesh) at 1 and 2
// threads, grid memory and active voxels against a dense 257^3 grid computed in the same run (exact distance +
// winding-number sign at every grid point), and the grid's error against a brute-force exact SDF at random band
// points. Results: docs/benchmarks/prep.md.
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/normalize.h"
#include "sdf/orientation.h"
#include "sdf/prepare.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

namespace sdfkit::app {
namespace {
namespace fs = std::filesystem;
/// CPU seconds of the whole process (user + system): robust to other processes sharing the machine.
const auto cpu_seconds = process_cpu_seconds;

/// ~50k-triangle closed mesh: a torus with 160 x 160 quads (51,200 triangles).
Mesh bench_closed() { return make_torus(Vec3::Zero(), 0.65, 0.25, 160, 160); }

/// A polygon soup of the same size: 10 overlapping closed icospheres (5,120 triangles each), some inside out.
Mesh bench_soup() {
  Rng rng(12);
  Mesh soup;
  for (int i = 0; i < 10; ++i) {
    const Vec3 c(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3));
    Mesh s = make_icosphere(c, rng.uniform(0.2, 0.45), 4);
    if (i % 3 == 0) s.F.col(1).swap(s.F.col(2));
    soup = i == 0 ? s : concatenate(soup, s);
  }
  return soup;
}

struct Shape {
  std::string name;
  Mesh mesh;
};

std::function<int()> setup_bench_prep(CLI::App& app) {
  struct Opts {
    std::vector<std::string> meshes;
    int repeats = 3;
    int dense_res = 257;
    long band_points = 10000;
    std::string sign = "auto";
    bool json = false;
    double band = 0.0;
    bool no_dense = false;
    std::string only;
    bool tree_memory = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("meshes", o->meshes, "extra meshes to time (default: the built-in 50k closed mesh and soup, and "
                                      "data/examples/meshes/*)");
  app.add_option("--repeats", o->repeats, "timed runs per shape and thread count (median reported)")
      ->check(positive())
      ->capture_default_str();
  app.add_option("--dense-res", o->dense_res, "resolution of the dense baseline grid over [-1.2, 1.2]^3")
      ->check(in_range(2, 1025))
      ->capture_default_str();
  app.add_option("--band-points", o->band_points, "random band points for the error against brute force")
      ->check(non_negative())
      ->capture_default_str();
  app.add_flag("--no-dense", o->no_dense, "skip the dense baseline");
  app.add_option("--band", o->band, "grid band half-width as in `sdfkit prep --band` (0 = 3 voxels)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--sign", o->sign, "sign method as in `sdfkit prep --sign`: auto or winding")
      ->check(CLI::IsMember({"auto", "winding"}))
      ->capture_default_str();
  app.add_flag("--tree-memory", o->tree_memory,
               "also report the memory of the same active voxels in non-standard OpenVDB trees with 4^3 leaves "
               "(5,4,2 and 4,3,2 log2 node sizes; such trees are not FloatGrids other tools read)");
  app.add_option("--only", o->only, "time only the shapes whose name contains this text (e.g. torus, soup)");
  app.add_flag("--json", o->json, "print the results as JSON on stdout (the table then goes to stderr)");
  return [o] {
    std::FILE* text = o->json ? stderr : stdout;
    std::vector<Shape> shapes = {{"closed torus 51k", bench_closed()}, {"soup 10 spheres 51k", bench_soup()}};
    std::vector<std::string> files = o->meshes;
    if (files.empty()) {
      const fs::path ex = fs::path(SDFKIT_SOURCE_DIR) / "data" / "examples" / "meshes";
      if (fs::is_directory(ex))
        for (const auto& e : fs::directory_iterator(ex)) files.push_back(e.path().string());
      std::sort(files.begin(), files.end());
    }
    for (const auto& f : files) shapes.push_back({fs::path(f).filename().string(), read_mesh(f)});
    if (!o->only.empty())
      shapes.erase(std::remove_if(shapes.begin(), shapes.end(),
                                  [&](const Shape& sh) { return sh.name.find(o->only) == std::string::npos; }),
                   shapes.end());
    const fs::path tmp = fs::temp_directory_path() / ("sdfkit_bench_prep_" + std::to_string(::getpid()));
    Json results = Json::array();
    std::fprintf(text, "%-22s %7s %5s %8s %8s %8s %8s %10s %8s %8s %9s %9s %9s %9s %9s %8s\n", "shape", "tris", "sign",
                "1thr s", "1thr cpu", "2thr s", "2thr cpu", "voxels", "% 257^3", "grid MB", "257^3 MB", "dense s",
                "dense cpu", "mean err", "max err", "sign ok");
    for (const auto& sh : shapes) {
      PrepareSettings s;
      s.grid.band = o->band;
      s.grid.sign = o->sign == "winding" ? SignMethod::kWindingNumber : SignMethod::kAuto;
      std::vector<double> t1, t2, c1, c2;
      PrepareStatus st;
      for (int threads : {2, 1}) {  // 1 thread last: its stage times are the ones printed
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
        for (int r = 0; r < o->repeats; ++r) {
          s.overwrite = true;
          const auto t0 = BenchClock::now();
          const double cpu0 = cpu_seconds();
          st = prepare_mesh(sh.mesh, sh.name, (tmp / "shape").string(), s);
          (threads == 1 ? t1 : t2).push_back(seconds_since(t0));
          (threads == 1 ? c1 : c2).push_back(cpu_seconds() - cpu0);
        }
      }
      const double rss_sparse = peak_rss_mb();
      const long dense_voxels = static_cast<long>(o->dense_res) * o->dense_res * o->dense_res;

      // Error of the interpolated grid against brute force at random points with |sdf| <= 0.1 that lie in the
      // stored band (at least one voxel inside it, so that trilinear interpolation reads band values only).
      const double h = s.grid.voxel_size;
      const double width = o->band > 0 ? std::ceil(o->band / h) * h : 3 * h;
      const double err_reach = std::min(0.1, width - h);
      const Normalization norm = unit_sphere_normalization(sh.mesh);
      const Mesh object = orient_consistently(apply_normalization(validate_mesh(sh.mesh, sh.name), norm));
      const SparseSdf grid = SparseSdf::read(ShapeFiles((tmp / "shape").string()).sdf);
      double tree542_mb = 0, tree432_mb = 0;
      if (o->tree_memory) {
        const auto g = vdb_grid(grid);
        auto copy_mb = [&](auto tree) {
          for (auto it = g->tree().cbeginValueOn(); it; ++it)
            if (it.isVoxelValue()) tree->setValueOn(it.getCoord(), *it);
          return static_cast<double>(tree->memUsage()) / 1e6;
        };
        tree542_mb = copy_mb(std::make_unique<openvdb::tree::Tree4<float, 5, 4, 2>::Type>(g->background()));
        tree432_mb = copy_mb(std::make_unique<openvdb::tree::Tree4<float, 4, 3, 2>::Type>(g->background()));
      }
      const MeshDistance dist(object);
      Rng rng(77);
      Points P(o->band_points, 3);
      {
        std::vector<double> cdf(static_cast<size_t>(object.F.rows()));
        double acc = 0;
        for (Eigen::Index f = 0; f < object.F.rows(); ++f) {
          acc += (object.V.row(object.F(f, 1)) - object.V.row(object.F(f, 0)))
                     .cross(object.V.row(object.F(f, 2)) - object.V.row(object.F(f, 0)))
                     .norm();
          cdf[static_cast<size_t>(f)] = acc;
        }
        long n = 0;
        while (n < o->band_points) {
          const auto f = static_cast<Eigen::Index>(std::lower_bound(cdf.begin(), cdf.end(), rng.uniform() * acc) -
                                                   cdf.begin());
          double a = rng.uniform(), b = rng.uniform();
          if (a + b > 1) a = 1 - a, b = 1 - b;
          const Vec3 x = object.V.row(object.F(f, 0)).transpose() * (1 - a - b) +
                         object.V.row(object.F(f, 1)).transpose() * a + object.V.row(object.F(f, 2)).transpose() * b;
          const Vec3 d = Vec3(rng.normal(), rng.normal(), rng.normal()).normalized() * rng.uniform(0, err_reach);
          const Vec3 p = x + d;
          if (dist(p) > err_reach) continue;
          P.row(n++) = p.transpose();
        }
      }
      Eigen::VectorXd ref(P.rows());
      tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 64), [&](const auto& r) {
        for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
          const Vec3 p = P.row(i).transpose();
          const double u = MeshDistance::brute_force(object, p);
          ref[i] = WindingNumber::brute_force(object, p) > 0.5 ? -u : u;
        }
      });
      const Eigen::VectorXd got = grid.values(P);
      double mean_err = 0, max_err = 0;
      long sign_ok = 0;
      for (Eigen::Index i = 0; i < P.rows(); ++i) {
        const double e = std::abs(got[i] - ref[i]);
        mean_err += e / static_cast<double>(std::max<Eigen::Index>(1, P.rows()));
        max_err = std::max(max_err, e);
        sign_ok += (got[i] < 0) == (ref[i] < 0) || std::abs(ref[i]) < grid.voxel_size();
      }

      // Dense baseline: exact distance + winding-number sign at every point of the dense grid (2 threads).
      double dense_s = 0, dense_cpu = 0;
      if (!o->no_dense) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
        const auto t0 = BenchClock::now();
        const double cpu0 = cpu_seconds();
        const WindingNumber wn(object);
        std::vector<float> dense(static_cast<size_t>(dense_voxels));
        const int R = o->dense_res;
        const double step = 2.4 / (R - 1);
        tbb::parallel_for(tbb::blocked_range<int>(0, R * R), [&](const auto& r) {
          for (int ij = r.begin(); ij != r.end(); ++ij)
            for (int k = 0; k < R; ++k) {
              const Vec3 p(-1.2 + step * (ij / R), -1.2 + step * (ij % R), -1.2 + step * k);
              const double u = dist(p);
              dense[static_cast<size_t>(ij) * R + k] = static_cast<float>(wn(p) > 0.5 ? -u : u);
            }
        });
        dense_s = seconds_since(t0);
        dense_cpu = cpu_seconds() - cpu0;
      }
      const double m1 = median(t1), m2 = median(t2);
      // Compare with the dense lattice at the grid's own voxel size (257^3 by default), whatever --dense-res is.
      const long side = std::lround(2.4 / s.grid.voxel_size) + 1;
      const long lattice = side * side * side;
      const double pct = 100.0 * static_cast<double>(st.active_voxels) / static_cast<double>(lattice);
      std::fprintf(text, "%-22s %7ld %5s %8.3f %8.3f %8.3f %8.3f %10ld %7.2f%% %8.2f %9.1f %9.2f %9.2f %9.5f %9.5f %7.2f%%\n",
                  sh.name.c_str(), static_cast<long>(sh.mesh.F.rows()),
                  st.sign == SignMethod::kPseudoNormal ? "pn" : "wn", m1, median(c1), m2, median(c2),
                  st.active_voxels, pct, st.grid_bytes / 1e6, lattice * 4e-6, dense_s, dense_cpu, mean_err, max_err,
                  100.0 * sign_ok / std::max<double>(1, static_cast<double>(P.rows())));
      std::fprintf(text, "  stages (wall s, last 1-thread run): mesh %.3f | grid: setup %.3f band %.3f insert %.3f sign %.3f (%ld probes) | "
                  "samples %.3f (%ld candidates) | gt %.3f | files %.3f\n",
                  st.seconds_mesh, st.grid.seconds_setup, st.grid.seconds_topology, st.grid.seconds_exact,
                  st.grid.seconds_sign, st.grid.winding_evaluations, st.seconds_samples, st.samples.candidates, st.seconds_gt, st.seconds_files);
      if (o->tree_memory)
        std::fprintf(text, "  same active voxels in non-standard trees with 4^3 leaves: 5,4,2 %.2f MB | 4,3,2 %.2f MB "
                    "(standard 5,4,3 FloatGrid %.2f MB)\n", tree542_mb, tree432_mb, st.grid_bytes / 1e6);
      std::fflush(stdout);
      results.push_back({{"shape", sh.name},
                         {"triangles", sh.mesh.F.rows()},
                         {"seconds_1_thread", t1},
                         {"seconds_2_threads", t2},
                         {"median_1_thread", m1},
                         {"median_2_threads", m2},
                         {"cpu_seconds_1_thread", c1},
                         {"cpu_seconds_2_threads", c2},
                         {"dense_cpu_seconds", dense_cpu},
                         {"active_voxels", st.active_voxels},
                         {"dense_voxels", dense_voxels},
                         {"lattice_voxels", lattice},
                         {"grid_bytes", st.grid_bytes},
                         {"tree_542_mb", tree542_mb},
                         {"tree_432_mb", tree432_mb},
                         {"dense_bytes", dense_voxels * 4},
                         {"dense_seconds_2_threads", dense_s},
                         {"band_points", P.rows()},
                         {"band_points_max_abs_sdf", err_reach},
                         {"mean_abs_error", mean_err},
                         {"max_abs_error", max_err},
                         {"sign_agreement", static_cast<double>(sign_ok) / std::max<double>(1, double(P.rows()))},
                         {"peak_rss_mb_after_sparse", rss_sparse},
                         {"peak_rss_mb_after_dense", peak_rss_mb()},
                         {"gt_source", st.gt_source},
                         {"sign", sign_method_name(st.sign)},
                         {"stage_seconds_last_run",
                          {{"mesh", st.seconds_mesh},
                           {"grid_setup", st.grid.seconds_setup},
                           {"grid_band", st.grid.seconds_topology},
                           {"grid_insert", st.grid.seconds_exact},
                           {"sample_candidates", st.samples.candidates},
                           {"grid_sign", st.grid.seconds_sign},
                           {"samples", st.seconds_samples},
                           {"gt", st.seconds_gt},
                           {"files", st.seconds_files}}},
                         {"band", o->band > 0 ? o->band : 3 * s.grid.voxel_size}});
    }
    std::error_code ec;
    fs::remove_all(tmp, ec);
    std::fprintf(text, "voxel %.6f, band %.6f (%s), 32768 samples; sign pn = pseudo-normal, wn = winding number; dense "
                "baseline = exact distance + winding sign at %d^3 points; peak RSS of the process %.0f MB\n",
                2.4 / 256, o->band > 0 ? o->band : 3 * 2.4 / 256, o->band > 0 ? "--band" : "3 voxels", o->dense_res,
                peak_rss_mb());
    if (o->json) std::cout << results.dump(2) << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench prep", "time dataset preparation against a dense baseline; error vs brute force",
                        setup_bench_prep);

}  // namespace
}  // namespace sdfkit::app
