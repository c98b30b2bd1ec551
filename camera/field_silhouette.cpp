#include "camera/field_silhouette.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {

FieldSilhouetteRays find_silhouette_points(const Camera& camera, const FieldSilhouetteSettings& st,
                                           const PointField& field) {
  require(st.size >= 1 && st.radius > 0 && std::isfinite(st.radius) && st.samples >= 1 &&
              (st.refine == 0 || st.refine == 4),
          "field silhouette: need size >= 1, radius > 0, samples >= 1 and refine 0 or 4");
  validate_camera(camera, "field silhouette: camera");
  const int n = st.size * st.size;
  FieldSilhouetteRays out;
  out.size = st.size;
  out.points.setZero(n, 3);
  out.hit.assign(static_cast<size_t>(n), 0);
  out.value.setZero(n);
  // Chords of the rays inside the sphere.
  std::vector<Ray> rays(static_cast<size_t>(n));
  std::vector<double> s0(static_cast<size_t>(n), 0), step(static_cast<size_t>(n), 0);
  std::vector<int> hits;
  const double sx = static_cast<double>(camera.width) / st.size, sy = static_cast<double>(camera.height) / st.size;
  for (int i = 0; i < st.size; ++i)
    for (int j = 0; j < st.size; ++j) {
      const int p = i * st.size + j;
      const Ray r = pixel_ray(camera, (j + 0.5) * sx, (i + 0.5) * sy);
      rays[static_cast<size_t>(p)] = r;
      // |o + s d|^2 = radius^2 with |d| = 1.
      const double b = r.origin.dot(r.direction), c = r.origin.squaredNorm() - st.radius * st.radius;
      const double disc = b * b - c;
      const double mid = -b;
      out.points.row(p) = (r.origin + mid * r.direction).cast<float>().transpose();
      if (disc <= 0) continue;
      const double half = std::sqrt(disc), a = std::max(mid - half, 0.0), e = mid + half;
      if (e <= a) continue;
      out.hit[static_cast<size_t>(p)] = 1;
      s0[static_cast<size_t>(p)] = a;
      step[static_cast<size_t>(p)] = (e - a) / st.samples;
      hits.push_back(p);
    }
  if (hits.empty()) return out;
  auto point_at = [&](int p, double s) {
    const Ray& r = rays[static_cast<size_t>(p)];
    return (r.origin + s * r.direction).cast<float>().transpose();
  };
  // Round 1: uniform samples (interval midpoints).
  const auto H = static_cast<Eigen::Index>(hits.size());
  PointsF pts(H * st.samples, 3);
  for (Eigen::Index h = 0; h < H; ++h) {
    const int p = hits[static_cast<size_t>(h)];
    for (int k = 0; k < st.samples; ++k)
      pts.row(h * st.samples + k) = point_at(p, s0[static_cast<size_t>(p)] + (k + 0.5) * step[static_cast<size_t>(p)]);
  }
  Eigen::VectorXf v;
  field(pts, v);
  require(v.size() == pts.rows(), "field silhouette: the field returned the wrong number of values");
  out.evaluations += pts.rows();
  std::vector<double> best_s(hits.size());
  std::vector<float> best_v(hits.size());
  for (Eigen::Index h = 0; h < H; ++h) {
    const int p = hits[static_cast<size_t>(h)];
    int kb = 0;
    for (int k = 1; k < st.samples; ++k)
      if (v[h * st.samples + k] < v[h * st.samples + kb]) kb = k;
    best_s[static_cast<size_t>(h)] = s0[static_cast<size_t>(p)] + (kb + 0.5) * step[static_cast<size_t>(p)];
    best_v[static_cast<size_t>(h)] = v[h * st.samples + kb];
    out.points.row(p) = point_at(p, best_s[static_cast<size_t>(h)]);
  }
  // Round 2: +-1/4 and +-1/2 of the spacing about the best sample (ties keep the earlier, nearer candidate).
  if (st.refine == 4) {
    static constexpr double kOffsets[4] = {-0.5, -0.25, 0.25, 0.5};
    PointsF ref(H * 4, 3);
    for (Eigen::Index h = 0; h < H; ++h) {
      const int p = hits[static_cast<size_t>(h)];
      for (int k = 0; k < 4; ++k)
        ref.row(h * 4 + k) = point_at(p, best_s[static_cast<size_t>(h)] + kOffsets[k] * step[static_cast<size_t>(p)]);
    }
    field(ref, v);
    require(v.size() == ref.rows(), "field silhouette: the field returned the wrong number of values");
    out.evaluations += ref.rows();
    for (Eigen::Index h = 0; h < H; ++h) {
      const int p = hits[static_cast<size_t>(h)];
      for (int k = 0; k < 4; ++k)
        if (v[h * 4 + k] < best_v[static_cast<size_t>(h)]) {
          best_v[static_cast<size_t>(h)] = v[h * 4 + k];
          out.points.row(p) = ref.row(h * 4 + k);
        }
    }
  }
  for (Eigen::Index h = 0; h < H; ++h) {
    const int p = hits[static_cast<size_t>(h)];
    out.value[p] = best_v[static_cast<size_t>(h)];
  }
  return out;
}

Eigen::VectorXf soft_coverage(const FieldSilhouetteRays& rays, const Eigen::VectorXf& value, double temperature,
                              Eigen::VectorXf* dalpha) {
  require(temperature > 0, "field silhouette: the temperature must be positive");
  const auto n = static_cast<Eigen::Index>(rays.hit.size());
  require(value.size() == n, "field silhouette: one value per pixel");
  Eigen::VectorXf alpha = Eigen::VectorXf::Zero(n);
  if (dalpha) dalpha->setZero(n);
  for (Eigen::Index p = 0; p < n; ++p) {
    if (!rays.hit[static_cast<size_t>(p)]) continue;
    const double a = 1.0 / (1.0 + std::exp(value[p] / temperature));
    alpha[p] = static_cast<float>(a);
    if (dalpha) (*dalpha)[p] = static_cast<float>(-a * (1 - a) / temperature);
  }
  return alpha;
}

}  // namespace sdfkit
