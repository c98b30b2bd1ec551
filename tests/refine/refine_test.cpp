#include "refine/refine.h"

#include "camera/silhouette.h"
#include "camera/views.h"
#include "core/error.h"
#include "core/files.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A view set of a box (unit-sphere sized) in a scratch folder: 8 views at 40 px around and above it.
fs::path box_views(const std::string& tag, Mesh* box = nullptr) {
  const fs::path dir = test::scratch_dir(tag);
  const Mesh m = make_box(Vec3(-0.7, -0.35, -0.45), Vec3(0.6, 0.4, 0.5));
  ViewSetSettings vs;
  vs.views = 8;
  vs.size = 40;
  vs.elevation_min = -20;
  vs.elevation_max = 50;
  render_view_set(m, (dir / "views").string(), vs, 5);
  if (box) *box = m;
  return dir;
}

/// Settings for a short run on the box views: the defaults with fewer steps and views.
RefineSettings short_run(long iters, int views_per_step, int log_every) {
  RefineSettings s;
  s.iters = iters;
  s.views_per_step = views_per_step;
  s.log_every = log_every;
  return s;
}

double mean_silhouette_iou(const Mesh& m, const std::vector<TargetView>& views) {
  double s = 0;
  for (const auto& v : views) {
    const Image sil = render_silhouette(m, v.camera, 2);
    s += silhouette_iou(sil, v.alpha);
  }
  return s / static_cast<double>(views.size());
}

}  // namespace

TEST_CASE("refine: a sphere deforms into a box's silhouettes, seeded and thread-independent") {
  const fs::path dir = box_views("refine_box");
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  REQUIRE(views.size() == 8);
  CHECK(views[0].name == "00");
  RefineSettings s = short_run(150, 3, 50);
  const Mesh start = refine_sphere(2, 1.0);
  const double before = mean_silhouette_iou(start, views);
  const RefineResult a = refine_mesh(views, start, s);
  const double after = mean_silhouette_iou(a.mesh, views);
  INFO("silhouette IoU before ", before, ", after ", after);
  CHECK(after > before + 0.3);  // 0.43 -> 0.80 (a 162-vertex sphere, 40 px views)
  CHECK(after > 0.75);
  REQUIRE(a.curve.size() == 3);
  CHECK(a.curve.back().step == 150);
  CHECK(a.curve.back().silhouette < a.curve.front().silhouette);
  CHECK(a.mesh.has_colors());
  RefineResult b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = refine_mesh(views, start, s);
  }
  CHECK((a.mesh.V.array() == b.mesh.V.array()).all());
  CHECK((a.mesh.colors.array() == b.mesh.colors.array()).all());
  s.seed = 2;
  const RefineResult c = refine_mesh(views, start, s);
  CHECK((a.mesh.V.array() != c.mesh.V.array()).any());
  const Image sheet = refine_preview_sheet(views, {0, 1, 2}, a.mesh, s.raster);
  CHECK(sheet.width == 120);
  CHECK(sheet.height == 80);
  fs::remove_all(dir);
}

namespace {
/// Mean distance of the vertices from the origin.
double mean_radius(const Points& V) { return V.rowwise().norm().mean(); }
}  // namespace

