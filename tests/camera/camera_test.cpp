#include "camera/camera.h"
#include "camera/rotation6d.h"
#include "core/error.h"
#include "core/json.h"
#include "core/random.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>

using namespace sdfkit;

namespace {
constexpr double kPi = 3.14159265358979323846;
Vec3 random_point(Rng& rng, double s = 0.8) { return Vec3(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s)); }
}  // namespace

TEST_CASE("camera: DISN intrinsics") {
  const Eigen::Matrix3d K = disn_intrinsics();
  CHECK(K(0, 0) == 149.84375);
  CHECK(K(1, 1) == 149.84375);
  CHECK(K(0, 2) == 68.5);
  CHECK(K(1, 2) == 68.5);
  CHECK(kDisnFocal == 149.84375);
}

TEST_CASE("camera: look-at axis convention and closed-form projection") {
  const double d = 2.0, f = kDisnFocal, c = kDisnPrincipal;
  // Azimuth 0, elevation 0: camera on +z looking at -z; world +x is image right, world +y is image up.
  Camera cam = look_at(0, 0, d);
  CHECK((camera_center(cam) - Vec3(0, 0, d)).norm() < 1e-14);
  double z;
  Eigen::Vector2d p = project(cam, Vec3(0, 0, 0), &z);
  CHECK(z == doctest::Approx(d));
  CHECK(p.x() == doctest::Approx(c));
  CHECK(p.y() == doctest::Approx(c));
  // x = (0.3, 0.2, 0.5): z_cam = d - 0.5, u = c + f*0.3/z, v = c - f*0.2/z.
  p = project(cam, Vec3(0.3, 0.2, 0.5), &z);
  CHECK(z == doctest::Approx(1.5));
  CHECK(p.x() == doctest::Approx(c + f * 0.3 / 1.5));
  CHECK(p.y() == doctest::Approx(c - f * 0.2 / 1.5));
  // Azimuth 90: camera on +x; world -z is image right.
  cam = look_at(90, 0, d);
  CHECK((camera_center(cam) - Vec3(d, 0, 0)).norm() < 1e-14);
  p = project(cam, Vec3(0, 0, -0.4), &z);
  CHECK(z == doctest::Approx(d));
  CHECK(p.x() == doctest::Approx(c + f * 0.4 / d));
  // Elevation 30: camera above; the origin still projects to the principal point, +y goes up in the image.
  cam = look_at(40, 30, d);
  const Vec3 C = camera_center(cam);
  CHECK(C.y() == doctest::Approx(d * std::sin(30 * kPi / 180)));
  p = project(cam, Vec3::Zero());
  CHECK(p.x() == doctest::Approx(c));
  CHECK(p.y() == doctest::Approx(c));
  CHECK(project(cam, Vec3(0, 0.1, 0)).y() < c);
  // Poles are well defined (no roll, x axis horizontal).
  for (double el : {90.0, -90.0}) {
    cam = look_at(30, el, d);
    CHECK((cam.R * cam.R.transpose() - Mat3::Identity()).norm() < 1e-14);
    CHECK(cam.R(0, 1) == 0.0);
  }
}

TEST_CASE("camera: look_at_params inverts look_at") {
  Rng rng(7);
  for (int k = 0; k < 100; ++k) {
    const double az = rng.uniform(0, 359.9), el = rng.uniform(-89.9, 89.9), d = rng.uniform(0.5, 5);
    const LookAtParams p = look_at_params(look_at(az, el, d));
    CHECK(p.azimuth_deg == doctest::Approx(az).epsilon(1e-9));
    CHECK(p.elevation_deg == doctest::Approx(el).epsilon(1e-9));
    CHECK(p.distance == doctest::Approx(d));
  }
  const LookAtParams pole = look_at_params(look_at(35, 90, 2));
  CHECK(pole.azimuth_deg == doctest::Approx(35));
  CHECK(pole.elevation_deg == doctest::Approx(90));
}

TEST_CASE("camera: turn_about_vertical moves a look-at camera's azimuth and sees the object turned back") {
  Rng rng(17);
  for (int k = 0; k < 50; ++k) {
    const double az = rng.uniform(0, 360), el = rng.uniform(-60, 60), d = rng.uniform(1, 4), x = rng.uniform(-400, 400);
    const Camera turned = turn_about_vertical(look_at(az, el, d), x);
    const Camera expect = look_at(az + x, el, d);
    CHECK((turned.R - expect.R).norm() < 1e-12);
    CHECK((turned.t - expect.t).norm() < 1e-12);
    // A point turned by x about +y is seen by the turned camera where the original camera saw the point.
    const Vec3 p = random_point(rng);
    const double a = x * kPi / 180;
    const Vec3 q(std::cos(a) * p.x() + std::sin(a) * p.z(), p.y(), -std::sin(a) * p.x() + std::cos(a) * p.z());
    CHECK((to_camera(turned, q) - to_camera(look_at(az, el, d), p)).norm() < 1e-12);
  }
}

