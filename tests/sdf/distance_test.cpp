#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/winding.h"

#include <cmath>

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("exact distance: BVH equals brute force, closest point lies on the mesh") {
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

TEST_CASE("ray winding: signed crossings equal the winding number of closed meshes, grazing rays refused") {
  // Two interpenetrating closed parts (w = 2 where they overlap) and a torus (a ray may cross four sheets).
  const Mesh two = concatenate(make_box(Vec3::Constant(-0.5), Vec3::Constant(0.1)),
                               make_box(Vec3::Constant(-0.1), Vec3::Constant(0.5)));
  const Mesh torus = make_torus(Vec3::Zero(), 0.55, 0.2, 40, 20);
  for (const Mesh* m : {&two, &torus}) {
    const MeshDistance dist(*m);
    Rng rng(3);
    int certain = 0, twos = 0;
    for (int i = 0; i < 400; ++i) {
      const Vec3 p(rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8));
      const Vec3 dir(rng.normal(), rng.normal(), rng.normal());
      int w = -99;
      if (!dist.ray_winding(p, dir, &w)) continue;
      ++certain;
      twos += w == 2;
      CHECK(w == static_cast<int>(std::lround(WindingNumber::brute_force(*m, p))));
    }
    CHECK(certain >= 398);  // random directions almost never graze an edge
    if (m == &two) CHECK(twos > 0);
  }
  // A ray through a box corner (a vertex shared by several triangles) or along a face is not certain.
  const Mesh box = make_box(Vec3::Constant(-0.5), Vec3::Constant(0.5));
  const MeshDistance dist(box);
  int w = -99;
  CHECK_FALSE(dist.ray_winding(Vec3::Zero(), Vec3(1, 1, 1), &w));
  CHECK_FALSE(dist.ray_winding(Vec3(-1, 0.5, 0.2), Vec3(1, 0, 0), &w));
  CHECK(w == -99);
  CHECK(dist.ray_winding(Vec3(0.1, 0.2, 0.05), Vec3(0.3, 1, 0.2), &w));
  CHECK(w == 1);
  CHECK(dist.ray_winding(Vec3(0.9, 0.2, 0.05), Vec3(-1, 0.1, 0.2), &w));
  CHECK(w == 0);
}
