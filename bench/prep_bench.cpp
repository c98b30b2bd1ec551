#include "bench/prep_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/normalize.h"
#include "sdf/orientation.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace sdfkit {
namespace {
namespace fs = std::filesystem;

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

struct NamedMesh {
  std::string name;
  Mesh mesh;
};

}  // namespace

PrepBenchResult run_prep_bench(const PrepBenchSettings& settings,
                               const std::function<void(const PrepBenchRow&)>& on_row) {
  /// CPU seconds of the whole process (user + system): robust to other processes sharing the machine.
  const auto cpu_seconds = process_cpu_seconds;
  std::vector<NamedMesh> shapes = {{"closed torus 51k", bench_closed()}, {"soup 10 spheres 51k", bench_soup()}};
  std::vector<std::string> files = settings.meshes;
  if (files.empty()) {
    const fs::path ex = settings.example_meshes;
    if (!ex.empty() && fs::is_directory(ex))
      for (const auto& e : fs::directory_iterator(ex)) files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
  }
  for (const auto& f : files) shapes.push_back({fs::path(f).filename().string(), read_mesh(f)});
  if (!settings.only.empty())
    shapes.erase(std::remove_if(shapes.begin(), shapes.end(),
                                [&](const NamedMesh& sh) { return sh.name.find(settings.only) == std::string::npos; }),
                 shapes.end());
  const fs::path tmp = fs::temp_directory_path() / ("sdfkit_bench_prep_" + std::to_string(::getpid()));
  PrepBenchResult result;
  result.band = settings.band;
  result.dense_res = settings.dense_res;
  for (const auto& sh : shapes) {
    PrepBenchRow row;
    row.shape = sh.name;
    row.triangles = static_cast<long>(sh.mesh.F.rows());
    PrepareSettings s;
    s.grid.band = settings.band;
    s.grid.sign = settings.sign;
    s.grid.seal = settings.seal;
    std::vector<double>& t1 = row.seconds_1_thread;
    std::vector<double>& t2 = row.seconds_2_threads;
    std::vector<double>& c1 = row.cpu_seconds_1_thread;
    std::vector<double>& c2 = row.cpu_seconds_2_threads;
    PrepareStatus& st = row.status;
    for (int threads : {2, 1}) {  // 1 thread last: its stage times are the ones printed
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
      for (int r = 0; r < settings.repeats; ++r) {
        s.overwrite = true;
        const auto t0 = BenchClock::now();
        const double cpu0 = cpu_seconds();
        st = prepare_mesh(sh.mesh, sh.name, (tmp / "shape").string(), s);
        (threads == 1 ? t1 : t2).push_back(seconds_since(t0));
        (threads == 1 ? c1 : c2).push_back(cpu_seconds() - cpu0);
      }
    }
    row.peak_rss_mb_after_sparse = peak_rss_mb();
    const long dense_voxels = static_cast<long>(settings.dense_res) * settings.dense_res * settings.dense_res;
    row.dense_voxels = dense_voxels;

    // Error of the interpolated grid against brute force at random points with |sdf| <= 0.1 that lie in the
    // stored band (at least one voxel inside it, so that trilinear interpolation reads band values only).
    const double h = s.grid.voxel_size;
    const double width = settings.band > 0 ? std::ceil(settings.band / h) * h : 3 * h;
    const double err_reach = std::min(0.1, width - h);
    const Normalization norm = unit_sphere_normalization(sh.mesh);
    const Mesh object = orient_consistently(apply_normalization(validate_mesh(sh.mesh, sh.name), norm));
    const SparseSdf grid = SparseSdf::read(ShapeFiles((tmp / "shape").string()).sdf);
    row.tree_memory = settings.tree_memory;
    if (settings.tree_memory) {
      const auto g = vdb_grid(grid);
      auto copy_mb = [&](auto tree) {
        for (auto it = g->tree().cbeginValueOn(); it; ++it)
          if (it.isVoxelValue()) tree->setValueOn(it.getCoord(), *it);
        return static_cast<double>(tree->memUsage()) / 1e6;
      };
      row.tree_542_mb = copy_mb(std::make_unique<openvdb::tree::Tree4<float, 5, 4, 2>::Type>(g->background()));
      row.tree_432_mb = copy_mb(std::make_unique<openvdb::tree::Tree4<float, 4, 3, 2>::Type>(g->background()));
    }
    const MeshDistance dist(object);
    Rng rng(77);
    Points P(settings.band_points, 3);
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
      while (n < settings.band_points) {
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
    row.band_points = static_cast<long>(P.rows());
    row.band_points_max_abs_sdf = err_reach;
    row.mean_abs_error = mean_err;
    row.max_abs_error = max_err;
    row.sign_ok = sign_ok;

    // Dense baseline: exact distance + winding-number sign at every point of the dense grid (2 threads).
    if (settings.dense_baseline) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
      const auto t0 = BenchClock::now();
      const double cpu0 = cpu_seconds();
      const WindingNumber wn(object);
      std::vector<float> dense(static_cast<size_t>(dense_voxels));
      const int R = settings.dense_res;
      const double step = 2.4 / (R - 1);
      tbb::parallel_for(tbb::blocked_range<int>(0, R * R), [&](const auto& r) {
        for (int ij = r.begin(); ij != r.end(); ++ij)
          for (int k = 0; k < R; ++k) {
            const int i = ij / R, j = ij % R;  // grid point (i, j, k)
            const Vec3 p(-1.2 + step * i, -1.2 + step * j, -1.2 + step * k);
            const double u = dist(p);
            dense[static_cast<size_t>(ij) * R + k] = static_cast<float>(wn(p) > 0.5 ? -u : u);
          }
      });
      row.dense_seconds = seconds_since(t0);
      row.dense_cpu_seconds = cpu_seconds() - cpu0;
    }
    // Compare with the dense lattice at the grid's own voxel size (257^3 by default), whatever --dense-res is.
    const long side = std::lround(2.4 / s.grid.voxel_size) + 1;
    row.lattice_voxels = side * side * side;
    row.band = settings.band > 0 ? settings.band : 3 * s.grid.voxel_size;
    row.peak_rss_mb_after_dense = peak_rss_mb();
    if (on_row) on_row(row);
    result.rows.push_back(std::move(row));
  }
  std::error_code ec;
  fs::remove_all(tmp, ec);
  result.peak_rss_mb = peak_rss_mb();
  return result;
}

