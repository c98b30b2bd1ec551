#include "recon/camera_refine.h"

#include "camera/silhouette.h"
#include "core/error.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

namespace sdfkit {

namespace {

using Vec4 = Eigen::VectorXd;  // the free parameters: 3 rotation components (+ the distance)

struct Scaled {
  Vec3 rotation_deg;
  double ratio;
};

Scaled unscale(const Vec4& x, const CameraRefineSettings& s) {
  const double r = x.size() > 3 ? std::exp(x[3] * std::log1p(s.max_distance_change)) : 1.0;
  return {x.head<3>() * s.max_rotation_deg, r};
}

/// Nelder-Mead (reflection 1, expansion 2, contraction 1/2, shrink 1/2) from x0 with an axis-aligned simplex of
/// edge `step`; ties keep the earlier vertex, so the run is a fixed function of its inputs.
template <class F>
Vec4 nelder_mead(const F& f, const Vec4& x0, double f0, double step, double tol, int budget, int& used, double& fbest) {
  const int dim = static_cast<int>(x0.size());
  std::vector<Vec4> x(dim + 1, x0);
  std::vector<double> fx(dim + 1, std::numeric_limits<double>::infinity());
  fx[0] = f0;
  for (int i = 0; i < dim && used < budget; ++i) {
    x[i + 1] = x0;
    x[i + 1][i] += step;
    fx[i + 1] = f(x[i + 1]);
    ++used;
  }
  if (used >= budget) {
    const auto best = std::min_element(fx.begin(), fx.end()) - fx.begin();
    fbest = fx[best];
    return x[best];
  }
  std::vector<int> order(dim + 1);
  while (used < budget) {
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return fx[a] < fx[b]; });
    const int lo = order[0], hi = order[dim], second = order[dim - 1];
    double size = 0;
    for (int i = 1; i <= dim; ++i) size = std::max(size, (x[order[i]] - x[lo]).cwiseAbs().maxCoeff());
    if (fx[hi] - fx[lo] <= tol && size <= tol * 10) break;
    if (size <= 1e-6) break;
    Vec4 centroid = Vec4::Zero(dim);
    for (int i = 0; i < dim; ++i) centroid += x[order[i]];
    centroid /= dim;
    const Vec4 xr = centroid + (centroid - x[hi]);
    const double fr = f(xr);
    ++used;
    if (fr < fx[lo]) {
      const Vec4 xe = centroid + 2.0 * (centroid - x[hi]);
      const double fe = used < budget ? f(xe) : fr + 1;
      if (used < budget) ++used;
      if (fe < fr) {
        x[hi] = xe;
        fx[hi] = fe;
      } else {
        x[hi] = xr;
        fx[hi] = fr;
      }
      continue;
    }
    if (fr < fx[second]) {
      x[hi] = xr;
      fx[hi] = fr;
      continue;
    }
    if (used >= budget) break;
    const bool outside = fr < fx[hi];
    const Vec4 xc = outside ? Vec4(centroid + 0.5 * (xr - centroid)) : Vec4(centroid + 0.5 * (x[hi] - centroid));
    const double fc = f(xc);
    ++used;
    if (fc < (outside ? fr : fx[hi])) {
      x[hi] = xc;
      fx[hi] = fc;
      continue;
    }
    for (int i = 1; i <= dim && used < budget; ++i) {  // shrink towards the best vertex
      const int k = order[i];
      x[k] = x[lo] + 0.5 * (x[k] - x[lo]);
      fx[k] = f(x[k]);
      ++used;
    }
  }
  int best = 0;
  for (int i = 1; i <= dim; ++i)
    if (fx[i] < fx[best]) best = i;
  fbest = fx[best];
  return x[best];
}

}  // namespace

Camera perturb_camera(const Camera& start, const Vec3& rotation_deg, double distance_ratio) {
  Camera c = start;
  const Vec3 w = rotation_deg * (M_PI / 180.0);
  const double angle = w.norm();
  const Mat3 Q = angle > 0 ? Mat3(Eigen::AngleAxisd(angle, w / angle)) : Mat3::Identity();
  c.R = Q * start.R;
  c.t = distance_ratio * start.t;
  return c;
}

