#include "camera/views.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
std::string tmpdir(const std::string& name) {
  const fs::path p = test::scratch_dir("views_test") / name;
  fs::remove_all(p);
  return p.string();
}
}  // namespace

TEST_CASE("views: cameras are seeded, inside the ranges, and view k does not depend on the count") {
  ViewSetSettings st;
  const auto a = view_set_cameras(st, 5);
  const auto b = view_set_cameras(st, 5);
  const auto c = view_set_cameras(st, 6);
  REQUIRE(a.size() == 24);
  st.views = 5;
  const auto first = view_set_cameras(st, 5);
  for (int k = 0; k < 24; ++k) {
    CHECK(a[k].R == b[k].R);
    CHECK(a[k].t == b[k].t);
    CHECK(a[k].R != c[k].R);
    if (k < 5) CHECK(first[k].R == a[k].R);
    const LookAtParams p = look_at_params(a[k]);
    CHECK(p.azimuth_deg >= 0);
    CHECK(p.azimuth_deg < 360);
    CHECK(p.elevation_deg >= 25 - 1e-9);
    CHECK(p.elevation_deg <= 30 + 1e-9);
    CHECK(p.distance >= 2.45 - 1e-12);
    CHECK(p.distance <= 3.0 + 1e-12);
    CHECK(a[k].K == disn_intrinsics());
  }
  CHECK(view_name(3, 24) == "03");
  CHECK(view_name(7, 101) == "007");
  st.elevation_min = 40;
  st.elevation_max = 30;
  CHECK_THROWS_AS(view_set_cameras(st, 1), InvalidInput);
}

TEST_CASE("views: the unit sphere stays inside the image at every default distance") {
  const Mesh sphere = make_icosphere(Vec3::Zero(), 1.0, 4);
  for (double d : {2.45, 3.0}) {
    const RenderResult r = render(sphere, look_at(10, 27, d));
    double border = 0, total = 0;
    for (int y = 0; y < 137; ++y)
      for (int x = 0; x < 137; ++x) {
        total += r.rgba.at(x, y, 3);
        if (x == 0 || y == 0 || x == 136 || y == 136) border += r.rgba.at(x, y, 3);
      }
    CHECK(border == 0.0);
    const double rho = kDisnFocal / std::sqrt(d * d - 1);
    CHECK(total == doctest::Approx(3.14159265358979 * rho * rho).epsilon(0.01));
  }
}

TEST_CASE("views: render_view_set writes PNG + JSON per view, byte-identical for the same seed") {
  Mesh m = make_torus(Vec3::Zero(), 0.7, 0.25, 32, 16);
  ViewSetSettings st;
  st.views = 3;
  st.size = 64;
  st.render.depth = true;
  const std::string d1 = tmpdir("a"), d2 = tmpdir("b"), d3 = tmpdir("c");
  const auto cams = render_view_set(m, d1, st, 11);
  render_view_set(m, d2, st, 11);
  render_view_set(m, d3, st, 12);
  REQUIRE(cams.size() == 3);
  for (int k = 0; k < 3; ++k) {
    const std::string n = view_name(k, 3);
    for (const char* ext : {".png", ".json", "_depth.exr"}) {
      REQUIRE(fs::exists(d1 + "/" + n + ext));
      CHECK(read_file(d1 + "/" + n + ext) == read_file(d2 + "/" + n + ext));
    }
    CHECK(read_file(d1 + "/" + n + ".png") != read_file(d3 + "/" + n + ".png"));
    const Camera back = read_camera(d1 + "/" + n + ".json");
    CHECK((back.R - cams[k].R).norm() < 1e-15);
    CHECK((back.t - cams[k].t).norm() < 1e-15);
    CHECK(back.width == 64);
    const Image png = read_image(d1 + "/" + n + ".png");
    CHECK(png.channels == 4);
    CHECK(png.width == 64);
    CHECK(!fs::exists(d1 + "/" + n + "_mask.png"));
  }
  // Occluded view sets also write the mask and name the mode in the JSON.
  st.occlusion.mode = OcclusionMode::kRight;
  st.render.depth = false;
  const std::string d4 = tmpdir("d");
  render_view_set(m, d4, st, 11);
  CHECK(fs::exists(d4 + "/00_mask.png"));
  CHECK(read_json(d4 + "/00.json")["occlusion"] == "right");
  const Image occluded = read_image(d4 + "/00.png");
  const Image mask = read_image(d4 + "/00_mask.png");
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      if (mask.at(x, y) > 0) CHECK(occluded.at(x, y, 3) == 0.0f);
  fs::remove_all(fs::path(d1).parent_path());
}