std::string prep_bench_header() {
  return detail::bench_printf(
      "%-22s %7s %5s %8s %8s %8s %8s %10s %8s %8s %9s %9s %9s %9s %9s %8s\n", "shape", "tris", "sign", "1thr s",
      "1thr cpu", "2thr s", "2thr cpu", "voxels", "% 257^3", "grid MB", "257^3 MB", "dense s", "dense cpu", "mean err",
      "max err", "sign ok");
}

std::string prep_bench_row_text(const PrepBenchRow& row) {
  using detail::bench_printf;
  const PrepareStatus& st = row.status;
  const double pct = 100.0 * static_cast<double>(st.active_voxels) / static_cast<double>(row.lattice_voxels);
  // Columns of what a run did not measure (no dense baseline, no band points) read "-", not a zero.
  const bool dense = row.dense_seconds > 0, checked = row.band_points > 0;
  const std::string dense_cols = dense ? bench_printf(" %9.2f %9.2f", row.dense_seconds, row.dense_cpu_seconds)
                                       : bench_printf(" %9s %9s", "-", "-");
  const std::string error_cols =
      checked ? bench_printf(" %9.5f %9.5f %7.2f%%", row.mean_abs_error, row.max_abs_error,
                             100.0 * static_cast<double>(row.sign_ok) / static_cast<double>(row.band_points))
              : bench_printf(" %9s %9s %8s", "-", "-", "-");
  std::string text = bench_printf(
      "%-22s %7ld %5s %8.3f %8.3f %8.3f %8.3f %10ld %7.2f%% %8.2f %9.1f%s%s\n", row.shape.c_str(), row.triangles,
      st.sign == SignMethod::kPseudoNormal ? "pn" : "wn", median(row.seconds_1_thread),
      median(row.cpu_seconds_1_thread), median(row.seconds_2_threads), median(row.cpu_seconds_2_threads),
      st.active_voxels, pct, static_cast<double>(st.grid_bytes) / 1e6, static_cast<double>(row.lattice_voxels) * 4e-6,
      dense_cols.c_str(), error_cols.c_str());
  text += bench_printf(
      "  stages (wall s, last 1-thread run): mesh %.3f | grid: setup %.3f band %.3f insert %.3f sign %.3f (%ld "
      "probes) | samples %.3f (%ld candidates) | gt %.3f | files %.3f\n",
      st.seconds_mesh, st.grid.seconds_setup, st.grid.seconds_topology, st.grid.seconds_exact, st.grid.seconds_sign,
      st.grid.winding_evaluations, st.seconds_samples, st.samples.candidates, st.seconds_gt, st.seconds_files);
  if (row.tree_memory)
    text += bench_printf(
        "  same active voxels in non-standard trees with 4^3 leaves: 5,4,2 %.2f MB | 4,3,2 %.2f MB (standard 5,4,3 "
        "FloatGrid %.2f MB)\n",
        row.tree_542_mb, row.tree_432_mb, static_cast<double>(st.grid_bytes) / 1e6);
  return text;
}

