#include "camera/pose_metrics.h"
#include "core/error.h"
#include "core/random.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {
Points random_points(int n, uint64_t seed) {
  Rng rng(seed);
  Points X(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) X(i, k) = rng.uniform(-1, 1);
  return X;
}
}  // namespace

TEST_CASE("pose metrics: zero for the true camera, |delta| for a translation error") {
  const Points X = random_points(2048, 1);
  const Camera truth = look_at(45, 28, 2.6);
  const PoseErrors same = pose_errors(X, truth, truth);
  CHECK(same.d3d == 0.0);
  CHECK(same.d2d == 0.0);
  CHECK(same.points_2d == 2048);
  Camera shifted = truth;
  shifted.t += Vec3(0.03, -0.04, 0.0);  // |delta| = 0.05
  CHECK(pose_d3d(X, shifted, truth) == doctest::Approx(0.05).epsilon(1e-12));
  // d2D of an x/y shift: each pixel moves by f * |delta_xy| / z_cam.
  double expect = 0;
  for (Eigen::Index i = 0; i < X.rows(); ++i) expect += kDisnFocal * 0.05 / to_camera(truth, X.row(i).transpose()).z();
  CHECK(pose_d2d(X, shifted, truth) == doctest::Approx(expect / 2048).epsilon(1e-9));
}

TEST_CASE("pose metrics: a roll about the optical axis, closed form") {
  const Points X = random_points(500, 2);
  const Camera truth = look_at(120, 25, 2.5);
  const double theta = 0.1;
  Camera rolled = truth;
  const Mat3 Rz = Eigen::AngleAxisd(theta, Vec3::UnitZ()).toRotationMatrix();
  rolled.R = Rz * truth.R;
  rolled.t = Rz * truth.t;  // (0, 0, d): unchanged
  double e3 = 0, e2 = 0;
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const Vec3 c = to_camera(truth, X.row(i).transpose());
    const double rxy = std::hypot(c.x(), c.y());
    e3 += 2 * std::sin(theta / 2) * rxy;
    e2 += 2 * std::sin(theta / 2) * kDisnFocal * rxy / c.z();  // pixels rotate about the principal point
  }
  const PoseErrors e = pose_errors(X, rolled, truth);
  CHECK(e.d3d == doctest::Approx(e3 / 500).epsilon(1e-10));
  CHECK(e.d2d == doctest::Approx(e2 / 500).epsilon(1e-10));
}

TEST_CASE("pose metrics: errors") {
  CHECK_THROWS_AS(pose_errors(Points(0, 3), look_at(0, 0, 2), look_at(0, 0, 2)), InvalidInput);
  Points bad = random_points(3, 3);
  bad(1, 1) = NAN;
  CHECK_THROWS_AS(pose_errors(bad, look_at(0, 0, 2), look_at(0, 0, 2)), InvalidInput);
}

TEST_CASE("pose metrics modulo symmetries: the turned twin of the true camera scores zero only when it is a symmetry") {
  const Points X = random_points(2048, 7);
  const Camera truth = look_at(40, 27, 2.6);
  Mat3 half, quarter;
  half << -1, 0, 0, 0, 1, 0, 0, 0, -1;
  quarter << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  Camera twin = truth;
  twin.R = truth.R * half;
  const PoseErrors plain = pose_errors(X, twin, truth);
  CHECK(plain.d2d > 10.0);
  CHECK(plain.d3d > 0.5);
  // The half turn is declared a symmetry: the twin is as right as the true camera.
  const PoseErrors mod = pose_errors_modulo(X, twin, truth, {half});
  CHECK(mod.d2d < 1e-9);
  CHECK(mod.d3d < 1e-12);
  CHECK(mod.points_2d == 2048);
  // Only the quarter turn: the twin stays wrong, and no symmetry list can make an error larger.
  const PoseErrors q = pose_errors_modulo(X, twin, truth, {quarter});
  CHECK(q.d2d > 5.0);
  CHECK(q.d2d <= plain.d2d);
  CHECK(q.d3d <= plain.d3d);
  // No symmetries: exactly pose_errors.
  const PoseErrors none = pose_errors_modulo(X, twin, truth, {});
  CHECK(none.d2d == plain.d2d);
  CHECK(none.d3d == plain.d3d);
  // A look-at camera half an orbit away is the twin (R' = R rot_y(180), same t).
  const Camera opposite = look_at(220, 27, 2.6);
  CHECK(pose_errors_modulo(X, opposite, truth, {half}).d2d < 1e-6);
  CHECK_THROWS_AS(pose_errors_modulo(X, twin, truth, {Mat3(2.0 * Mat3::Identity())}), InvalidInput);
}

TEST_CASE("rotation error: the angle and the turn about the vertical axis, closed forms") {
  auto turn_y = [](double deg) {
    const double a = deg * M_PI / 180.0;
    Mat3 R;
    R << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
    return R;
  };
  for (const double az : {0.0, 37.0, 200.0})
    for (const double phi : {0.0, 12.5, -90.0, 179.0, -150.0}) {
      const Mat3 R = look_at(az, 27, 2.7).R;
      const auto [angle, azimuth] = rotation_error_degrees(R * turn_y(phi), R);
      CHECK(angle == doctest::Approx(std::abs(phi)).epsilon(1e-9));
      CHECK(azimuth == doctest::Approx(phi).epsilon(1e-9));
    }
  // A camera that sees the object turned about +y by phi is look_at's camera at azimuth - or + phi: the turn's
  // size is the azimuth difference.
  const auto [angle, azimuth] = rotation_error_degrees(look_at(70, 27, 2.7).R, look_at(30, 27, 2.7).R);
  CHECK(angle == doctest::Approx(40).epsilon(1e-9));
  CHECK(std::abs(azimuth) == doctest::Approx(40).epsilon(1e-9));
  // A tilt about the object's x axis has no vertical turn: the angle alone.
  Mat3 tilt;
  const double t = 20 * M_PI / 180;
  tilt << 1, 0, 0, 0, std::cos(t), -std::sin(t), 0, std::sin(t), std::cos(t);
  const auto [tilt_angle, tilt_azimuth] = rotation_error_degrees(look_at(10, 27, 2.7).R * tilt, look_at(10, 27, 2.7).R);
  CHECK(tilt_angle == doctest::Approx(20).epsilon(1e-9));
  CHECK(tilt_azimuth == doctest::Approx(0).epsilon(1e-9));
}
