#include "camera/field_silhouette.h"

#include "camera/camera.h"
#include "core/error.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {

/// Signed distance to a sphere of radius r at c.
PointField sphere_field(const Vec3& c, double r, long* calls = nullptr) {
  return [c, r, calls](const PointsF& p, Eigen::VectorXf& v) {
    if (calls) ++*calls;
    v.resize(p.rows());
    for (Eigen::Index i = 0; i < p.rows(); ++i)
      v[i] = static_cast<float>((p.row(i).cast<double>().transpose() - c).norm() - r);
  };
}

/// Distance from c to the ray's line (origin o, unit direction d).
double line_distance(const Ray& ray, const Vec3& c) {
  const Vec3 w = c - ray.origin;
  return (w - w.dot(ray.direction) * ray.direction).norm();
}

}  // namespace

TEST_CASE("field silhouette: each ray's smallest value of a sphere's SDF is its distance to the centre minus r") {
  const Vec3 c(0.1, -0.05, 0.08);
  const double r = 0.45;
  const Camera cam = look_at(35, 25, 2.5);
  FieldSilhouetteSettings st;
  st.size = 28;
  long calls = 0;
  const FieldSilhouetteRays rays = find_silhouette_points(cam, st, sphere_field(c, r, &calls));
  REQUIRE(rays.points.rows() == 28 * 28);
  CHECK(calls == 2);  // one batch per round
  int hits = 0, inside = 0;
  for (int i = 0; i < 28; ++i)
    for (int j = 0; j < 28; ++j) {
      const int p = i * 28 + j;
      const Ray ray = pixel_ray(cam, (j + 0.5) * 137.0 / 28, (i + 0.5) * 137.0 / 28);
      // The ray meets the bounding sphere exactly when its line passes within the radius of the origin.
      CHECK(static_cast<bool>(rays.hit[static_cast<size_t>(p)]) == (line_distance(ray, Vec3::Zero()) < st.radius));
      if (!rays.hit[static_cast<size_t>(p)]) continue;
      ++hits;
      // Closest approach: the value at p* is within the search's resolution of the exact minimum, and p* lies on
      // the ray inside the bounding sphere.
      const double exact = line_distance(ray, c) - r;
      CHECK(rays.value[p] >= exact - 1e-5);
      CHECK(rays.value[p] <= exact + 0.01);
      const Vec3 q = rays.points.row(p).cast<double>().transpose();
      CHECK(line_distance(ray, q) < 1e-5);
      CHECK(q.norm() <= st.radius + 1e-5);
      inside += exact < 0;
    }
  CHECK(hits == static_cast<int>(rays.evaluations / (st.samples + st.refine)));
  CHECK(inside > 30);
  CHECK(hits > inside);
}

TEST_CASE("field silhouette: soft coverage is a sigmoid of the value, its derivative matches finite differences") {
  const Camera cam = look_at(0, 20, 2.5);
  FieldSilhouetteSettings st;
  st.size = 14;
  const FieldSilhouetteRays rays = find_silhouette_points(cam, st, sphere_field(Vec3::Zero(), 0.5));
  const double T = 0.05;
  Eigen::VectorXf dalpha;
  const Eigen::VectorXf alpha = soft_coverage(rays, rays.value, T, &dalpha);
  for (Eigen::Index p = 0; p < alpha.size(); ++p) {
    if (!rays.hit[static_cast<size_t>(p)]) {
      CHECK(alpha[p] == 0.0f);
      CHECK(dalpha[p] == 0.0f);
      continue;
    }
    CHECK(alpha[p] == doctest::Approx(1.0 / (1.0 + std::exp(rays.value[p] / T))).epsilon(1e-5));
    Eigen::VectorXf up = rays.value, down = rays.value;
    const float h = 1e-3f;
    up[p] += h;
    down[p] -= h;
    const double fd = (soft_coverage(rays, up, T)[p] - soft_coverage(rays, down, T)[p]) / (2.0 * h);
    CHECK(dalpha[p] == doctest::Approx(fd).epsilon(2e-2).scale(1e-3));
  }
  // The centre pixel sees the sphere, a corner does not.
  CHECK(alpha[7 * 14 + 7] > 0.99f);
  CHECK(alpha[0] < 0.01f);
}

TEST_CASE("field silhouette: bad settings and a field returning the wrong count are refused") {
  const Camera cam = look_at(0, 20, 2.5);
  FieldSilhouetteSettings st;
  st.size = 0;
  CHECK_THROWS_AS(find_silhouette_points(cam, st, sphere_field(Vec3::Zero(), 0.5)), InvalidInput);
  st.size = 8;
  st.refine = 2;
  CHECK_THROWS_AS(find_silhouette_points(cam, st, sphere_field(Vec3::Zero(), 0.5)), InvalidInput);
  st.refine = 4;
  const PointField short_field = [](const PointsF& p, Eigen::VectorXf& v) { v.setZero(p.rows() / 2); };
  CHECK_THROWS_AS(find_silhouette_points(cam, st, short_field), InvalidInput);
  const FieldSilhouetteRays rays = find_silhouette_points(cam, st, sphere_field(Vec3::Zero(), 0.5));
  CHECK_THROWS_AS(soft_coverage(rays, rays.value, 0.0), InvalidInput);
}
