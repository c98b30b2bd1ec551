// Silhouette carving (refine/carve.h): the visual hull of a rendered box is the box (a convex shape is its own
// hull with enough views), the hull shrinks as views are added, an intersection with a starting mesh is the
// closed-form intersection of the two boxes, completion restores the leg a starting mesh lacks and adds nothing
// to a whole one, and bad input is refused.
#include "refine/carve.h"

#include "camera/views.h"
#include "core/error.h"
#include "core/primitives.h"
#include "metrics/iou.h"
#include "scratch.h"
#include "sdf/winding.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const Vec3 kLo(-0.6, -0.3, -0.4), kHi(0.5, 0.35, 0.45);

/// `count` views of `mesh` at 96 px, elevation `elevation_min`..`elevation_max` degrees, in the scratch folder `name`.
std::vector<TargetView> views_of(const Mesh& mesh, const std::string& name, int count, double elevation_min,
                                 double elevation_max) {
  const fs::path dir = test::scratch_dir(name);
  fs::remove_all(dir);
  ViewSetSettings vs;
  vs.views = count;
  vs.size = 96;
  vs.elevation_min = elevation_min;
  vs.elevation_max = elevation_max;
  render_view_set(mesh, (dir / "views").string(), vs, 3);
  return read_target_views((dir / "views").string());
}

/// Views of the box above, rendered around and above it.
std::vector<TargetView> box_views(int count) {
  return views_of(make_box(kLo, kHi), "carve_box_" + std::to_string(count), count, -30, 60);
}

double box_volume(const Vec3& lo, const Vec3& hi) { return (hi - lo).prod(); }

}  // namespace

TEST_CASE("carve: the visual hull of a box from 16 views is the box") {
  const auto views = box_views(16);
  CarveSettings cs;
  cs.resolution = 97;
  CarveReport rep;
  const Mesh hull = carve_mesh(views, nullptr, cs, &rep);
  const double truth = box_volume(kLo, kHi);
  CHECK(rep.evaluations == 97L * 97 * 97);
  CHECK(rep.faces == hull.F.rows());
  CHECK(rep.init_volume == 0);
  // A hull contains the shape: only the discretisation (a cell of 2.1/96 = 0.022) may cut into it, and 16 views
  // of a convex box leave little beyond it.
  CHECK(rep.volume > 0.97 * truth);
  CHECK(rep.volume < 1.10 * truth);
  CHECK(voxel_iou(hull, make_box(kLo, kHi)) > 0.9);
}

TEST_CASE("carve: more views never enlarge the hull") {
  const auto views = box_views(12);
  CarveSettings cs;
  cs.resolution = 49;
  CarveReport three, twelve;
  carve_mesh(std::vector<TargetView>(views.begin(), views.begin() + 3), nullptr, cs, &three);
  carve_mesh(views, nullptr, cs, &twelve);
  CHECK(twelve.volume <= three.volume + 1e-9);
  // Every vertex of the 12-view hull lies inside the 3-view hull's solid (up to a cell).
  const Mesh h3 = carve_mesh(std::vector<TargetView>(views.begin(), views.begin() + 3), nullptr, cs);
  const Mesh h12 = carve_mesh(views, nullptr, cs);
  const WindingNumber w(h3);
  long outside = 0;
  for (Eigen::Index i = 0; i < h12.V.rows(); ++i) {
    const Vec3 p = h12.V.row(i).transpose();
    if (w(p * 0.97) < 0.5) ++outside;  // shrunk by 3% towards the centre: clear of the shared surface
  }
  CHECK(outside == 0);
}

TEST_CASE("carve: with a starting mesh, the intersection of the box and the mesh") {
  const auto views = box_views(16);
  // A starting box that covers the right part of the object and sticks out of it on every other side.
  const Vec3 lo2(0.0, -0.8, -0.8), hi2(0.9, 0.8, 0.8);
  const Mesh init = make_box(lo2, hi2);
  CarveSettings cs;
  cs.resolution = 97;
  CarveReport rep;
  const Mesh m = carve_mesh(views, &init, cs, &rep);
  const Vec3 lo = kLo.cwiseMax(lo2), hi = kHi.cwiseMin(hi2);
  const double truth = box_volume(lo, hi);
  CHECK(rep.init_faces == init.F.rows());
  CHECK(rep.init_volume == doctest::Approx(box_volume(lo2, hi2)).epsilon(1e-9));
  CHECK(rep.volume > 0.95 * truth);
  CHECK(rep.volume < 1.10 * truth);
  // Nothing left of x = 0 (one cell of slack).
  CHECK(m.V.col(0).minCoeff() > -2.1 / 96);
}

