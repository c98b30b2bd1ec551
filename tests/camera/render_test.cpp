#include "camera/render.h"
#include "camera/pose_metrics.h"
#include "core/error.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>

using namespace sdfkit;

namespace {
constexpr double kPi = 3.14159265358979323846;

double alpha_sum(const Image& rgba) {
  double s = 0;
  for (int y = 0; y < rgba.height; ++y)
    for (int x = 0; x < rgba.width; ++x) s += rgba.at(x, y, 3);
  return s;
}

/// Square [-h, h]^2 in the plane y = y0, split into n x n quads (2 triangles each).
Mesh ground(double h, double y0, int n) {
  Mesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) m.V.row(i * (n + 1) + j) = Vec3(-h + 2 * h * j / n, y0, -h + 2 * h * i / n).transpose();
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
      m.F.row(f++) << a, c, b;
      m.F.row(f++) << b, c, d;
    }
  return m;
}

Mesh colored(Mesh m, float r, float g, float b) {
  m.colors.resize(m.V.rows(), 3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) m.colors.row(i) << r, g, b;
  return m;
}
}  // namespace

TEST_CASE("render: sphere silhouette area matches the exact perspective disc") {
  const double r = 0.5;
  const Mesh sphere = make_icosphere(Vec3::Zero(), r, 5);
  for (double z : {2.0, 3.0}) {
    RenderSettings st;
    const RenderResult res = render(sphere, look_at(17, 0, z), st);
    // On the optical axis the silhouette is a disc of radius f r / sqrt(z^2 - r^2) (not f r / z).
    const double rho = kDisnFocal * r / std::sqrt(z * z - r * r);
    const double exact = kPi * rho * rho;
    CAPTURE(z);
    CHECK(std::abs(alpha_sum(res.rgba) - exact) / exact < 0.005);
    // Anti-aliased: the boundary has fractional alpha, the inside is opaque, the corners are empty.
    int partial = 0;
    for (int y = 0; y < 137; ++y)
      for (int x = 0; x < 137; ++x) partial += res.rgba.at(x, y, 3) > 0 && res.rgba.at(x, y, 3) < 1;
    CHECK(partial > 2 * rho);
    CHECK(res.rgba.at(68, 68, 3) == 1.0f);
    CHECK(res.rgba.at(0, 0, 3) == 0.0f);
  }
}

TEST_CASE("render: depth of a plane matches the closed form, with near-plane and guard-band clipping") {
  // A large ground plane y = -0.3 reaches behind the camera, so its triangles are clipped.
  for (int n : {1, 30}) {
    const Mesh plane = ground(50.0, -0.3, n);
    const Camera cam = look_at(30, 35, 2.5);
    RenderSettings st;
    st.depth = true;
    st.normals = true;
    const RenderResult res = render(plane, cam, st);
    const Vec3 C = camera_center(cam);
    const Eigen::Matrix3d Kinv = cam.K.inverse();
    int checked = 0, holes = 0;
    double max_err = 0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const Vec3 dcam = Kinv * Vec3(x + 0.5, y + 0.5, 1.0);  // z component 1: the ray parameter is z_cam
        const Vec3 w = cam.R.transpose() * dcam;
        if (w.y() >= -1e-3) continue;  // above the horizon (or grazing)
        const double s = (-0.3 - C.y()) / w.y();
        const Vec3 hit = C + s * w;
        if (std::abs(hit.x()) > 49 || std::abs(hit.z()) > 49) continue;
        ++checked;
        if (res.rgba.at(x, y, 3) != 1.0f) ++holes;
        max_err = std::max(max_err, std::abs(res.depth.at(x, y) - s) / s);
        // Normal: world +y in the camera frame (facing the camera from above).
        const Vec3 n = cam.R * Vec3::UnitY();
        CHECK(std::abs(res.normals.at(x, y, 1) - n.y()) < 1e-5);
      }
    CAPTURE(n);
    CHECK(checked > 137 * 137 / 3);
    CHECK(holes == 0);  // no cracks between the grid's triangles
    CHECK(max_err < 1e-5);
  }
}

TEST_CASE("render: a cube seen along an axis shows exactly one face") {
  const Mesh cube = make_box(Vec3::Constant(-0.5), Vec3::Constant(0.5));
  const double d = 3.0;
  RenderSettings st;
  st.depth = true;
  st.normals = true;
  st.albedo = true;
  const RenderResult res = render(cube, look_at(0, 0, d), st);
  // Albedo is the unlit colour: the default albedo inside, 0 outside.
  for (int k = 0; k < 3; ++k) {
    CHECK(res.albedo.at(68, 68, k) == doctest::Approx(st.default_color[k]));
    CHECK(res.albedo.at(2, 2, k) == 0.0f);
  }
  int fg = 0;
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x) {
      if (res.depth.at(x, y) == 0.0f) continue;
      ++fg;
      CHECK(res.depth.at(x, y) == doctest::Approx(d - 0.5).epsilon(1e-6));
      CHECK(res.normals.at(x, y, 2) == doctest::Approx(-1.0f));
    }
  // The silhouette is the front face: a square of side 2 f 0.5 / (d - 0.5) pixels.
  const double side = 2 * kDisnFocal * 0.5 / (d - 0.5);
  // With s x s samples an edge pixel's coverage is off by at most 1/(2s) of a pixel: bound by the perimeter.
  CHECK(std::abs(alpha_sum(res.rgba) - side * side) <= 4 * side / (2.0 * st.supersampling) + 1);
  CHECK(std::abs(alpha_sum(res.rgba) - side * side) / (side * side) < 0.01);
  CHECK(std::abs(fg - side * side) <= 4 * side * 0.5 + 4);
  // Flat shading of one face: every opaque pixel has the same colour.
  const float c0 = res.rgba.at(68, 68, 0);
  for (int y = 50; y < 87; ++y)
    for (int x = 50; x < 87; ++x) CHECK(res.rgba.at(x, y, 0) == c0);
}

