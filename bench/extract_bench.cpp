#include "bench/extract_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "extract/adaptive.h"
#include "extract/band_grid.h"
#include "extract/marching_cubes.h"
#include "metrics/chamfer.h"
#include "metrics/sampling.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace sdfkit {
namespace {

struct BoxPart {
  Vec3 lo, hi;
};

/// A chair in the object frame (y up, inside the unit sphere): union (min) of box SDFs. The min of exact SDFs is
/// 1-Lipschitz, so the distance bound (safety 1) holds.
std::vector<BoxPart> chair_parts() {
  std::vector<BoxPart> parts;
  parts.push_back({Vec3(-0.45, -0.06, -0.45), Vec3(0.45, 0.02, 0.45)});  // seat
  for (double x : {-0.41, 0.35})
    for (double z : {-0.41, 0.35}) parts.push_back({Vec3(x, -0.80, z), Vec3(x + 0.06, -0.06, z + 0.06)});  // legs
  for (double x : {-0.45, 0.39}) parts.push_back({Vec3(x, 0.02, 0.37), Vec3(x + 0.06, 0.85, 0.45)});     // posts
  parts.push_back({Vec3(-0.39, 0.72, 0.38), Vec3(0.39, 0.85, 0.44)});                                   // top rail
  for (double x : {-0.25, -0.09, 0.07, 0.23})
    parts.push_back({Vec3(x - 0.025 + 0.01, 0.02, 0.395), Vec3(x + 0.025 + 0.01, 0.72, 0.425)});  // slats
  return parts;
}

double chair_sdf(const Vec3& p, const std::vector<BoxPart>& parts) {
  double d = 1e300;
  for (const auto& b : parts) d = std::min(d, box_sdf(p, b.lo, b.hi));
  return d;
}

/// Point-wise field evaluated in parallel (each value depends only on its point: deterministic).
BatchField parallel_field(std::function<double(const Vec3&)> f) {
  return [f](const Points& p, Eigen::VectorXd& v) {
    v.resize(p.rows());
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, p.rows(), 1024), [&](const auto& r) {
      for (Eigen::Index i = r.begin(); i < r.end(); ++i) v[i] = f(p.row(i).transpose());
    });
  };
}

bool same_mesh(const Mesh& a, const Mesh& b, double tol) {
  if (a.F.rows() != b.F.rows() || a.V.rows() != b.V.rows() || a.F != b.F) return false;
  return a.V.rows() == 0 || (a.V - b.V).cwiseAbs().maxCoeff() <= tol;
}

}  // namespace

ExtractBenchResult run_extract_bench(const ExtractBenchSettings& settings,
                                     const std::function<void(const ExtractBenchRow&)>& on_row) {
  const std::vector<BoxPart> parts = chair_parts();
  ExtractBenchResult result;
  for (const std::string& shape : settings.shapes) {
    std::function<double(const Vec3&)> sdf;
    if (shape == "sphere")
      sdf = [](const Vec3& p) { return sphere_sdf(p, Vec3(0.013, -0.021, 0.007), 0.8); };
    else
      sdf = [&parts](const Vec3& p) { return chair_sdf(p, parts); };
    const BatchField field = parallel_field(sdf);
    for (int res : settings.resolutions) {
      ExtractSettings s;
      s.resolution = res;
      s.coarse_resolution = std::min(settings.coarse, res);
      const double dense_evals = double(res) * res * res;
      // Dense: sample every point, then marching cubes.
      std::vector<double> t_eval, t_mc;
      DenseGrid grid;
      Mesh dense;
      for (int r = 0; r < settings.runs; ++r) {
        auto t0 = BenchClock::now();
        grid = sample_dense(field, s);
        t_eval.push_back(seconds_since(t0));
        t0 = BenchClock::now();
        dense = marching_cubes(grid, {0.0, true});
        t_mc.push_back(seconds_since(t0));
      }
      // Sparse: marching cubes over a narrow band (built once from the dense samples; the band's values are
      // what `prep` stores in sdf.vdb).
      auto t0 = BenchClock::now();
      const BandGrid band = BandGrid::from_dense(grid, settings.band);
      const double band_build = seconds_since(t0);
      std::vector<double> t_sparse;
      Mesh sparse;
      for (int r = 0; r < settings.runs; ++r) {
        t0 = BenchClock::now();
        sparse = band.extract({0.0, false});
        t_sparse.push_back(seconds_since(t0));
      }
      // Adaptive: distance-bound refinement from the field itself.
      std::vector<double> t_adaptive;
      ExtractResult adaptive;
      for (int r = 0; r < settings.runs; ++r) {
        t0 = BenchClock::now();
        adaptive = adaptive_extract(field, s);
        t_adaptive.push_back(seconds_since(t0));
      }
      // For comparison: the same refinement with Occupancy Networks' sign-change rule (MISE).
      std::vector<double> t_mise;
      ExtractResult mise;
      ExtractSettings ms = s;
      ms.refine = RefineRule::kSignChange;
      for (int r = 0; r < settings.runs; ++r) {
        t0 = BenchClock::now();
        mise = adaptive_extract(field, ms);
        t_mise.push_back(seconds_since(t0));
      }
      // Distances: between results (vertices), and of each to the analytic surface (area samples).
      auto cd_to_dense = [&](const Mesh& m) {
        if (m.V.rows() == 0 || dense.V.rows() == 0) return std::nan("");
        return 1000.0 * chamfer(m.V, dense.V).cd_squared();
      };
      auto surface_error = [&](const Mesh& m) {
        if (m.F.rows() == 0) return std::nan("");
        const Points p = sample_surface(m, settings.samples, 7).points;
        double sum = 0;
        for (Eigen::Index i = 0; i < p.rows(); ++i) sum += std::abs(sdf(p.row(i).transpose()));
        return sum / double(p.rows());
      };
      const double voxel = s.box_size / (res - 1);
      struct Method {
        const char* method;
        double evaluations, eval_s, mc_s, total_s;
        const Mesh* mesh;
        bool identical;
      };
      const double adaptive_total = median(t_adaptive);
      const std::vector<Method> table = {
          {"dense", dense_evals, median(t_eval), median(t_mc), median(t_eval) + median(t_mc), &dense, true},
          {"sparse", double(band.active_voxels()), std::nan(""), median(t_sparse), median(t_sparse), &sparse,
           same_mesh(sparse, dense, 1e-9 * voxel)},
          {"adaptive", double(adaptive.evaluations), std::nan(""), std::nan(""), adaptive_total, &adaptive.mesh,
           same_mesh(adaptive.mesh, dense, 0.0)},
          {"signchange", double(mise.evaluations), std::nan(""), std::nan(""), median(t_mise), &mise.mesh,
           same_mesh(mise.mesh, dense, 0.0)}};
      for (const Method& m : table) {
        ExtractBenchRow row;
        row.shape = shape;
        row.resolution = res;
        row.method = m.method;
        row.evaluations = m.evaluations;
        row.dense_evaluations = dense_evals;
        row.eval_seconds = m.eval_s;
        row.mc_seconds = m.mc_s;
        row.total_seconds = m.total_s;
        row.identical = m.identical;
        row.cd_to_dense_x1000 = cd_to_dense(*m.mesh);
        row.mean_abs_sdf = surface_error(*m.mesh);
        row.faces = static_cast<long>(m.mesh->F.rows());
        row.vertices = static_cast<long>(m.mesh->V.rows());
        row.runs = settings.runs;
        if (row.method == "sparse") row.band_build_seconds = band_build;
        if (row.method == "signchange") {
          row.level_cells = mise.level_cells;
          row.level_evaluations = mise.level_evaluations;
          row.area_ratio_to_dense = surface_area(mise.mesh) / surface_area(dense);
        }
        if (row.method == "adaptive") {
          row.level_cells = adaptive.level_cells;
          row.level_evaluations = adaptive.level_evaluations;
          row.coarse_resolution = s.coarse_resolution;
          row.speedup_vs_dense = (median(t_eval) + median(t_mc)) / adaptive_total;
        }
        if (on_row) on_row(row);
        result.rows.push_back(row);
        if (!settings.out.empty())
          write_mesh(settings.out + "/" + shape + "_" + std::to_string(res) + "_" + row.method + ".ply", *m.mesh);
      }
    }
  }
  return result;
}

