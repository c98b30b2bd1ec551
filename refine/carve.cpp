#include "refine/carve.h"

#include "camera/camera.h"
#include "core/error.h"
#include "core/primitives.h"
#include "extract/adaptive.h"
#include "extract/cleanup.h"
#include "sdf/winding.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

namespace sdfkit {

void validate_carve_settings(const CarveSettings& s) {
  require(s.resolution >= 3 && s.resolution <= 1025, "carve: resolution must be 3..1025 grid points per axis");
  require(s.threshold > 0 && s.threshold < 1, "carve: threshold must be in (0, 1)");
  require(std::isfinite(s.box_size) && s.box_size > 0 && s.box_min.allFinite(), "carve: the box must be finite and non-empty");
  require(s.min_component_fraction >= 0 && s.min_component_fraction <= 1,
          "carve: min_component_fraction must be in [0, 1]");
}

double sample_alpha(const Image& alpha, double x, double y) {
  if (!std::isfinite(x) || !std::isfinite(y)) return 0.0;
  const double u = x - 0.5, v = y - 0.5;
  if (u < -1 || v < -1 || u > alpha.width || v > alpha.height) return 0.0;
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  const double fx = u - x0, fy = v - y0;
  double s = 0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int xx = x0 + dx, yy = y0 + dy;
      if (xx < 0 || yy < 0 || xx >= alpha.width || yy >= alpha.height) continue;
      s += (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * alpha.at(xx, yy);
    }
  return s;
}

Mesh carve_mesh(const std::vector<TargetView>& views, const Mesh* init, const CarveSettings& settings,
                CarveReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  validate_carve_settings(settings);
  require(!views.empty(), "carve: no views");
  std::unique_ptr<WindingNumber> winding;
  if (init) {
    require(init->F.rows() > 0, "carve: the starting mesh has no faces");
    require(init->V.allFinite(), "carve: the starting mesh has non-finite vertices");
    winding = std::make_unique<WindingNumber>(*init);
  }
  const double threshold = settings.threshold;
  // f = max(threshold - min_v alpha_v, 0.5 - w): negative inside every silhouette and inside the starting mesh.
  BatchField field = [&](const Points& P, Eigen::VectorXd& values) {
    values.resize(P.rows());
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
        const Vec3 p = P.row(i).transpose();
        double lowest = 1.0;
        for (const TargetView& v : views) {
          double depth = 0;
          const Eigen::Vector2d q = project(v.camera, p, &depth);
          lowest = std::min(lowest, depth > 0 ? sample_alpha(v.alpha, q.x(), q.y()) : 0.0);
          if (lowest <= 0) break;
        }
        values[i] = threshold - lowest;
      }
    });
    if (winding) {
      const Eigen::VectorXd w = winding->query(P);
      values = values.cwiseMax((0.5 - w.array()).matrix());
    }
  };
  ExtractSettings es;
  es.resolution = settings.resolution;
  es.box_min = settings.box_min;
  es.box_size = settings.box_size;
  es.close_boundary = true;
  ExtractResult r = dense_extract(field, es);
  if (r.mesh.F.rows() == 0)
    throw InvalidInput("carve: nothing left: no grid point lies inside every view's silhouette" +
                       std::string(init ? " and inside the starting mesh" : ""));
  CleanupSettings cs;
  cs.min_component_fraction = settings.min_component_fraction;
  const Mesh out = cleanup(r.mesh, cs);  // marching cubes gives no colours: refine starts the carved mesh grey
  if (report) {
    report->evaluations = r.evaluations;
    report->init_faces = init ? static_cast<long>(init->F.rows()) : 0;
    report->init_volume = init ? signed_volume(*init) : 0.0;
    report->faces = static_cast<long>(out.F.rows());
    report->vertices = static_cast<long>(out.V.rows());
    report->volume = signed_volume(out);
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return out;
}

}  // namespace sdfkit