TEST_CASE("render: two objects occlude correctly, whatever their order in the mesh") {
  const Mesh front = colored(make_icosphere(Vec3(0, 0, 0.5), 0.3, 4), 1, 0, 0);
  const Mesh back = colored(make_icosphere(Vec3(0, 0, -0.5), 0.6, 4), 0, 1, 0);
  RenderSettings st;
  st.depth = true;
  st.ambient = 1.0f;  // pure albedo: colours tell which object is seen
  st.lights.clear();
  st.specular = 0;
  const Camera cam = look_at(0, 0, 3.0);
  const RenderResult a = render(concatenate(front, back), cam, st);
  const RenderResult b = render(concatenate(back, front), cam, st);
  CHECK(a.rgba.data == b.rgba.data);
  CHECK(a.depth.data == b.depth.data);
  CHECK(a.rgba.at(68, 68, 0) == 1.0f);
  CHECK(a.rgba.at(68, 68, 1) == 0.0f);
  CHECK(a.depth.at(68, 68) == doctest::Approx(3.0 - 0.8).epsilon(2e-3));
  // Beyond the front sphere's disc (radius ~ f 0.3 / 2.5 = 18 px) only the back one is seen.
  CHECK(a.rgba.at(68 + 25, 68, 1) == 1.0f);
  CHECK(a.rgba.at(68 + 25, 68, 0) == 0.0f);
  CHECK(a.depth.at(68 + 25, 68) > 3.0f);
}

TEST_CASE("render: two-sided shading, deterministic across thread counts, vertex colours interpolate") {
  Mesh m = make_torus(Vec3::Zero(), 0.6, 0.25, 48, 24);
  m.colors.resize(m.V.rows(), 3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    m.colors.row(i) << static_cast<float>(0.5 + 0.5 * m.V(i, 0)), 0.3f, static_cast<float>(0.5 - 0.5 * m.V(i, 2));
  Mesh flipped = m;
  for (Eigen::Index f = 0; f < flipped.F.rows(); ++f) std::swap(flipped.F(f, 1), flipped.F(f, 2));
  RenderSettings st;
  st.depth = true;
  st.normals = true;
  const Camera cam = look_at(40, 30, 2.4, 160, 120);
  const RenderResult r2 = render(m, cam, st);
  RenderResult r1;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    r1 = render(m, cam, st);
  }
  CHECK(r1.rgba.data == r2.rgba.data);
  CHECK(r1.depth.data == r2.depth.data);
  CHECK(r1.normals.data == r2.normals.data);
  const RenderResult rf = render(flipped, cam, st);
  CHECK(rf.depth.data == r2.depth.data);
  double max_diff = 0;
  for (size_t i = 0; i < rf.rgba.data.size(); ++i) max_diff = std::max(max_diff, double(std::abs(rf.rgba.data[i] - r2.rgba.data[i])));
  CHECK(max_diff < 1e-5);
  CHECK(r2.rgba.width == 160);
  CHECK(r2.rgba.height == 120);
  // Colours vary smoothly across the surface: the two sides of the image differ.
  for (float v : r2.rgba.data) CHECK(std::isfinite(v));
}

TEST_CASE("render: invalid input") {
  CHECK_THROWS_AS(render(Mesh(), look_at(0, 0, 2)), InvalidInput);
  Mesh bad = make_box(Vec3::Zero(), Vec3::Ones());
  bad.F(0, 0) = 99;
  CHECK_THROWS_AS(render(bad, look_at(0, 0, 2)), InvalidInput);
  RenderSettings st;
  st.supersampling = 0;
  CHECK_THROWS_AS(render(make_box(Vec3::Zero(), Vec3::Ones()), look_at(0, 0, 2), st), InvalidInput);
  // An object entirely behind the camera renders empty, not garbage.
  const RenderResult r = render(make_icosphere(Vec3(0, 0, 5), 0.5, 2), look_at(0, 0, 2));
  CHECK(alpha_sum(r.rgba) == 0.0);
}

