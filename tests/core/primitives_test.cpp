#include "core/primitives.h"
#include "sdf/orientation.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

TEST_CASE("primitives are closed, outward, and match their closed-form volume and area") {
  const Mesh box = make_box(Vec3(-1, -2, -3), Vec3(1, 2, 3));
  CHECK(signed_volume(box) == doctest::Approx(48.0));
  CHECK(surface_area(box) == doctest::Approx(2 * (2 * 4 + 2 * 6 + 4 * 6)));
  const Mesh sphere = make_icosphere(Vec3(0.1, 0.2, 0.3), 0.5, 5);
  CHECK(signed_volume(sphere) == doctest::Approx(4.0 / 3.0 * M_PI * 0.125).epsilon(2e-3));
  CHECK(surface_area(sphere) == doctest::Approx(4 * M_PI * 0.25).epsilon(2e-3));
  const Mesh uv = make_sphere(Vec3::Zero(), 1.0, 64, 128);
  CHECK(signed_volume(uv) == doctest::Approx(4.0 / 3.0 * M_PI).epsilon(2e-3));
  const Mesh torus = make_torus(Vec3::Zero(), 0.6, 0.2, 128, 64);
  CHECK(signed_volume(torus) == doctest::Approx(2 * M_PI * M_PI * 0.6 * 0.04).epsilon(2e-3));
  // Every edge is shared by exactly two faces, in opposite directions (closed and consistently oriented).
  for (const Mesh* m : {&box, &sphere, &uv, &torus}) CHECK(is_closed_oriented(*m));
}

TEST_CASE("analytic SDFs: sign and value at known points") {
  CHECK(sphere_sdf(Vec3(0, 0, 2), Vec3::Zero(), 1) == doctest::Approx(1));
  CHECK(sphere_sdf(Vec3::Zero(), Vec3::Zero(), 1) == doctest::Approx(-1));
  CHECK(box_sdf(Vec3(0, 0, 0), Vec3(-1, -1, -1), Vec3(1, 1, 1)) == doctest::Approx(-1));
  CHECK(box_sdf(Vec3(2, 2, 1), Vec3(-1, -1, -1), Vec3(1, 1, 1)) == doctest::Approx(std::sqrt(2.0)));
  CHECK(torus_sdf(Vec3(0.6, 0, 0), Vec3::Zero(), 0.6, 0.2) == doctest::Approx(-0.2));
  CHECK(torus_sdf(Vec3(0, 0, 0), Vec3::Zero(), 0.6, 0.2) == doctest::Approx(0.4));
}
