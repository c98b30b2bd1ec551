#include "recon/camera_refine.h"

#include "camera/silhouette.h"
#include "core/error.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>

using namespace sdfkit;

namespace {

/// An object without symmetries: a box body, a sphere on one corner, a thin arm and a torus handle.
Mesh asymmetric_object() {
  Mesh m = make_box(Vec3(-0.45, -0.25, -0.3), Vec3(0.35, 0.15, 0.3));
  m = concatenate(m, make_sphere(Vec3(0.3, 0.35, 0.15), 0.22, 16, 32));
  m = concatenate(m, make_box(Vec3(-0.8, -0.05, -0.05), Vec3(-0.45, 0.05, 0.45)));
  m = concatenate(m, make_torus(Vec3(0.0, -0.45, -0.2), 0.25, 0.06, 32, 12));
  return m;
}

double rotation_error_deg(const Camera& a, const Camera& b) {
  const Eigen::AngleAxisd d(Mat3(a.R * b.R.transpose()));
  return std::abs(d.angle()) * 180.0 / 3.14159265358979323846;
}

double distance_error(const Camera& a, const Camera& b) {
  return std::abs(camera_center(a).norm() - camera_center(b).norm()) / camera_center(b).norm();
}

}  // namespace

TEST_CASE("perturb_camera: rotation about the object origin and distance scaling") {
  const Camera c = look_at(40.0, 25.0, 2.7);
  const Camera p = perturb_camera(c, Vec3(3.0, -4.0, 0.0), 1.1);
  CHECK(rotation_error_deg(p, c) == doctest::Approx(5.0).epsilon(1e-9));
  CHECK(camera_center(p).norm() == doctest::Approx(2.7 * 1.1).epsilon(1e-12));
  // The origin keeps its pixel (the principal point of a look-at camera).
  const Eigen::Vector2d o = project(p, Vec3::Zero());
  CHECK(o.x() == doctest::Approx(kDisnPrincipal));
  CHECK(o.y() == doctest::Approx(kDisnPrincipal));
  const Camera same = perturb_camera(c, Vec3::Zero(), 1.0);
  CHECK((same.R - c.R).norm() == 0.0);
  CHECK((same.t - c.t).norm() == 0.0);
}

TEST_CASE("refine_camera recovers a known perturbation of ~8 degrees and 10% distance") {
  const Mesh mesh = asymmetric_object();
  const Camera truth = look_at(35.0, 25.0, 2.7);
  const Image mask = render_silhouette(mesh, truth, 3);
  for (const auto& item : {std::pair{Vec3(5.0, -6.0, 2.0), 1.1}, std::pair{Vec3(-4.0, 3.0, -6.0), 0.9}}) {
    const Vec3& w = item.first;
    const double r = item.second;
    CAPTURE(w.transpose());
    CAPTURE(r);
    const Camera start = perturb_camera(truth, w, r);
    const double rot0 = rotation_error_deg(start, truth), dist0 = distance_error(start, truth);
    const CameraRefineResult res = refine_camera(mesh, mask, start);
    const double rot1 = rotation_error_deg(res.camera, truth), dist1 = distance_error(res.camera, truth);
    MESSAGE("rotation error " << rot0 << " -> " << rot1 << " deg, distance error " << dist0 << " -> " << dist1
                              << ", IoU " << res.iou_before << " -> " << res.iou_after << ", " << res.evaluations
                              << " evaluations");
    CHECK(rot0 > 7.0);
    CHECK(dist0 > 0.09);
    CHECK(rot1 < rot0 / 8);
    CHECK(dist1 < dist0 / 8);
    CHECK(res.iou_before < 0.85);
    CHECK(res.iou_after > 0.97);
    CHECK(res.iou_after >= res.iou_before);
    CHECK(res.evaluations <= CameraRefineSettings{}.max_evaluations + 1);
    // The reported parameters reproduce the camera.
    const Camera again = perturb_camera(start, res.rotation_deg, res.distance_ratio);
    CHECK((again.R - res.camera.R).norm() < 1e-12);
    CHECK((again.t - res.camera.t).norm() < 1e-12);
  }
}

TEST_CASE("the azimuth sweep finds a 40 degree azimuth error that the local search alone cannot") {
  const Mesh mesh = asymmetric_object();
  const Camera truth = look_at(35.0, 25.0, 2.7);
  // A turn of delta about the object's vertical axis is the look-at camera at azimuth - delta.
  const Camera turned = perturb_camera(truth, 40.0 * Vec3(truth.R.col(1)), 1.0);
  const Camera other = look_at(35.0 - 40.0, 25.0, 2.7);
  CHECK((turned.R - other.R).norm() < 1e-12);
  CHECK((turned.t - other.t).norm() < 1e-12);

  const Image mask = render_silhouette(mesh, truth, 2);
  const Camera start = look_at(35.0 + 40.0, 25.0, 2.7);
  CameraRefineSettings s;
  s.max_evaluations = 150;
  s.max_rotation_deg = 10.0;
  const CameraRefineResult local = refine_camera(mesh, mask, start, s);
  CHECK(rotation_error_deg(local.camera, truth) > 20.0);
  s.sweep_azimuth_deg = 60.0;
  s.sweep_step_deg = 10.0;
  const CameraRefineResult swept = refine_camera(mesh, mask, start, s);
  CHECK(swept.sweep_azimuth_deg == 40.0);
  CHECK(rotation_error_deg(swept.camera, truth) < 1.0);
  CHECK(swept.iou_after > 0.97);
  // The reported rotation (both stages) reproduces the camera from the start.
  const Camera again = perturb_camera(start, swept.rotation_deg, swept.distance_ratio);
  CHECK((again.R - swept.camera.R).norm() < 1e-9);
}

