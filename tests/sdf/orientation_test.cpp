#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/orientation.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("orientation: flipped faces and inside-out parts become outward; volume positive") {
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
