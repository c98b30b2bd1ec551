#include "synth/parts.h"

#include "core/error.h"
#include "core/primitives.h"
#include "synth_test_util.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;
using test::closed_and_oriented;
using test::min_width;

namespace {
void check_part(const Mesh& m, double expected_volume, double rel_tol) {
  CHECK(closed_and_oriented(m));
  const double v = signed_volume(m);
  CHECK(v > 0);
  if (expected_volume > 0) CHECK(v == doctest::Approx(expected_volume).epsilon(rel_tol));
}
const Mat3 kTilt = (rot_x(0.3) * rot_y(-0.7) * rot_z(1.1));
}  // namespace

TEST_CASE("oriented boxes, bars and hexahedra are closed with the exact volume") {
  check_part(make_box_part(Vec3(1, 2, 3), Vec3(0.5, 0.2, 0.1)), 8 * 0.5 * 0.2 * 0.1, 1e-12);
  check_part(make_box_part(Vec3(1, 2, 3), Vec3(0.5, 0.2, 0.1), kTilt), 8 * 0.5 * 0.2 * 0.1, 1e-12);
  const Mesh bar = make_bar(Vec3(0, 0, 0), Vec3(1, 1, 0), 0.1, 0.05, Vec3::UnitZ());
  check_part(bar, std::sqrt(2.0) * 0.1 * 0.05, 1e-12);
  CHECK(min_width(bar) == doctest::Approx(0.05));
  // A bar along `up` still works (the frame falls back to another perpendicular).
  check_part(make_bar(Vec3(0, 0, 0), Vec3(0, 2, 0), 0.1, 0.1, Vec3::UnitY()), 2 * 0.01, 1e-12);
  // Hexahedron from a left-handed corner order is re-oriented outward.
  std::array<Vec3, 8> c;
  for (int i = 0; i < 8; ++i) c[i] = Vec3((i & 1) ? 1 : 0, (i & 2) ? 1 : 0, (i & 4) ? -1 : 0);
  check_part(make_hexahedron(c), 1.0, 1e-12);
  // A frustum-like tapered slab: volume of a prismatoid with parallel rectangular ends.
  for (int i = 0; i < 8; ++i) {
    const double s = (i & 4) ? 0.5 : 1.0;
    c[i] = Vec3(((i & 1) ? 1 : -1) * s, ((i & 2) ? 1 : -1) * s, (i & 4) ? 1 : 0);
  }
  // Prismatoid: h/6 (A0 + 4 Am + A1) with A0 = 4, A1 = 1, Am = (1.5)^2 = 2.25.
  check_part(make_hexahedron(c), (4 + 4 * 2.25 + 1) / 6.0, 1e-9);
}

TEST_CASE("mirroring a part keeps it outward-facing") {
  const Mesh box = make_box_part(Vec3(1, 0, 0), Vec3(0.3, 0.2, 0.1), kTilt);
  const Mat3 mirror = Vec3(-1, 1, 1).asDiagonal();
  const Mesh m = transformed(box, mirror, Vec3(0, 1, 0));
  check_part(m, signed_volume(box), 1e-12);
  CHECK(m.V(0, 0) == doctest::Approx(-box.V(0, 0)));
}

TEST_CASE("rounded boxes approach the exact rounded-box volume") {
  const Vec3 h(0.5, 0.3, 0.2);
  const double r = 0.1;
  // Exact: inner box + face slabs + quarter cylinders on edges + sphere at corners.
  const Vec3 a = 2 * (h - Vec3::Constant(r));
  const double exact = a.prod() + 2 * r * (a.x() * a.y() + a.y() * a.z() + a.x() * a.z()) +
                       M_PI * r * r * (a.x() + a.y() + a.z()) + 4.0 / 3.0 * M_PI * r * r * r;
  const Mesh coarse = make_rounded_box(Vec3(0, 0, 0), h, r, kTilt, 2);
  const Mesh fine = make_rounded_box(Vec3(0, 0, 0), h, r, kTilt, 12);
  check_part(coarse, exact, 0.02);
  check_part(fine, exact, 0.001);
  CHECK(std::abs(signed_volume(fine) - exact) < std::abs(signed_volume(coarse) - exact));
  // Every vertex lies on the rounded surface: distance to the inner box equals r.
  const Mesh axis = make_rounded_box(Vec3(0, 0, 0), h, r, Mat3::Identity(), 3);
  for (Eigen::Index i = 0; i < axis.V.rows(); ++i)
    CHECK(box_sdf(axis.V.row(i).transpose(), -(h - Vec3::Constant(r)), h - Vec3::Constant(r)) ==
          doctest::Approx(r).epsilon(1e-9));
  // Radius 0 falls back to a plain box.
  check_part(make_rounded_box(Vec3(0, 0, 0), h, 0.0), 8 * h.prod(), 1e-12);
}