TEST_CASE("refine: started on the object itself, the exact silhouette keeps it and the soft one shrinks it") {
  // An ellipsoid (an icosphere scaled per axis) seen in 12 views of 64 px rendered at `render`'s 3 x 3 samples.
  const fs::path dir = test::scratch_dir("refine_exact");
  Mesh obj = make_icosphere(Vec3::Zero(), 1.0, 3);
  obj.V.col(0) *= 0.75;
  obj.V.col(1) *= 0.45;
  obj.V.col(2) *= 0.6;
  ViewSetSettings vs;
  vs.views = 12;
  vs.size = 64;
  vs.elevation_min = -20;
  vs.elevation_max = 50;
  REQUIRE(vs.render.supersampling == 3);
  render_view_set(obj, (dir / "views").string(), vs, 3);
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  RefineSettings s;
  s.iters = 100;
  s.views_per_step = 4;
  s.w_rgb = s.w_edge = s.w_normal = s.w_laplacian = 0;  // the silhouette term alone
  s.log_every = 100;
  const double r0 = mean_radius(obj.V);
  s.exact_silhouette = 3;
  s.exact_after = 0;
  const RefineResult exact = refine_mesh(views, obj, s);
  s.exact_silhouette = 0;
  const RefineResult soft = refine_mesh(views, obj, s);
  const double shrink_exact = 1 - mean_radius(exact.mesh.V) / r0, shrink_soft = 1 - mean_radius(soft.mesh.V) / r0;
  INFO("shrinkage: exact ", shrink_exact, ", soft ", shrink_soft);
  CHECK(std::abs(shrink_exact) < 0.002);
  CHECK(shrink_soft > 0.005);
  const double iou_exact = mean_silhouette_iou(exact.mesh, views), iou_soft = mean_silhouette_iou(soft.mesh, views);
  INFO("silhouette IoU: exact ", iou_exact, ", soft ", iou_soft);
  CHECK(iou_exact > 0.98);  // 2 x 2 samples against the targets' 3 x 3
  CHECK(iou_soft < iou_exact - 0.02);
  fs::remove_all(dir);
}

TEST_CASE("refine: by default the colour term fits the colours and leaves the positions to the silhouettes") {
  const fs::path dir = box_views("refine_rgb");
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  RefineSettings s = short_run(40, 3, 40);
  const Mesh start = refine_sphere(2, 1.0);
  REQUIRE(!s.rgb_moves_vertices);
  const RefineResult colours_only = refine_mesh(views, start, s);
  s.w_rgb = 0;
  const RefineResult silhouettes = refine_mesh(views, start, s);
  // The same positions as without the colour term, bit for bit; the colours fitted (the box renders lit grey).
  CHECK((colours_only.mesh.V.array() == silhouettes.mesh.V.array()).all());
  CHECK(colours_only.curve.back().rgb > 0);
  CHECK((colours_only.mesh.colors.array() - 0.5f).abs().maxCoeff() > 0.01f);
  CHECK((silhouettes.mesh.colors.array() == 0.5f).all());
  // The paper's way: the colour term moves the vertices too.
  s.w_rgb = 1;
  s.rgb_moves_vertices = true;
  const RefineResult both = refine_mesh(views, start, s);
  CHECK((both.mesh.V.array() != silhouettes.mesh.V.array()).any());
  CHECK(paper_loss(RefineSettings{}).rgb_moves_vertices);
  fs::remove_all(dir);
}

namespace {
/// An icosphere of radius 0.8 (level 4) with, when `depth` > 0, a smooth dimple of that depth around its top
/// (+y) pole, within 15 degrees of it: no view at elevation 20-70 degrees sees it on a contour (a view at
/// elevation e has its contour at latitudes up to 90 - e). `cap` gets the vertices within the dimple.
Mesh dimpled_sphere(double depth, std::vector<int>* cap = nullptr) {
  Mesh m = make_icosphere(Vec3::Zero(), 0.8, 4);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const double theta = std::acos(std::clamp(m.V(v, 1) / 0.8, -1.0, 1.0)) * 180 / M_PI;  // from the pole
    if (theta >= 15) continue;
    m.V.row(v) *= 1 - depth / 0.8 * std::cos(M_PI / 2 * theta / 15);
    if (cap) cap->push_back(static_cast<int>(v));
  }
  return m;
}
}  // namespace