std::string extract_bench_header() {
  return detail::bench_printf("%-7s %5s %-10s %12s %8s %10s %10s %10s %9s %11s %12s\n", "shape", "res", "method",
                              "evaluations", "eval %", "eval s", "mc s", "total s", "identical", "CD x1000",
                              "mean |sdf|");
}

std::string extract_bench_row_text(const ExtractBenchRow& row) {
  return detail::bench_printf("%-7s %5d %-10s %12.0f %7.2f%% %10.4f %10.4f %10.4f %9s %11.3g %12.3g\n",
                              row.shape.c_str(), row.resolution, row.method.c_str(), row.evaluations,
                              100.0 * row.evaluations / row.dense_evaluations, row.eval_seconds, row.mc_seconds,
                              row.total_seconds, row.identical ? "yes" : "NO", row.cd_to_dense_x1000,
                              row.mean_abs_sdf);
}

std::string extract_bench_text(const ExtractBenchResult& result) {
  std::string text = extract_bench_header();
  for (const ExtractBenchRow& row : result.rows) text += extract_bench_row_text(row);
  return text;
}

Json extract_bench_row_json(const ExtractBenchRow& row) {
  const double cd = row.cd_to_dense_x1000, err = row.mean_abs_sdf;
  Json j = {{"shape", row.shape},
            {"resolution", row.resolution},
            {"method", row.method},
            {"evaluations", row.evaluations},
            {"evaluation_fraction", row.evaluations / row.dense_evaluations},
            {"seconds_median", row.total_seconds},
            {"faces", row.faces},
            {"vertices", row.vertices},
            {"identical_to_dense", row.identical},
            {"cd_to_dense_x1000", std::isfinite(cd) ? Json(cd) : Json(nullptr)},
            {"mean_abs_sdf", std::isfinite(err) ? Json(err) : Json(nullptr)},
            {"runs", row.runs}};
  if (std::isfinite(row.eval_seconds)) j["eval_seconds_median"] = row.eval_seconds;
  if (std::isfinite(row.mc_seconds)) j["mc_seconds_median"] = row.mc_seconds;
  if (row.method == "sparse") j["band_build_seconds"] = row.band_build_seconds;
  if (row.method == "signchange") {
    j["level_cells"] = row.level_cells;
    j["level_evaluations"] = row.level_evaluations;
    j["area_ratio_to_dense"] = row.area_ratio_to_dense;
  }
  if (row.method == "adaptive") {
    j["level_cells"] = row.level_cells;
    j["level_evaluations"] = row.level_evaluations;
    j["coarse_resolution"] = row.coarse_resolution;
    j["speedup_vs_dense"] = row.speedup_vs_dense;
  }
  return j;
}

Json extract_bench_json(const ExtractBenchResult& result) {
  Json rows = Json::array();
  for (const ExtractBenchRow& row : result.rows) rows.push_back(extract_bench_row_json(row));
  return rows;
}

}  // namespace sdfkit