std::string prep_bench_footer(const PrepBenchResult& result) {
  return detail::bench_printf(
      "voxel %.6f, band %.6f (%s), 32768 samples; sign pn = pseudo-normal, wn = winding number; dense baseline = "
      "exact distance + winding sign at %d^3 points; peak RSS of the process %.0f MB\n",
      2.4 / 256, result.band > 0 ? result.band : 3 * 2.4 / 256, result.band > 0 ? "--band" : "3 voxels",
      result.dense_res, result.peak_rss_mb);
}

std::string prep_bench_text(const PrepBenchResult& result) {
  std::string text = prep_bench_header();
  for (const PrepBenchRow& row : result.rows) text += prep_bench_row_text(row);
  return text + prep_bench_footer(result);
}

Json prep_bench_row_json(const PrepBenchRow& row) {
  const PrepareStatus& st = row.status;
  return {{"shape", row.shape},
          {"triangles", row.triangles},
          {"seconds_1_thread", row.seconds_1_thread},
          {"seconds_2_threads", row.seconds_2_threads},
          {"median_1_thread", median(row.seconds_1_thread)},
          {"median_2_threads", median(row.seconds_2_threads)},
          {"cpu_seconds_1_thread", row.cpu_seconds_1_thread},
          {"cpu_seconds_2_threads", row.cpu_seconds_2_threads},
          {"dense_cpu_seconds", row.dense_cpu_seconds},
          {"active_voxels", st.active_voxels},
          {"dense_voxels", row.dense_voxels},
          {"lattice_voxels", row.lattice_voxels},
          {"grid_bytes", st.grid_bytes},
          {"tree_542_mb", row.tree_542_mb},
          {"tree_432_mb", row.tree_432_mb},
          {"dense_bytes", row.dense_voxels * 4},
          {"dense_seconds_2_threads", row.dense_seconds},
          {"band_points", row.band_points},
          {"band_points_max_abs_sdf", row.band_points_max_abs_sdf},
          {"mean_abs_error", row.band_points > 0 ? Json(row.mean_abs_error) : Json()},
          {"max_abs_error", row.band_points > 0 ? Json(row.max_abs_error) : Json()},
          {"sign_agreement",
           row.band_points > 0 ? Json(static_cast<double>(row.sign_ok) / static_cast<double>(row.band_points)) : Json()},
          {"peak_rss_mb_after_sparse", row.peak_rss_mb_after_sparse},
          {"peak_rss_mb_after_dense", row.peak_rss_mb_after_dense},
          {"gt_source", st.gt_source},
          {"sign", sign_method_name(st.sign)},
          {"sealed_voxels", st.grid.sealed_voxels},  // 0 unless --sign flood
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
          {"band", row.band}};
}

Json prep_bench_json(const PrepBenchResult& result) {
  Json rows = Json::array();
  for (const PrepBenchRow& row : result.rows) rows.push_back(prep_bench_row_json(row));
  return rows;
}

}  // namespace sdfkit