TEST_CASE("camera: mirror_camera sees the mirrored object as the image flipped left to right") {
  Rng rng(23);
  for (int k = 0; k < 50; ++k) {
    const double az = rng.uniform(0, 360), el = rng.uniform(-60, 60), d = rng.uniform(1, 4);
    Camera cam = look_at(az, el, d, 160, 120);
    const Camera m = mirror_camera(cam);
    // A look-at camera at azimuth a becomes the one at -a, a proper rotation.
    const Camera expect = look_at(-az, el, d, 160, 120);
    CHECK((m.R - expect.R).norm() < 1e-12);
    CHECK((m.t - expect.t).norm() < 1e-12);
    CHECK(m.R.determinant() == doctest::Approx(1.0).epsilon(1e-12));
    // Any camera (off-centre principal point, skew, translation off the axis): the point (-x, y, z) lands at
    // (width - u, v) where (x, y, z) landed at (u, v).
    cam.K(0, 1) = rng.uniform(-3, 3);
    cam.K(0, 2) = rng.uniform(40, 120);
    cam.K(1, 2) = rng.uniform(40, 80);
    cam.t += Vec3(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0);
    const Camera mm = mirror_camera(cam);
    const Vec3 p = random_point(rng);
    const Eigen::Vector2d a = project(cam, p), b = project(mm, Vec3(-p.x(), p.y(), p.z()));
    CHECK(b.x() == doctest::Approx(cam.width - a.x()).epsilon(1e-12));
    CHECK(b.y() == doctest::Approx(a.y()).epsilon(1e-12));
    // An involution.
    const Camera back = mirror_camera(mm);
    CHECK((back.R - cam.R).norm() < 1e-15);
    CHECK((back.K - cam.K).norm() < 1e-12);
  }
}

TEST_CASE("camera: distance_as_focal keeps the origin's pixel and recovers the camera of a magnified image") {
  // In range: the camera comes back unchanged.
  const Camera in = look_at(40, 25, 2.7);
  const Camera same = distance_as_focal(in, 2.45, 3.0);
  CHECK((same.K - in.K).norm() == 0.0);
  CHECK((same.t - in.t).norm() == 0.0);
  // An image magnified 2x about its centre: made by the camera at 2.6 with a 2x focal length. A distance-only
  // estimate answers 1.3 with the renders' focal length; read as a focal length it is the camera at 2.45 with
  // 2.6 / 1.3 * 2.45 / 2.6 = 1.885x the focal length, nearly the true one.
  Camera truth = look_at(40, 25, 2.6);
  truth.K(0, 0) *= 2;
  truth.K(1, 1) *= 2;
  const Camera near = look_at(40, 25, 1.3);
  const Camera fixed = distance_as_focal(near, 2.45, 3.0);
  CHECK(fixed.t.norm() == doctest::Approx(2.45).epsilon(1e-12));
  CHECK(fixed.K(0, 0) == doctest::Approx(near.K(0, 0) * 2.45 / 1.3).epsilon(1e-12));
  CHECK((fixed.R - near.R).norm() == 0.0);
  Rng rng(3);
  double err_near = 0, err_fixed = 0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 x(rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6));
    const Eigen::Vector2d p = project(truth, x);
    err_near += (project(near, x) - p).norm();
    err_fixed += (project(fixed, x) - p).norm();
  }
  CHECK(err_fixed < 0.25 * err_near);
  CHECK((project(fixed, Vec3::Zero()) - project(truth, Vec3::Zero())).norm() < 1e-9);
  // A camera whose origin is off its axis (a moved principal point, a sideways t): the origin keeps its pixel.
  Camera side = look_at(10, 30, 4.2);
  side.t += Vec3(0.3, -0.2, 0);
  side.K(0, 1) = 2.0;
  side.K(0, 2) += 7;
  const Camera moved = distance_as_focal(side, 2.45, 3.0);
  CHECK(moved.t.norm() == doctest::Approx(3.0).epsilon(1e-12));
  CHECK((project(moved, Vec3::Zero()) - project(side, Vec3::Zero())).norm() < 1e-9);
  CHECK_THROWS_AS(distance_as_focal(in, 3.0, 2.45), InvalidInput);
  Camera at_origin = in;
  at_origin.t.setZero();
  CHECK_THROWS_AS(distance_as_focal(at_origin, 2.45, 3.0), InvalidInput);
}