namespace {

/// The optimisation shared by both variants; `iou(camera, mask)` scores one candidate.
CameraRefineResult refine(const std::function<double(const Camera&, const Image&)>& iou, const Image& mask,
                          const Camera& start, const CameraRefineSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  require(settings.max_rotation_deg > 0 && settings.max_distance_change > 0 && settings.initial_step > 0 &&
              settings.max_evaluations > 0 && settings.max_restarts >= 0,
          "camera refinement: bounds, step and evaluation budget must be positive");
  validate_camera(start, "camera refinement: start camera");
  if (mask.empty() || mask.width != start.width || mask.height != start.height)
    throw InvalidInput("camera refinement: the mask is " + std::to_string(mask.width) + "x" +
                       std::to_string(mask.height) + " but the camera's image is " + std::to_string(start.width) +
                       "x" + std::to_string(start.height));
  Image m(mask.width, mask.height, 1);
  double area = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      m.at(x, y) = std::clamp(mask.at(x, y, 0), 0.f, 1.f);
      area += m.at(x, y);
    }
  if (!(area > 0)) throw InvalidInput("camera refinement: the mask has no object pixel (nothing to align to)");

  Camera base = start;  // the local search's centre (the sweep's best)
  const auto objective = [&](const Vec4& x) {
    const double out = (x.cwiseAbs().array() - 1.0).max(0.0).matrix().norm();
    if (out > 0) return 2.0 + out;  // outside the bounds: worse than any camera inside (1 - IoU <= 1)
    const Scaled p = unscale(x, settings);
    return 1.0 - iou(perturb_camera(base, p.rotation_deg, p.ratio), m);
  };

  CameraRefineResult r;
  // Coarse stage: turns about the object's vertical axis, w = delta * (R e_y) in camera-frame axes.
  const Camera start0 = start;
  double f0 = 1.0 - iou(start0, m);
  int used = 1;
  r.iou_before = 1.0 - f0;
  if (settings.sweep_azimuth_deg > 0) {
    require(settings.sweep_step_deg > 0, "camera refinement: sweep step must be positive");
    const Vec3 axis = start0.R.col(1);  // object +y in camera-frame axes
    const int steps = static_cast<int>(std::floor(settings.sweep_azimuth_deg / settings.sweep_step_deg + 1e-9));
    double best_delta = 0;
    for (int k = 1; k <= steps; ++k)
      for (const int sign : {-1, 1}) {
        const double delta = sign * k * settings.sweep_step_deg;
        const double f = 1.0 - iou(perturb_camera(start0, delta * axis, 1.0), m);
        ++used;
        if (f < f0) {
          f0 = f;
          best_delta = delta;
        }
      }
    base = perturb_camera(start0, best_delta * axis, 1.0);
    r.sweep_azimuth_deg = best_delta;
  }
  Vec4 best = Vec4::Zero(settings.refine_distance ? 4 : 3);
  double fbest = f0;
  int local = 0;  // evaluations of the local search (its own budget)
  for (int run = 0; settings.local_search && run <= settings.max_restarts && local < settings.max_evaluations;
       ++run) {
    double f = 0;
    const Vec4 x = nelder_mead(objective, best, fbest, settings.initial_step, settings.tolerance,
                               settings.max_evaluations, local, f);
    const bool improved = f < fbest - 1e-12;
    if (f < fbest) {
      best = x;
      fbest = f;
    }
    if (!improved && run > 0) break;
  }
  const Scaled p = unscale(best, settings);
  r.camera = perturb_camera(base, p.rotation_deg, p.ratio);
  // Both stages as one rotation relative to the start: R_final = Q R_start.
  const Eigen::AngleAxisd q(Mat3(r.camera.R * start.R.transpose()));
  r.rotation_deg = q.axis() * q.angle() * (180.0 / M_PI);
  r.distance_ratio = p.ratio;
  r.iou_after = 1.0 - fbest;
  r.evaluations = used + local;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace

CameraRefineResult refine_camera(const Mesh& mesh, const Image& mask, const Camera& start,
                                 const CameraRefineSettings& settings) {
  require(settings.supersampling >= 1 && settings.supersampling <= 8, "camera refinement: supersampling 1..8");
  const SilhouetteRenderer renderer(mesh, settings.supersampling);
  return refine([&](const Camera& c, const Image& m) { return silhouette_iou(renderer.render(c), m); }, mask, start,
                settings);
}

CameraRefineResult refine_camera(const MeshForCamera& mesh_for, const Image& mask, const Camera& start,
                                 const CameraRefineSettings& settings) {
  require(static_cast<bool>(mesh_for), "camera refinement: no mesh function");
  const auto iou = [&](const Camera& c, const Image& m) {
    const Mesh mesh = mesh_for(c);
    if (mesh.empty()) return 0.0;
    return silhouette_iou(SilhouetteRenderer(mesh, settings.supersampling).render(c), m);
  };
  return refine(iou, mask, start, settings);
}

}  // namespace sdfkit
