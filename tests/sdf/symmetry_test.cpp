#include "core/error.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/symmetry.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {
/// {90, 180, 270} -> symmetric flags, in that order.
std::array<bool, 3> flags(const Mesh& m, double tol = 1e-3) {
  const auto s = vertical_symmetries(m, tol);
  REQUIRE(s.size() == 3);
  CHECK(s[0].degrees == 90);
  CHECK(s[1].degrees == 180);
  CHECK(s[2].degrees == 270);
  return {s[0].symmetric, s[1].symmetric, s[2].symmetric};
}

/// The mesh turned about +y by `deg` degrees.
Mesh turned(Mesh m, double deg) {
  const double a = deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << c, 0, s, 0, 1, 0, -s, 0, c;
  m.V = (m.V * R.transpose()).eval();
  return m;
}
}  // namespace

TEST_CASE("vertical symmetries: square and oblong boxes, a box off the axis, a sphere, and an L of two boxes") {
  // Centred box with a square footprint (x = z): every quarter turn maps it onto itself.
  CHECK(flags(make_box(Vec3(-0.4, -0.3, -0.4), Vec3(0.4, 0.3, 0.4))) == std::array<bool, 3>{true, true, true});
  // Oblong footprint: only the half turn.
  CHECK(flags(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2))) == std::array<bool, 3>{false, true, false});
  // The same box turned by 30 degrees about y: still exactly the half turn (a symmetry of the shape, not of axes).
  CHECK(flags(turned(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)), 30.0)) ==
        std::array<bool, 3>{false, true, false});
  // Off the axis: no turn about the axis maps it onto itself.
  CHECK(flags(make_box(Vec3(-0.1, -0.3, -0.2), Vec3(0.5, 0.3, 0.2))) == std::array<bool, 3>{false, false, false});
  // A torus around the y axis with 64 major segments (a multiple of 4): the quarter turns map its vertices onto
  // vertices, so it is symmetric to round-off. With 62 segments only the half turn is.
  const Mat3 x_to_y = (Mat3() << 1, 0, 0, 0, 0, -1, 0, 1, 0).finished();  // z axis -> y axis, exactly
  Mesh torus = make_torus(Vec3::Zero(), 0.6, 0.2, 64, 16);
  torus.V = (torus.V * x_to_y.transpose()).eval();
  CHECK(flags(torus, 1e-9) == std::array<bool, 3>{true, true, true});
  torus = make_torus(Vec3::Zero(), 0.6, 0.2, 62, 16);
  torus.V = (torus.V * x_to_y.transpose()).eval();
  CHECK(flags(torus, 1e-9) == std::array<bool, 3>{false, true, false});
  // Two boxes forming an L (one soup): asymmetric although each part alone is symmetric.
  const Mesh l = concatenate(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)),
                             make_box(Vec3(0.3, -0.3, 0.2), Vec3(0.5, 0.3, 0.6)));
  CHECK(flags(l) == std::array<bool, 3>{false, false, false});
}

TEST_CASE("vertical symmetries: the tolerance decides near-symmetric shapes, bad input is refused") {
  // Oblong box whose +x half is 0.01 longer: not a half-turn symmetry at tol 1e-3, one at tol 0.02.
  const Mesh almost = make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.51, 0.3, 0.2));
  CHECK(flags(almost, 1e-3)[1] == false);
  CHECK(flags(almost, 0.02)[1] == true);
  const auto loose = vertical_symmetries(almost, 0.02);
  CHECK(!loose[0].symmetric);
  CHECK(!loose[2].symmetric);
  CHECK((loose[1].R - Mat3(Eigen::Vector3d(-1, 1, -1).asDiagonal())).norm() == 0.0);
  CHECK_THROWS_AS(vertical_symmetries(Mesh(), 0.01), InvalidInput);
  CHECK_THROWS_AS(vertical_symmetries(almost, 0.0), InvalidInput);
  CHECK_THROWS_AS(vertical_symmetries(almost, std::nan("")), InvalidInput);
}

TEST_CASE("vertical_turn and symmetric_rotations: exact quarter turns, the symmetric ones in order") {
  for (const int deg : {90, 180, 270}) {
    const Mat3 expect = Eigen::AngleAxisd(deg * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix();
    CHECK((vertical_turn(deg) - expect).cwiseAbs().maxCoeff() < 1e-15);
  }
  CHECK(vertical_turn(180)(0, 0) == -1.0);  // exact, no round-off
  CHECK_THROWS_AS(vertical_turn(45), InvalidInput);
  const auto tested = vertical_symmetries(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)), 1e-3);
  const std::vector<Mat3> g = symmetric_rotations(tested);
  REQUIRE(g.size() == 1);
  CHECK(g[0] == vertical_turn(180));
  CHECK(symmetric_rotations({}).empty());
}