TEST_CASE("refine --lit: shading finds a dimple that no silhouette shows, the colours alone do not") {
  const fs::path dir = test::scratch_dir("refine_lit");
  const double depth = 0.12;
  std::vector<int> cap;
  const Mesh dimpled = dimpled_sphere(depth, &cap);
  ViewSetSettings vs;
  vs.views = 12;
  vs.size = 64;
  vs.elevation_min = 20;
  vs.elevation_max = 70;
  render_view_set(dimpled, (dir / "views").string(), vs, 7);
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  // From the sphere itself (the dimpled sphere's visual hull for these views), exact silhouettes from the start.
  const Mesh start = dimpled_sphere(0);
  // 300 steps; under AddressSanitizer (about 40x slower here) 20, for the memory checks: the effect is the normal
  // build's to check.
  const long steps = test::kAddressSanitizer ? 20 : 300;
  RefineSettings s = short_run(steps, 4, steps);
  s.exact_after = 0;
  const RefineResult unlit = refine_mesh(views, start, s);
  s.lit = true;
  REQUIRE(lit_from(s) == 0);
  const RefineResult lit = refine_mesh(views, start, s);
  // How far the dimple's vertices sank towards the centre, on average, against the truth.
  const auto sink = [&](const Points& V) {
    double d = 0;
    for (const int v : cap) d += start.V.row(v).norm() - V.row(v).norm();
    return d / static_cast<double>(cap.size());
  };
  const double want = sink(dimpled.V), got_lit = sink(lit.mesh.V), got_unlit = sink(unlit.mesh.V);
  INFO("the dimple's ", cap.size(), " vertices sink by ", got_lit, " lit, ", got_unlit, " unlit (truth ", want, ")");
  if (!test::kAddressSanitizer) {
    CHECK(got_lit > 0.7 * want);               // 0.052 of 0.053
    CHECK(std::abs(got_unlit) < 0.15 * want);  // 0.003
  }
  // One albedo for the whole mesh (the default), near `render`'s grey (0.72, 0.72, 0.75).
  for (Eigen::Index v = 1; v < lit.mesh.colors.rows(); ++v)
    CHECK((lit.mesh.colors.row(v).array() == lit.mesh.colors.row(0).array()).all());
  if (!test::kAddressSanitizer) CHECK(lit.mesh.colors(0, 0) == doctest::Approx(0.72).epsilon(0.1));
  // Per-vertex albedo: the colours differ, and the dimple is found too (0.055).
  s.uniform_albedo = false;
  const RefineResult per_vertex = refine_mesh(views, start, s);
  CHECK((per_vertex.mesh.colors.array() != per_vertex.mesh.colors(0, 0)).any());
  if (!test::kAddressSanitizer) CHECK(sink(per_vertex.mesh.V) > 0.5 * want);
  // Shading starts with the exact silhouette, or at once without it; refused without the colour term.
  s.exact_after = 100;
  CHECK(lit_from(s) == 100);
  s.exact_silhouette = 0;
  CHECK(lit_from(s) == 0);
  s.lit = false;
  CHECK(lit_from(s) == -1);
  s.lit = true;
  s.w_rgb = 0;
  CHECK_THROWS_AS(validate_refine_settings(s), InvalidInput);
  s.w_rgb = 1;
  s.raster.lit = true;  // the schedule is refine's
  CHECK_THROWS_AS(validate_refine_settings(s), InvalidInput);
  fs::remove_all(dir);
}

TEST_CASE("refine: view folders and settings are checked, naming the file") {
  const fs::path dir = test::scratch_dir("refine_bad");
  CHECK_THROWS_AS(read_target_views((dir / "none").string()), IoError);
  fs::create_directories(dir / "empty");
  try {
    read_target_views((dir / "empty").string());
    FAIL("expected IoError");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("no views") != std::string::npos);
  }
  // A camera whose size differs from its image.
  const fs::path v = box_views("refine_bad_views");
  Camera cam = read_camera((v / "views" / "03.json").string());
  cam.width = 64;
  write_camera((v / "views" / "03.json").string(), cam);
  try {
    read_target_views((v / "views").string());
    FAIL("expected IoError");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("03.png: 40 x 40 pixels, its camera says 64 x 40") != std::string::npos);
  }
  // Chosen views come in the order asked; an unknown name is refused.
  const auto two = read_target_views((v / "views").string(), Eigen::Vector3d::Ones(), {"05", "01"});
  REQUIRE(two.size() == 2);
  CHECK(two[0].name == "05");
  CHECK(two[1].name == "01");
  CHECK_THROWS_AS(read_target_views((v / "views").string(), Eigen::Vector3d::Ones(), {"99"}), IoError);
  RefineSettings s;
  s.momentum = 1;
  CHECK_THROWS_AS(validate_refine_settings(s), InvalidInput);
  s = {};
  s.w_normal = -1;
  CHECK_THROWS_AS(validate_refine_settings(s), InvalidInput);
  CHECK_THROWS_AS(refine_mesh({}, refine_sphere(1), RefineSettings{}), InvalidInput);
  fs::remove_all(dir);
  fs::remove_all(v);
}