TEST_CASE("refine_camera is deterministic, stays in its bounds, and can keep the distance") {
  const Mesh mesh = asymmetric_object();
  const Camera truth = look_at(200.0, 28.0, 2.5);
  const Image mask = render_silhouette(mesh, truth, 2);
  const Camera start = perturb_camera(truth, Vec3(-7.0, 4.0, 3.0), 1.15);
  CameraRefineSettings s;
  s.max_evaluations = 150;
  const CameraRefineResult a = refine_camera(mesh, mask, start, s), b = refine_camera(mesh, mask, start, s);
  CHECK(std::memcmp(a.camera.R.data(), b.camera.R.data(), sizeof(double) * 9) == 0);
  CHECK(std::memcmp(a.camera.t.data(), b.camera.t.data(), sizeof(double) * 3) == 0);
  CHECK(a.iou_after == b.iou_after);
  CHECK(a.evaluations == b.evaluations);
  CHECK(a.evaluations <= 151);  // the start + the local search's budget

  // Tight bounds: the result stays inside them even though the truth is outside.
  s.max_rotation_deg = 2.0;
  s.max_distance_change = 0.05;
  const CameraRefineResult c = refine_camera(mesh, mask, start, s);
  CHECK(c.rotation_deg.cwiseAbs().maxCoeff() <= 2.0 + 1e-9);
  CHECK(c.distance_ratio <= 1.05 + 1e-12);
  CHECK(c.distance_ratio >= 1 / 1.05 - 1e-12);
  CHECK(c.iou_after >= c.iou_before);

  // Rotation only (the truth at the start's distance): t is kept bit for bit, the rotation recovered.
  s = CameraRefineSettings{};
  s.refine_distance = false;
  s.max_evaluations = 150;
  const Camera turned = perturb_camera(truth, Vec3(-7.0, 4.0, 3.0), 1.0);
  const CameraRefineResult d = refine_camera(mesh, mask, turned, s);
  CHECK(d.distance_ratio == 1.0);
  CHECK((d.camera.t - turned.t).norm() == 0.0);
  CHECK(rotation_error_deg(d.camera, truth) < rotation_error_deg(turned, truth) / 8);
}

TEST_CASE("the joint variant with a camera-independent mesh is the fixed-mesh variant") {
  const Mesh mesh = asymmetric_object();
  const Camera truth = look_at(120.0, 26.0, 2.8);
  const Image mask = render_silhouette(mesh, truth, 2);
  const Camera start = perturb_camera(truth, Vec3(4.0, 4.0, -3.0), 0.95);
  CameraRefineSettings s;
  s.max_evaluations = 80;
  int calls = 0;
  const CameraRefineResult a = refine_camera(mesh, mask, start, s);
  const CameraRefineResult b = refine_camera(
      [&](const Camera&) {
        ++calls;
        return mesh;
      },
      mask, start, s);
  CHECK(calls <= b.evaluations);  // candidates outside the bounds are not reconstructed
  CHECK(a.evaluations == b.evaluations);
  CHECK(a.iou_after == b.iou_after);
  CHECK((a.camera.R - b.camera.R).norm() == 0.0);
  // A mesh function that finds nothing: IoU 0 everywhere, the start camera is kept.
  const CameraRefineResult e = refine_camera([](const Camera&) { return Mesh{}; }, mask, start, s);
  CHECK(e.iou_before == 0.0);
  CHECK(e.iou_after == 0.0);
  CHECK((e.camera.R - start.R).norm() == 0.0);
}

TEST_CASE("refine_camera errors: empty mask, mask of another size, empty mesh") {
  const Mesh mesh = asymmetric_object();
  const Camera cam = look_at(10.0, 25.0, 2.7);
  CHECK_THROWS_WITH_AS(refine_camera(mesh, Image(137, 137, 1, 0.f), cam), doctest::Contains("no object pixel"),
                       InvalidInput);
  CHECK_THROWS_WITH_AS(refine_camera(mesh, Image(64, 64, 1, 1.f), cam), doctest::Contains("64x64"), InvalidInput);
  CHECK_THROWS_AS(refine_camera(Mesh{}, Image(137, 137, 1, 1.f), cam), InvalidInput);
}
