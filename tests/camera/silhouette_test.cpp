#include "camera/silhouette.h"

#include "camera/render.h"
#include "core/error.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {

constexpr double kPi = 3.14159265358979323846;

double sum(const Image& img, int channel = 0) {
  double s = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) s += img.at(x, y, channel);
  return s;
}

/// Pixels where the silhouette's coverage differs from render.h's alpha, and the total absolute difference.
std::pair<int, double> compare_with_render(const Mesh& mesh, const Camera& cam, int s) {
  RenderSettings rs;
  rs.supersampling = s;
  const Image alpha = render(mesh, cam, rs).rgba;
  const Image sil = render_silhouette(mesh, cam, s);
  REQUIRE(sil.width == cam.width);
  REQUIRE(sil.height == cam.height);
  REQUIRE(sil.channels == 1);
  int differ = 0;
  double total = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double d = std::abs(double(sil.at(x, y)) - double(alpha.at(x, y, 3)));
      differ += d > 1e-6;
      total += d;
    }
  return {differ, total};
}

}  // namespace

TEST_CASE("silhouette coverage equals render.h's alpha (same samples) for closed meshes and several cameras") {
  const Mesh mesh = concatenate(make_torus(Vec3(0.1, 0.0, -0.1), 0.5, 0.18, 48, 24), make_box(Vec3(-0.7, -0.4, -0.2),
                                                                                      Vec3(-0.2, 0.5, 0.3)));
  for (const int s : {1, 2, 3}) {
    for (const double az : {0.0, 37.0, 145.0, 260.0}) {
      CAPTURE(s);
      CAPTURE(az);
      const Camera cam = look_at(az, 27.0, 2.6);
      const auto [differ, total] = compare_with_render(mesh, cam, s);
      const double area = sum(render_silhouette(mesh, cam, s));
      CHECK(area > 500);
      // Only samples lying exactly on an outer silhouette edge may differ (closed edges here, a top-left rule
      // there): none or a handful of pixels, each by one sample.
      CHECK(differ <= 3);
      CHECK(total <= 3.0 / (s * s) + 1e-9);
    }
  }
}

TEST_CASE("silhouette of a sphere: a disc of radius f r / sqrt(d^2 - r^2)") {
  const double r = 0.8, d = 2.5;
  const Mesh sphere = make_sphere(Vec3::Zero(), r, 96, 192);
  const Camera cam = look_at(20.0, 10.0, d);
  const Image sil = render_silhouette(sphere, cam, 4);
  const double rho = kDisnFocal * r / std::sqrt(d * d - r * r);
  const double area = sum(sil);
  CHECK(area == doctest::Approx(kPi * rho * rho).epsilon(0.01));
  // Pixels well inside the disc are fully covered, pixels well outside empty.
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double dist = std::hypot(x + 0.5 - kDisnPrincipal, y + 0.5 - kDisnPrincipal);
      if (dist < rho - 1.5) CHECK(sil.at(x, y) == 1.f);
      if (dist > rho + 1.0) CHECK(sil.at(x, y) == 0.f);
    }
}

TEST_CASE("silhouette clips triangles crossing the near plane like render.h") {
  // A large floor under a camera looking down at it: the floor extends behind the camera.
  Mesh floor;
  floor.V.resize(4, 3);
  floor.V << -20, -0.5, -20, 20, -0.5, -20, 20, -0.5, 20, -20, -0.5, 20;
  floor.F.resize(2, 3);
  floor.F << 0, 1, 2, 0, 2, 3;
  const Camera cam = look_at(30.0, 20.0, 2.0);
  const auto [differ, total] = compare_with_render(floor, cam, 2);
  CHECK(differ <= 3);
  const double area = sum(render_silhouette(floor, cam, 2));
  CHECK(area > 0.2 * cam.width * cam.height);
  CHECK(area < 0.9 * cam.width * cam.height);
  // From below the floor, looking up through it: also clipped, also as render.h.
  const Camera away = look_at(30.0, -60.0, 2.0);
  const Image up = render_silhouette(floor, away, 1);
  RenderSettings rs;
  rs.supersampling = 1;
  CHECK(sum(up) == doctest::Approx(sum(render(floor, away, rs).rgba, 3)).epsilon(0.01));
}

TEST_CASE("silhouette_iou: soft IoU, bounds and errors") {
  Image a(4, 3, 1, 0.f), b(4, 3, 1, 0.f);
  CHECK(silhouette_iou(a, b) == 1.0);  // both empty
  a.at(0, 0) = 1.f;
  CHECK(silhouette_iou(a, b) == 0.0);
  b.at(0, 0) = 0.5f;
  b.at(1, 0) = 1.f;
  // min: 0.5, max: 1 + 1 = 2
  CHECK(silhouette_iou(a, b) == doctest::Approx(0.25));
  CHECK(silhouette_iou(a, a) == 1.0);
  CHECK_THROWS_AS((void)silhouette_iou(a, Image(3, 3, 1)), InvalidInput);
  CHECK_THROWS_AS((void)silhouette_iou(a, Image()), InvalidInput);
}

TEST_CASE("silhouette renderer refuses bad meshes and settings") {
  CHECK_THROWS_AS((void)SilhouetteRenderer(Mesh{}), InvalidInput);
  Mesh bad = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  CHECK_THROWS_AS((void)SilhouetteRenderer(bad, 0), InvalidInput);
  CHECK_THROWS_AS((void)SilhouetteRenderer(bad, 9), InvalidInput);
  bad.F(3, 1) = 99;
  CHECK_THROWS_AS((void)SilhouetteRenderer(bad), InvalidInput);
  Mesh nan = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  nan.V(2, 0) = std::nan("");
  CHECK_THROWS_AS((void)SilhouetteRenderer(nan), InvalidInput);
}
