#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/orientation.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("orientation: flipped faces and inside-out parts become outward, volume positive") {
  const Mesh s = make_icosphere(Vec3::Zero(), 1.0, 3);
  CHECK(is_closed_oriented(s));
  const Mesh flipped = test::flip_every(s, 3);
  CHECK_FALSE(is_closed_oriented(flipped));
  OrientationReport r;
  const Mesh fixed = orient_consistently(flipped, &r);
  CHECK(is_closed_oriented(fixed));
  CHECK(r.closed);
  CHECK(r.components == 1);
  CHECK(signed_volume(fixed) == doctest::Approx(signed_volume(s)));

  Mesh inverted = s;
  inverted.F.col(1).swap(inverted.F.col(2));
  const Mesh back = orient_consistently(inverted, &r);
  CHECK(r.inverted_components == 1);
  CHECK(signed_volume(back) > 0);
}

TEST_CASE("orientation: an inner shell bounding a cavity keeps its inward orientation") {
  Mesh inner = make_icosphere(Vec3::Zero(), 0.5, 2);
  inner.F.col(1).swap(inner.F.col(2));  // inward: a hollow ball
  const Mesh hollow = concatenate(make_icosphere(Vec3::Zero(), 1.0, 2), inner);
  OrientationReport r;
  const Mesh out = orient_consistently(hollow, &r);
  CHECK(r.components == 2);
  CHECK(r.flipped_faces == 0);
  CHECK(signed_volume(out) == doctest::Approx(signed_volume(hollow)));
}

TEST_CASE("orientation: open box stays open, outward") {
  OrientationReport r;
  const Mesh b = orient_consistently(test::flip_every(test::open_box(), 2), &r);
  CHECK_FALSE(r.closed);
  CHECK(r.closed_components == 0);
  // Every face points away from the box centre.
  for (Eigen::Index f = 0; f < b.F.rows(); ++f) {
    const Vec3 a = b.V.row(b.F(f, 0)), e1 = b.V.row(b.F(f, 1)).transpose() - a, e2 = b.V.row(b.F(f, 2)).transpose() - a;
    CHECK(e1.cross(e2).dot(a) > 0);
  }
}

TEST_CASE("orientation: edge neighbours of closed meshes and balanced edges") {
  const Mesh t = make_torus(Vec3::Zero(), 0.55, 0.2, 12, 8);
  const auto across = closed_edge_neighbours(t);
  REQUIRE(across.size() == static_cast<size_t>(t.F.rows()));
  for (Eigen::Index f = 0; f < t.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      // The face across edge (a, b) holds the edge as (b, a).
      const int32_t a = t.F(f, k), b = t.F(f, (k + 1) % 3);
      const int32_t g = across[static_cast<size_t>(f)][static_cast<size_t>(k)];
      REQUIRE(g >= 0);
      CHECK(g != f);
      bool twin = false;
      for (int j = 0; j < 3; ++j) twin = twin || (t.F(g, j) == b && t.F(g, (j + 1) % 3) == a);
      CHECK(twin);
    }
  CHECK(edges_balanced(t));
  CHECK(closed_edge_neighbours(test::open_box()).empty());
  CHECK_FALSE(edges_balanced(test::open_box()));
  // Two interpenetrating closed parts: balanced, and every edge still has one neighbour. One flipped face: neither.
  const Mesh two = concatenate(make_box(Vec3::Constant(-0.5), Vec3::Constant(0.1)),
                               make_box(Vec3::Constant(-0.1), Vec3::Constant(0.5)));
  CHECK(edges_balanced(two));
  CHECK_FALSE(closed_edge_neighbours(two).empty());
  Mesh flipped = t;
  std::swap(flipped.F(0, 1), flipped.F(0, 2));
  CHECK(closed_edge_neighbours(flipped).empty());
  CHECK_FALSE(edges_balanced(flipped));
}