TEST_CASE("refine with the adversarial critic: both losses reported, seeded and thread-independent") {
  const fs::path dir = box_views("refine_adv");
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  RefineSettings s = short_run(20, 2, 10);
  s.w_adversarial = 0.5;
  s.critic.size = 16;
  s.critic.stem = 4;
  s.critic.block_layers = 2;
  s.critic.growth = 3;
  s.critic.key1 = s.critic.key2 = 2;
  const Mesh start = refine_sphere(2, 1.0);
  const RefineResult a = refine_mesh(views, start, s);
  REQUIRE(a.curve.size() == 2);
  for (const RefineRow& r : a.curve) {
    CHECK(r.adversarial > 0);
    CHECK(r.critic > 0);
    CHECK(std::isfinite(r.loss));
  }
  RefineResult b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = refine_mesh(views, start, s);
  }
  CHECK((a.mesh.V.array() == b.mesh.V.array()).all());
  // The critic's term moves the mesh: without it the result differs.
  s.w_adversarial = 0;
  const RefineResult c = refine_mesh(views, start, s);
  CHECK((a.mesh.V.array() != c.mesh.V.array()).any());
  CHECK(c.curve.back().adversarial == 0);
  fs::remove_all(dir);
}

TEST_CASE("subdivide_midpoints: 4 faces per face, shared midpoints, area and colours kept, refine grows the mesh") {
  const Mesh ico = make_icosphere(Vec3::Zero(), 1.0, 0);
  Points colours(12, 3);
  for (int i = 0; i < 12; ++i) colours.row(i) = Vec3(i / 11.0, 1 - i / 11.0, 0.5).transpose();
  Points finer_colours;
  const Mesh m = subdivide_midpoints(ico, colours, &finer_colours);
  CHECK(m.V.rows() == 12 + 30);  // one new vertex per edge
  CHECK(m.F.rows() == 80);
  CHECK(finer_colours.rows() == 42);
  const auto area = [](const Mesh& x) {
    double a = 0;
    for (Eigen::Index f = 0; f < x.F.rows(); ++f) {
      const Vec3 p = x.V.row(x.F(f, 0)), q = x.V.row(x.F(f, 1)), r = x.V.row(x.F(f, 2));
      a += 0.5 * (q - p).cross(r - p).norm();
    }
    return a;
  };
  CHECK(area(m) == doctest::Approx(area(ico)));  // flat split: the same surface
  // Each new vertex is the midpoint of an edge, with the mean colour of its ends.
  for (Eigen::Index f = 0; f < ico.F.rows(); ++f) {
    const int32_t a = m.F(4 * f, 0), ab = m.F(4 * f, 1);
    CHECK(a == ico.F(f, 0));
    const int32_t b = ico.F(f, 1);
    CHECK((m.V.row(ab) - 0.5 * (ico.V.row(a) + ico.V.row(b))).norm() < 1e-15);
    CHECK((finer_colours.row(ab) - 0.5 * (colours.row(a) + colours.row(b))).norm() < 1e-15);
  }
  // In refine: a 162-vertex sphere subdivided once ends with 642 vertices.
  const fs::path dir = box_views("refine_subdivide");
  const std::vector<TargetView> views = read_target_views((dir / "views").string());
  RefineSettings s;
  s.iters = 20;
  s.subdivide_at = {10};
  const RefineResult r = refine_mesh(views, refine_sphere(2, 1.0), s);
  CHECK(r.mesh.V.rows() == 642);
  CHECK(r.mesh.F.rows() == 1280);
  CHECK(r.mesh.colors.rows() == 642);
  fs::remove_all(dir);
}