TEST_CASE("carve: completion adds back the part a starting mesh lacks, and nothing to a whole one") {
  // The object: the box above on a leg under one corner (the part a recon mesh could miss), 16 views at elevation
  // 0-30 degrees (DISN's renders: 25-30).
  const Vec3 flo(0.3, -0.85, 0.25), fhi(0.45, -0.3, 0.4);
  const Mesh body = make_box(kLo, kHi), foot = make_box(flo, fhi);
  Mesh object;
  object.V.resize(body.V.rows() + foot.V.rows(), 3);
  object.V << body.V, foot.V;
  object.F.resize(body.F.rows() + foot.F.rows(), 3);
  object.F << body.F, (foot.F.array() + static_cast<int>(body.V.rows())).matrix();
  const auto views = views_of(object, "carve_complete", 16, 0, 30);
  const double body_volume = box_volume(kLo, kHi), foot_volume = box_volume(flo, fhi);
  // A starting mesh around the body only.
  const Mesh start = make_box(Vec3(-0.9, -0.28, -0.9), Vec3(0.9, 0.9, 0.9));
  CarveSettings cs;
  cs.resolution = 97;
  CarveReport plain, completed;
  carve_mesh(views, &start, cs, &plain);
  CHECK(plain.volume < 1.1 * body_volume);
  CHECK(plain.carved_volume == plain.volume);
  CHECK(plain.unexplained_pixels == 0);
  cs.complete = true;
  const Mesh m = carve_mesh(views, &start, cs, &completed);
  // Most views see the leg on pixels the carved body leaves unexplained: the leg's hull joins the body.
  CHECK(completed.unexplained_pixels > 100);
  CHECK(completed.carved_volume == doctest::Approx(plain.volume).epsilon(0.02));
  CHECK(completed.volume - completed.carved_volume > 0.3 * foot_volume);  // 48%: the body hides the rest in half the views
  CHECK(completed.volume - completed.carved_volume < 1.5 * foot_volume);
  CHECK(m.V.col(1).minCoeff() < flo.y() + 0.05);
  // All 16 views required: the views in which the body hides part of the leg veto that part.
  CarveSettings all = cs;
  all.complete_views = 16;
  CarveReport strict;
  carve_mesh(views, &start, all, &strict);
  CHECK(strict.volume < completed.volume);
  // A starting mesh around the whole object leaves only contour slivers, which the erosion drops: nothing added.
  const Mesh whole = make_box(Vec3(-0.9, -0.9, -0.9), Vec3(0.9, 0.9, 0.9));
  CarveReport whole_plain, whole_completed;
  cs.complete = false;
  carve_mesh(views, &whole, cs, &whole_plain);
  cs.complete = true;
  carve_mesh(views, &whole, cs, &whole_completed);
  CHECK(whole_completed.volume == doctest::Approx(whole_plain.volume).epsilon(0.01));
  // A starting mesh that misses the object entirely: every silhouette pixel is unexplained, the result is the
  // visual hull.
  const Mesh away = make_box(Vec3(0.85, 0.85, 0.85), Vec3(1.0, 1.0, 1.0));
  CarveReport away_rep, hull_rep;
  carve_mesh(views, &away, cs, &away_rep);
  CarveSettings hull_settings;
  hull_settings.resolution = 97;
  carve_mesh(views, nullptr, hull_settings, &hull_rep);
  CHECK(away_rep.carved_volume == 0);
  CHECK(away_rep.volume > 0.95 * hull_rep.volume);
  CHECK(away_rep.volume <= hull_rep.volume * 1.001);
  fs::remove_all(test::scratch_dir("carve_complete"));
}

TEST_CASE("carve: bad input is refused with a message") {
  const auto views = box_views(4);
  CarveSettings cs;
  cs.resolution = 33;
  CHECK_THROWS_WITH_AS(carve_mesh({}, nullptr, cs), "carve: no views", InvalidInput);
  cs.threshold = 1.0;
  CHECK_THROWS_AS(carve_mesh(views, nullptr, cs), InvalidInput);
  cs.threshold = 0.5;
  cs.resolution = 2;
  CHECK_THROWS_AS(carve_mesh(views, nullptr, cs), InvalidInput);
  cs.resolution = 33;
  const Mesh empty;
  CHECK_THROWS_AS(carve_mesh(views, &empty, cs), InvalidInput);
  cs.complete_erode = -1;
  CHECK_THROWS_WITH_AS(carve_mesh(views, nullptr, cs), "carve: complete_erode must be 0..64 pixels", InvalidInput);
  cs.complete_erode = 1;
  // A starting mesh far from the object: nothing is inside both.
  const Mesh away = make_box(Vec3(0.8, 0.8, 0.8), Vec3(1.0, 1.0, 1.0));
  CHECK_THROWS_WITH_AS(carve_mesh(views, &away, cs),
                       "carve: nothing left: no grid point lies inside every view's silhouette and inside the "
                       "starting mesh",
                       InvalidInput);
}

TEST_CASE("carve: silhouette samples are bilinear between pixel centres and 0 outside the image") {
  Image a(3, 2, 1, 0.0f);
  a.at(0, 0) = 1.0f;
  a.at(1, 0) = 0.5f;
  a.at(2, 1) = 0.25f;
  CHECK(sample_alpha(a, 0.5, 0.5) == doctest::Approx(1.0));
  CHECK(sample_alpha(a, 1.5, 0.5) == doctest::Approx(0.5));
  CHECK(sample_alpha(a, 1.0, 0.5) == doctest::Approx(0.75));
  CHECK(sample_alpha(a, 2.0, 1.0) == doctest::Approx((0.5 + 0.25) / 4));
  CHECK(sample_alpha(a, 2.5, 1.5) == doctest::Approx(0.25));
  CHECK(sample_alpha(a, -2.0, 0.5) == 0.0);
  CHECK(sample_alpha(a, 0.5, 9.0) == 0.0);
  CHECK(sample_alpha(a, std::nan(""), 0.5) == 0.0);
}