TEST_CASE("camera: projection Jacobians against finite differences") {
  Rng rng(8);
  for (int k = 0; k < 30; ++k) {
    Camera cam = look_at(rng.uniform(0, 360), rng.uniform(-40, 60), rng.uniform(1.5, 3));
    cam.K(0, 1) = 0.3;  // skew, to exercise a general K
    cam.K(1, 2) += 2.0;
    const Vec3 x = random_point(rng);
    ProjectionJacobians J;
    const Eigen::Vector2d p0 = project(cam, x, J);
    CHECK((p0 - project(cam, x)).norm() < 1e-12);
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Vec3 e = Vec3::Zero();
      e[i] = h;
      // point
      Eigen::Vector2d fd = (project(cam, x + e) - project(cam, x - e)) / (2 * h);
      CHECK((fd - J.d_point.col(i)).norm() < 1e-5 * (1 + fd.norm()));
      // translation
      Camera cp = cam, cm = cam;
      cp.t += e;
      cm.t -= e;
      fd = (project(cp, x) - project(cm, x)) / (2 * h);
      CHECK((fd - J.d_translation.col(i)).norm() < 1e-5 * (1 + fd.norm()));
      // left rotation perturbation exp([w]) R
      cp = cam;
      cm = cam;
      cp.R = Eigen::AngleAxisd(h, Vec3::Unit(i)).toRotationMatrix() * cam.R;
      cm.R = Eigen::AngleAxisd(-h, Vec3::Unit(i)).toRotationMatrix() * cam.R;
      fd = (project(cp, x) - project(cm, x)) / (2 * h);
      CHECK((fd - J.d_rotation.col(i)).norm() < 1e-5 * (1 + fd.norm()));
    }
    for (int k9 = 0; k9 < 9; ++k9) {
      Camera cp = cam, cm = cam;
      cp.R(k9 % 3, k9 / 3) += h;
      cm.R(k9 % 3, k9 / 3) -= h;
      const Eigen::Vector2d fd = (project(cp, x) - project(cm, x)) / (2 * h);
      CHECK((fd - J.d_matrix.col(k9)).norm() < 1e-5 * (1 + fd.norm()));
    }
  }
}

TEST_CASE("camera: Jacobian wrt look-at parameters and chained through the 6D rotation") {
  Rng rng(9);
  for (int k = 0; k < 20; ++k) {
    const double az = rng.uniform(0, 360), el = rng.uniform(-60, 60), d = rng.uniform(1.5, 3);
    const Vec3 x = random_point(rng);
    const Eigen::Matrix<double, 2, 3> J = project_jacobian_lookat(az, el, d, x);
    const double h = 1e-5;
    const Eigen::Vector2d fa = (project(look_at(az + h, el, d), x) - project(look_at(az - h, el, d), x)) / (2 * h);
    const Eigen::Vector2d fe = (project(look_at(az, el + h, d), x) - project(look_at(az, el - h, d), x)) / (2 * h);
    const Eigen::Vector2d fdd = (project(look_at(az, el, d + h), x) - project(look_at(az, el, d - h), x)) / (2 * h);
    CHECK((fa - J.col(0)).norm() < 1e-5 * (1 + fa.norm()));
    CHECK((fe - J.col(1)).norm() < 1e-5 * (1 + fe.norm()));
    CHECK((fdd - J.col(2)).norm() < 1e-5 * (1 + fdd.norm()));

    // d pixel / d b6 = d_matrix * rot6d_jacobian(b6): the networks' chain rule.
    Vec6T<double> b;
    for (int i = 0; i < 6; ++i) b[i] = rng.normal();
    Camera cam = look_at(0, 0, d);
    cam.R = rot6d_to_matrix(b);
    ProjectionJacobians PJ;
    project(cam, x, PJ);
    const Eigen::Matrix<double, 2, 6> Jb = PJ.d_matrix * rot6d_jacobian(b);
    for (int i = 0; i < 6; ++i) {
      Vec6T<double> bp = b, bm = b;
      bp[i] += 1e-6;
      bm[i] -= 1e-6;
      Camera cp = cam, cm = cam;
      cp.R = rot6d_to_matrix(bp);
      cm.R = rot6d_to_matrix(bm);
      const Eigen::Vector2d fd = (project(cp, x) - project(cm, x)) / 2e-6;
      CHECK((fd - Jb.col(i)).norm() < 1e-4 * (1 + fd.norm()));
    }
  }
}

