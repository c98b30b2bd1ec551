#include "core/primitives.h"
#include "core/random.h"
#include "sdf/distance.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("exact distance: BVH equals brute force; closest point lies on the mesh") {
  const Mesh t = make_torus(Vec3(0.1, 0, 0), 0.6, 0.2, 40, 20);
  const MeshDistance dist(t);
  Rng rng(11);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p(rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-0.6, 0.6));
    const ClosestPoint c = dist.closest(p);
    CHECK(c.distance == doctest::Approx(MeshDistance::brute_force(t, p)).epsilon(1e-12));
    CHECK((c.point - p).norm() == doctest::Approx(c.distance).epsilon(1e-12));
    REQUIRE(c.face >= 0);
  }
}

TEST_CASE("exact distance to a box mesh equals the analytic unsigned distance") {
  const Vec3 lo(-0.3, -0.2, -0.1), hi(0.4, 0.2, 0.3);
  const Mesh b = make_box(lo, hi);
  const MeshDistance dist(b);
  Rng rng(5);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    CHECK(dist(p) == doctest::Approx(std::abs(box_sdf(p, lo, hi))).epsilon(1e-12).scale(1));
  }
}

TEST_CASE("closest point on triangle: vertex, edge, face and degenerate regions") {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  CHECK((closest_point_on_triangle(Vec3(-1, -1, 0), a, b, c) - a).norm() < 1e-15);
  CHECK((closest_point_on_triangle(Vec3(0.5, -1, 2), a, b, c) - Vec3(0.5, 0, 0)).norm() < 1e-15);
  CHECK((closest_point_on_triangle(Vec3(0.2, 0.2, 3), a, b, c) - Vec3(0.2, 0.2, 0)).norm() < 1e-15);
  CHECK((closest_point_on_triangle(Vec3(1, 1, 0), a, b, c) - Vec3(0.5, 0.5, 0)).norm() < 1e-15);
  // Zero-area triangle (all on a line): distance to the segment.
  const Vec3 q = closest_point_on_triangle(Vec3(0.5, 1, 0), a, b, Vec3(2, 0, 0));
  CHECK((q - Vec3(0.5, 0, 0)).norm() < 1e-12);
}
