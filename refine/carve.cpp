#include "refine/carve.h"

#include "camera/camera.h"
#include "camera/silhouette.h"
#include "core/error.h"
#include "core/primitives.h"
#include "extract/adaptive.h"
#include "extract/cleanup.h"
#include "sdf/winding.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

namespace sdfkit {

void validate_carve_settings(const CarveSettings& s) {
  require(s.resolution >= 3 && s.resolution <= 1025, "carve: resolution must be 3..1025 grid points per axis");
  require(s.threshold > 0 && s.threshold < 1, "carve: threshold must be in (0, 1)");
  require(std::isfinite(s.box_size) && s.box_size > 0 && s.box_min.allFinite(), "carve: the box must be finite and non-empty");
  require(s.min_component_fraction >= 0 && s.min_component_fraction <= 1,
          "carve: min_component_fraction must be in [0, 1]");
  require(s.complete_erode >= 0 && s.complete_erode <= 64, "carve: complete_erode must be 0..64 pixels");
  require(s.complete_views >= 0, "carve: complete_views must be >= 0 (0: a majority of the views)");
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

namespace {

/// 1 where the target's silhouette (alpha >= threshold) is not covered by `covered` (coverage < 0.5), less `erode`
/// pixels from the edge of those regions (3 x 3 erosions; outside the image counts as 0).
Image unexplained_pixels(const Image& alpha, const Image& covered, double threshold, int erode) {
  Image u(alpha.width, alpha.height, 1);
  for (int y = 0; y < alpha.height; ++y)
    for (int x = 0; x < alpha.width; ++x)
      u.at(x, y) = alpha.at(x, y) >= threshold && covered.at(x, y) < 0.5f ? 1.0f : 0.0f;
  const auto set = [&u](int x, int y) { return x >= 0 && y >= 0 && x < u.width && y < u.height && u.at(x, y) > 0; };
  for (int pass = 0; pass < erode; ++pass) {
    Image e(u.width, u.height, 1);
    for (int y = 0; y < u.height; ++y)
      for (int x = 0; x < u.width; ++x) {
        bool all = true;
        for (int dy = -1; dy <= 1 && all; ++dy)
          for (int dx = -1; dx <= 1 && all; ++dx) all = set(x + dx, y + dy);
        e.at(x, y) = all ? 1.0f : 0.0f;
      }
    u = std::move(e);
  }
  return u;
}

}  // namespace

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
  // With `unexplained` (one image per view), the starting mesh's term becomes min(0.5 - w, 0.5 - U_(k)), U_(k) the
  // k-th largest of the views' unexplained values at the point (k = complete_views, 0 = a majority): also inside
  // where k views see the point on pixels the carved mesh leaves unexplained.
  const int n_views = static_cast<int>(views.size());
  const int need = settings.complete_views > 0 ? std::min(settings.complete_views, n_views) : n_views / 2 + 1;
  const auto make_field = [&](const std::vector<Image>* unexplained) -> BatchField {
    return [&, unexplained](const Points& P, Eigen::VectorXd& values) {
      values.resize(P.rows());
      Eigen::VectorXd added;
      if (unexplained) added.resize(P.rows());
      tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
        std::vector<double> u;  // the views' unexplained values at a point (the need-th largest decides)
        if (unexplained) u.reserve(views.size());
        for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
          const Vec3 p = P.row(i).transpose();
          double lowest = 1.0;
          u.clear();
          for (size_t k = 0; k < views.size(); ++k) {
            const TargetView& v = views[k];
            double depth = 0;
            const Eigen::Vector2d q = project(v.camera, p, &depth);
            lowest = std::min(lowest, depth > 0 ? sample_alpha(v.alpha, q.x(), q.y()) : 0.0);
            if (lowest <= 0) break;
            if (unexplained) u.push_back(depth > 0 ? sample_alpha((*unexplained)[k], q.x(), q.y()) : 0.0);
          }
          values[i] = threshold - lowest;
          if (unexplained) {
            // Inside when at least `need` views see p on unexplained pixels: 0.5 - their need-th largest value.
            double kth = 0.0;
            if (u.size() == views.size()) {  // every view sampled (no early exit: p is inside the hull)
              std::nth_element(u.begin(), u.begin() + (need - 1), u.end(), std::greater<double>());
              kth = u[static_cast<size_t>(need - 1)];
            }
            added[i] = 0.5 - kth;
          }
        }
      });
      if (winding) {
        Eigen::VectorXd w = (0.5 - winding->query(P).array()).matrix();
        if (unexplained) w = w.cwiseMin(added);
        values = values.cwiseMax(w);
      }
    };
  };
  ExtractSettings es;
  es.resolution = settings.resolution;
  es.box_min = settings.box_min;
  es.box_size = settings.box_size;
  es.close_boundary = true;
  CleanupSettings cs;
  cs.min_component_fraction = settings.min_component_fraction;
  ExtractResult r = dense_extract(make_field(nullptr), es);
  // marching cubes gives no colours: refine starts the carved mesh grey
  Mesh out = r.mesh.F.rows() > 0 ? cleanup(r.mesh, cs) : Mesh{};
  long unexplained_count = 0;
  double carved_volume = 0;
  if (init && settings.complete) {
    // The silhouette pixels the carved solid leaves uncovered, eroded so that a contour's sliver does not count.
    carved_volume = out.F.rows() > 0 ? signed_volume(out) : 0.0;
    std::unique_ptr<SilhouetteRenderer> sharp;
    if (out.F.rows() > 0) sharp = std::make_unique<SilhouetteRenderer>(out, 3);
    std::vector<Image> unexplained(views.size());
    for (size_t k = 0; k < views.size(); ++k) {
      const Image& alpha = views[k].alpha;
      const Image covered = sharp ? sharp->render(views[k].camera) : Image(alpha.width, alpha.height, 1);
      unexplained[k] = unexplained_pixels(alpha, covered, threshold, settings.complete_erode);
      for (const float v : unexplained[k].data) unexplained_count += v > 0;
    }
    if (unexplained_count > 0) {
      r = dense_extract(make_field(&unexplained), es);
      out = r.mesh.F.rows() > 0 ? cleanup(r.mesh, cs) : Mesh{};
    }
  }
  if (r.mesh.F.rows() == 0)
    throw InvalidInput("carve: nothing left: no grid point lies inside every view's silhouette" +
                       std::string(init ? " and inside the starting mesh" : ""));
  if (report) {
    report->evaluations = r.evaluations;
    report->init_faces = init ? static_cast<long>(init->F.rows()) : 0;
    report->init_volume = init ? signed_volume(*init) : 0.0;
    report->faces = static_cast<long>(out.F.rows());
    report->vertices = static_cast<long>(out.V.rows());
    report->volume = signed_volume(out);
    report->unexplained_pixels = unexplained_count;
    report->carved_volume = init && settings.complete ? carved_volume : report->volume;
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return out;
}

}  // namespace sdfkit