TEST_CASE("camera: batch projection equals single projection (double and float)") {
  Rng rng(10);
  const Camera cam = look_at(33, 21, 2.2);
  Points X(10000, 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i) X.row(i) = random_point(rng, 1.0).transpose();
  X.row(5) = Vec3(0, 0, 10).transpose();  // behind the camera: finite pixel, negative depth reported
  Eigen::VectorXd depth;
  const Pixels P = project_points(cam, X, &depth);
  REQUIRE(P.allFinite());
  for (Eigen::Index i = 0; i < X.rows(); i += 37) {
    double z;
    const Eigen::Vector2d p = project(cam, X.row(i).transpose(), &z);
    CHECK((P.row(i).transpose() - p).norm() < 1e-9);
    CHECK(depth[i] == doctest::Approx(z));
  }
  CHECK(depth[5] < 0);
  const PointsF Xf = X.cast<float>();
  Eigen::VectorXf depthf;
  const PixelsF Pf = project_points(cam, Xf, &depthf);
  const Pixels diff = Pf.cast<double>() - P;
  CHECK((diff.array().abs() <= 1e-3 + 1e-6 * P.array().abs()).all());
}

TEST_CASE("camera: pixel_ray back-projects onto the projected point") {
  Rng rng(11);
  for (int k = 0; k < 50; ++k) {
    const Camera cam = look_at(rng.uniform(0, 360), rng.uniform(-80, 80), rng.uniform(1, 4));
    const Vec3 x = random_point(rng, 0.5);
    const Eigen::Vector2d p = project(cam, x);
    const Ray ray = pixel_ray(cam, p.x(), p.y());
    CHECK(ray.direction.norm() == doctest::Approx(1.0));
    const Vec3 v = x - ray.origin;
    CHECK((v - ray.direction * v.dot(ray.direction)).norm() < 1e-10);  // x lies on the ray
    CHECK(v.dot(ray.direction) > 0);
  }
  // The principal point's ray passes through the look-at target.
  const Camera cam = look_at(10, 20, 2);
  const Ray r = pixel_ray(cam, kDisnPrincipal, kDisnPrincipal);
  CHECK((r.origin + 2 * r.direction).norm() < 1e-12);
}

TEST_CASE("camera: JSON round trip and errors") {
  const Camera cam = look_at(123.5, 27.25, 2.1);
  const Json j = camera_to_json(cam);
  for (const char* key : {"K", "R", "t", "azimuth", "elevation", "distance", "width", "height"})
    CHECK(j.contains(key));
  CHECK(j["azimuth"].get<double>() == doctest::Approx(123.5));
  CHECK(j["elevation"].get<double>() == doctest::Approx(27.25));
  CHECK(j["distance"].get<double>() == doctest::Approx(2.1));
  const Camera back = camera_from_json(j);
  CHECK((back.K - cam.K).norm() == 0);
  CHECK((back.R - cam.R).norm() == 0);
  CHECK((back.t - cam.t).norm() == 0);
  CHECK(back.width == 137);

  const std::string dir = test::scratch_dir("camera_test").string();
  write_camera(dir + "/00.json", cam);
  const Camera file = read_camera(dir + "/00.json");
  CHECK((file.R - cam.R).norm() == 0);

  Json bad = j;
  bad.erase("R");
  CHECK_THROWS_AS(camera_from_json(bad, "x.json"), IoError);
  bad = j;
  bad["R"] = {{1, 0, 0}, {0, 1, 0}, {0, 0, -1}};  // a reflection
  CHECK_THROWS_AS(camera_from_json(bad, "x.json"), InvalidInput);
  bad = j;
  bad["width"] = "wide";
  CHECK_THROWS_AS(camera_from_json(bad, "x.json"), IoError);
  CHECK_THROWS_AS(look_at(0, 0, 0), InvalidInput);
  CHECK_THROWS_AS(look_at(0, NAN, 1), InvalidInput);
  CHECK_THROWS_AS(read_camera(dir + "/missing.json"), IoError);
  std::filesystem::remove_all(dir);
}