TEST_CASE("view_difference: pixels inside one silhouette only or apart in colour, over the silhouettes' union") {
  Image a(4, 3, 4, 0.f), b(4, 3, 4, 0.f);
  const auto set = [](Image& im, int x, int y, float grey, float alpha) {
    for (int c = 0; c < 3; ++c) im.at(x, y, c) = grey;
    im.at(x, y, 3) = alpha;
  };
  set(a, 0, 0, 0.5f, 1.f);  // inside a only: differs
  set(a, 1, 0, 0.5f, 1.f);  // inside both, same colour
  set(b, 1, 0, 0.5f, 1.f);
  set(b, 2, 0, 0.5f, 1.f);  // inside b only: differs
  set(a, 0, 1, 0.5f, 1.f);  // inside both, 0.05 apart: within the tolerance
  set(b, 0, 1, 0.55f, 0.6f);
  set(a, 1, 1, 0.5f, 1.f);  // inside both, 0.15 apart in green only: differs
  set(b, 1, 1, 0.5f, 1.f);
  b.at(1, 1, 1) = 0.65f;
  set(a, 3, 2, 0.9f, 0.49f);  // alpha below one half: background, not counted
  ViewDifference d = view_difference(a, b);
  CHECK(d.silhouette == 5);
  CHECK(d.differing == 3);
  CHECK(d.share() == doctest::Approx(0.6));
  d = view_difference(a, b, 0.2f);  // the green pixel is now within the tolerance
  CHECK(d.differing == 2);
  CHECK(view_difference(a, a).differing == 0);
  CHECK(view_difference(a, a).silhouette == 4);
  CHECK(view_difference(Image(4, 3, 4, 0.f), Image(4, 3, 4, 0.f)).share() == 0.0);  // both empty
  CHECK_THROWS_AS(view_difference(a, Image(3, 4, 4, 0.f)), InvalidInput);
  CHECK_THROWS_AS(view_difference(a, Image(4, 3, 3, 0.f)), InvalidInput);
  CHECK_THROWS_AS(view_difference(a, b, -0.1f), InvalidInput);
}

TEST_CASE("view_twin_turns: the turns whose render looks like the view, by the pose errors' convention") {
  const Camera truth = look_at(30, 27, 2.7);
  // An estimate turned by 180 degrees about the vertical axis, as rotation_error_degrees reads it.
  const Camera flipped = turn_about_vertical(truth, -180);
  const double turn = rotation_error_degrees(flipped.R, truth.R).second;
  CHECK(std::abs(turn) == doctest::Approx(180).epsilon(1e-9));
  // A centred oblong box, one colour: the half turn maps it onto itself; the other candidates (165..195 by 5) do not.
  const MeshRenderer box(colored(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)), 0.6f, 0.5f, 0.4f));
  double best = -1;
  std::vector<double> twins = view_twin_turns(box, truth, 178, {}, &best);
  CHECK(twins == std::vector<double>{180});
  CHECK(best <= 0.01);
  twins = view_twin_turns(box, truth, turn, {});
  REQUIRE(twins.size() == 1);
  CHECK(std::abs(std::remainder(twins[0], 360.0)) == doctest::Approx(180));
  // A knob on its front tells the half turn apart, unless the tolerance allows its pixels.
  const Mesh knobbed = concatenate(colored(make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)), 0.6f, 0.5f, 0.4f),
                                   colored(make_box(Vec3(-0.1, -0.1, 0.2), Vec3(0.1, 0.1, 0.35)), 0.1f, 0.1f, 0.9f));
  const MeshRenderer knob(knobbed);
  CHECK(view_twin_turns(knob, truth, 180, {}, &best).empty());
  CHECK(best > 0.01);
  TwinSearch loose;
  loose.tol = 0.5;
  const std::vector<double> loose_twins = view_twin_turns(knob, truth, 180, loose);
  CHECK(std::find(loose_twins.begin(), loose_twins.end(), 180.0) != loose_twins.end());
  // Off the axis, the box has no twin.
  const MeshRenderer off(colored(make_box(Vec3(-0.2, -0.3, -0.2), Vec3(0.6, 0.3, 0.2)), 0.6f, 0.5f, 0.4f));
  CHECK(view_twin_turns(off, truth, 180).empty());
  // A sphere of 360 slices looks the same turned by any whole degree: every candidate near 97 is a twin.
  const MeshRenderer ball(colored(make_sphere(Vec3::Zero(), 0.8, 16, 360), 0.3f, 0.6f, 0.3f));
  CHECK(view_twin_turns(ball, truth, 97) == std::vector<double>{85, 90, 95, 100, 105, 110});
  // No candidate at least 20 degrees from no turn: nothing rendered, best share +inf.
  CHECK(view_twin_turns(ball, truth, 0, {}, &best).empty());
  CHECK(std::isinf(best));
  TwinSearch bad;
  bad.step = 0;
  CHECK_THROWS_AS(view_twin_turns(box, truth, 180, bad), InvalidInput);
  bad = {};
  bad.step = 1e-6;  // millions of candidates
  CHECK_THROWS_AS(view_twin_turns(box, truth, 180, bad), InvalidInput);
  bad = {};
  bad.tol = 1.5;
  CHECK_THROWS_AS(view_twin_turns(box, truth, 180, bad), InvalidInput);
}