TEST_CASE("ellipsoids, cylinders, cones and tori converge to their closed-form volumes") {
  check_part(make_ellipsoid(Vec3(1, 1, 1), Vec3(0.3, 0.2, 0.1), kTilt, 16), 4.0 / 3.0 * M_PI * 0.3 * 0.2 * 0.1, 0.01);
  // Polygonal prism with n sides: (n/2) r^2 sin(2 pi / n) h exactly.
  const int n = 12;
  const double prism = 0.5 * n * 0.2 * 0.2 * std::sin(2 * M_PI / n) * 1.5;
  check_part(make_cylinder(Vec3(0, 0, 0), Vec3(0, 1.5, 0), 0.2, n), prism, 1e-9);
  check_part(make_cylinder(Vec3(0, 0, 0), Vec3(0.3, -1.0, 0.7), 0.2, n), 0, 0);
  // Pointed cone: one third of the prism.
  const double pyramid = prism / 3.0;
  check_part(make_cone(Vec3(0, 0, 0), Vec3(0, 1.5, 0), 0.2, 0.0, n), pyramid, 1e-9);
  check_part(make_cone(Vec3(0, 0, 0), Vec3(0, 1.5, 0), 0.0, 0.2, n), pyramid, 1e-9);
  // Frustum of a polygonal pyramid: h/3 (A0 + A1 + sqrt(A0 A1)).
  const double A0 = 0.5 * n * 0.04 * std::sin(2 * M_PI / n), A1 = 0.5 * n * 0.01 * std::sin(2 * M_PI / n);
  check_part(make_cone(Vec3(0, 0, 0), Vec3(0, 0, 1), 0.2, 0.1, n), (A0 + A1 + std::sqrt(A0 * A1)) / 3.0, 1e-9);
  check_part(make_torus_part(Vec3(0, 1, 0), Vec3(1, 1, 0), 0.5, 0.1, 64, 32), 2 * M_PI * M_PI * 0.5 * 0.01, 0.01);
  CHECK_THROWS_AS(make_cone(Vec3(0, 0, 0), Vec3(0, 0, 0), 0.1, 0.1), sdfkit::InvalidInput);
  CHECK_THROWS_AS(make_cone(Vec3(0, 0, 0), Vec3(0, 0, 1), 0.0, 0.0), sdfkit::InvalidInput);
}

TEST_CASE("lofts and swept tubes are closed whatever the ring winding") {
  // Square rings of side 1 at z = 0 and z = 2: a box of volume 2, wound both ways.
  std::vector<Vec3> sq = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  std::vector<Vec3> sq2 = sq;
  for (auto& p : sq2) p.z() = 2;
  check_part(make_loft({sq, sq2}), 2.0, 1e-12);
  std::reverse(sq.begin(), sq.end());
  std::reverse(sq2.begin(), sq2.end());
  check_part(make_loft({sq, sq2}), 2.0, 1e-12);
  CHECK_THROWS_AS(make_loft({sq}), sdfkit::InvalidInput);

  // A straight tube is a prism; a bent tube (quarter circle) has about pi r^2 times its centre-line length.
  const int n = 16;
  const double r = 0.05;
  check_part(make_tube({Vec3(0, 0, 0), Vec3(0, 0.5, 0), Vec3(0, 1, 0)}, {r}, n),
             0.5 * n * r * r * std::sin(2 * M_PI / n), 1e-9);
  const auto path = arc(Vec3(0, 0, 0), Vec3::UnitX(), Vec3::UnitY(), 1.0, 0.0, M_PI / 2, 24);
  const Mesh bent = make_tube(path, {r}, n);
  double length = 0;
  for (size_t i = 0; i + 1 < path.size(); ++i) length += (path[i + 1] - path[i]).norm();
  check_part(bent, 0.5 * n * r * r * std::sin(2 * M_PI / n) * length, 0.005);
  // Tapering radii.
  check_part(make_tube({Vec3(0, 0, 0), Vec3(0, 0, 1)}, {0.2, 0.1}, n),
             (0.5 * n * std::sin(2 * M_PI / n)) * (0.04 + 0.01 + 0.02) / 3.0, 1e-9);
  CHECK_THROWS_AS(make_tube({Vec3(0, 0, 0), Vec3(0, 0, 0)}, {r}, n), sdfkit::InvalidInput);
}

TEST_CASE("bezier and arc sample their end points") {
  const auto b = bezier(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(2, 1, 0), 5);
  REQUIRE(b.size() == 5);
  CHECK((b.front() - Vec3(0, 0, 0)).norm() < 1e-12);
  CHECK((b.back() - Vec3(2, 1, 0)).norm() < 1e-12);
  CHECK((b[2] - Vec3(1, 0.5, 0)).norm() < 1e-12);  // symmetric control polygon: the midpoint is its centre
  const auto a = arc(Vec3(1, 0, 0), Vec3::UnitX(), Vec3::UnitZ(), 2.0, 0, M_PI, 3);
  CHECK((a[1] - Vec3(1, 0, 2)).norm() < 1e-12);
}
