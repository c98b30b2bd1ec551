#include "extract/adaptive.h"

#include "core/error.h"
#include "core/primitives.h"
#include "mesh_checks.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

using namespace sdfkit;
using sdfkit::test::bad_edges;
using sdfkit::test::euler_characteristic;
using sdfkit::test::identical;

namespace {

BatchField pointwise(std::function<double(const Vec3&)> f) {
  return [f](const Points& p, Eigen::VectorXd& v) {
    v.resize(p.rows());
    for (Eigen::Index r = 0; r < p.rows(); ++r) v[r] = f(p.row(r).transpose());
  };
}

ExtractSettings settings(int res, int coarse) {
  ExtractSettings s;
  s.resolution = res;
  s.coarse_resolution = coarse;
  s.max_batch = 5000;  // several batches per level
  return s;
}

}  // namespace

TEST_CASE("adaptive and dense give identical meshes for sphere, torus and box SDFs") {
  const std::vector<std::pair<const char*, BatchField>> fields = {
      {"sphere", pointwise([](const Vec3& p) { return sphere_sdf(p, Vec3(0.05, -0.1, 0.02), 0.7); })},
      {"torus", pointwise([](const Vec3& p) { return torus_sdf(p, Vec3(0.0, 0.03, -0.02), 0.6, 0.18); })},
      // Box faces on grid planes: many values are exactly 0 (snapped vertices).
      {"box", pointwise([](const Vec3& p) { return box_sdf(p, Vec3(-0.6, -0.45, -0.3), Vec3(0.6, 0.45, 0.3)); })}};
  for (const auto& item : fields) {
    const auto& name = item.first;
    const auto& field = item.second;
    INFO(name);
    const ExtractSettings s = settings(81, 11);
    const ExtractResult dense = dense_extract(field, s);
    const ExtractResult adaptive = adaptive_extract(field, s);
    CHECK(dense.evaluations == 81L * 81 * 81);
    CHECK(adaptive.evaluations < dense.evaluations / 4);
    CHECK(dense.mesh.F.rows() > 1000);
    CHECK(identical(dense.mesh, adaptive.mesh));
    CHECK(bad_edges(adaptive.mesh) == 0);
    CHECK(adaptive.level_cells.size() == 4);  // cells of 8, 4, 2 fine cells, then the final cells
    long sum = 0;
    for (long e : adaptive.level_evaluations) sum += e;
    CHECK(sum == adaptive.evaluations);
  }
}

TEST_CASE("a plate thinner than a coarse cell but thicker than a final cell survives exactly") {
  // Coarse cells are 16 fine cells wide; the plate is 2.5 fine cells thick and sits between coarse grid planes,
  // so no coarse grid point is inside: a sign-change refinement would lose it, the distance bound does not.
  ExtractSettings s = settings(129, 9);
  const double h = s.box_size / (s.resolution - 1), coarse = 16 * h;
  const double z0 = s.box_min.z() + 3 * coarse + 5.3 * h;  // strictly between coarse planes
  const Vec3 lo(-0.5, -0.4, z0), hi(0.5, 0.4, z0 + 2.5 * h);
  const BatchField plate = pointwise([&](const Vec3& p) { return box_sdf(p, lo, hi); });
  for (int k = 0; k < s.coarse_resolution; ++k)
    for (int j = 0; j < s.coarse_resolution; ++j)
      for (int i = 0; i < s.coarse_resolution; ++i)
        REQUIRE(box_sdf(s.box_min + coarse * Vec3(i, j, k), lo, hi) > 0);
  const ExtractResult dense = dense_extract(plate, s);
  const ExtractResult adaptive = adaptive_extract(plate, s);
  CHECK(dense.mesh.F.rows() > 0);
  CHECK(identical(dense.mesh, adaptive.mesh));
  CHECK(bad_edges(adaptive.mesh) == 0);
  CHECK(euler_characteristic(adaptive.mesh) == 2);
  CHECK(signed_volume(adaptive.mesh) == doctest::Approx(1.0 * 0.8 * 2.5 * h).epsilon(0.1));
  CHECK(adaptive.evaluations < dense.evaluations / 10);
  // The sign-change rule (MISE) sees no inside coarse corner and loses the whole plate.
  s.refine = RefineRule::kSignChange;
  const ExtractResult mise = adaptive_extract(plate, s);
  CHECK(mise.mesh.F.rows() == 0);
  CHECK(mise.level_cells.front() == 8 * 8 * 8);
}

TEST_CASE("sign-change refinement agrees with dense on a fat shape") {
  const BatchField sphere = pointwise([](const Vec3& p) { return sphere_sdf(p, Vec3(0.01, 0.02, -0.03), 0.6); });
  ExtractSettings s = settings(65, 9);
  s.refine = RefineRule::kSignChange;
  const ExtractResult mise = adaptive_extract(sphere, s);
  CHECK(identical(mise.mesh, dense_extract(sphere, s).mesh));
  CHECK(mise.evaluations < 65L * 65 * 65 / 3);
}

TEST_CASE("evaluation count at 257^3 is a few percent of dense (without running dense)") {
  ExtractSettings s = settings(257, 17);
  s.max_batch = 65536;
  const ExtractResult a =
      adaptive_extract(pointwise([](const Vec3& p) { return sphere_sdf(p, Vec3::Zero(), 0.5); }), s);
  CHECK(a.evaluations < 0.05 * 257.0 * 257 * 257);
  CHECK(bad_edges(a.mesh) == 0);
  CHECK(euler_characteristic(a.mesh) == 2);
  double worst = 0;
  for (Eigen::Index v = 0; v < a.mesh.V.rows(); ++v) worst = std::max(worst, std::abs(a.mesh.V.row(v).norm() - 0.5));
  CHECK(worst < 1e-4);
}

TEST_CASE("safety factor: an over-estimating field needs safety = its Lipschitz constant") {
  // 2 x the sphere SDF over-estimates distances by 2: with safety 2 the result equals dense exactly; with
  // safety 1 cells near the surface are wrongly discarded and holes appear.
  const BatchField doubled = pointwise([](const Vec3& p) { return 2.0 * sphere_sdf(p, Vec3::Zero(), 0.63); });
  ExtractSettings s = settings(65, 9);
  const ExtractResult dense = dense_extract(doubled, s);
  s.safety = 2.0;
  CHECK(identical(dense.mesh, adaptive_extract(doubled, s).mesh));
  s.safety = 1.0;
  const ExtractResult unsafe = adaptive_extract(doubled, s);
  CHECK_FALSE(identical(dense.mesh, unsafe.mesh));
  CHECK(bad_edges(unsafe.mesh) > 0);
}

TEST_CASE("surface following closes the holes a misjudging field leaves, exactly as dense") {
  // Fields that over-estimate distances far beyond the safety factor (like an occupancy logit): the refinement
  // drops cells the surface runs through; following the surface from the cells kept restores them all.
  const std::vector<std::pair<const char*, BatchField>> fields = {
      {"doubled sphere", pointwise([](const Vec3& p) { return 2.0 * sphere_sdf(p, Vec3::Zero(), 0.63); })},
      {"3 x (sphere + thin rod)", pointwise([](const Vec3& p) {
         // A rod of radius 0.04 (1.2 final cells) along y from the sphere's centre down to y = -0.9.
         const double along = std::clamp(p.y(), -0.9, 0.3);
         const double rod = std::hypot(p.x(), p.z(), p.y() - along) - 0.04;
         return 3.0 * std::min(sphere_sdf(p, Vec3(0, 0.3, 0), 0.35), rod);
       })},
      {"10 x sphere leaving the box", pointwise([](const Vec3& p) { return 10.0 * sphere_sdf(p, Vec3(0.6, 0, 0), 0.9); })}};
  for (const auto& named : fields) {
    const std::string name = named.first;  // a plain variable: lambdas (INFO) may not capture structured bindings in C++17
    const BatchField& field = named.second;
    INFO(name);
    ExtractSettings s = settings(65, 9);
    const ExtractResult dense = dense_extract(field, s);
    const ExtractResult pruned = adaptive_extract(field, s);
    INFO(pruned.mesh.F.rows() << " faces pruned, " << dense.mesh.F.rows() << " dense");
    CHECK(bad_edges(pruned.mesh) > 0);  // the refinement alone leaves holes
    CHECK(pruned.followed_cells == 0);
    s.follow_surface = true;
    const ExtractResult followed = adaptive_extract(field, s);
    CHECK(followed.followed_cells > 0);
    CHECK(identical(dense.mesh, followed.mesh));
    CHECK(bad_edges(followed.mesh) == 0);
    CHECK(followed.evaluations < dense.evaluations / 2);
    long sum = 0;
    for (long e : followed.level_evaluations) sum += e;
    CHECK(sum == followed.evaluations);
  }
}

TEST_CASE("surface following adds nothing when the refinement already holds the surface") {
  const BatchField torus = pointwise([](const Vec3& p) { return torus_sdf(p, Vec3(0.0, 0.03, -0.02), 0.6, 0.18); });
  ExtractSettings s = settings(65, 9);
  const ExtractResult plain = adaptive_extract(torus, s);
  s.follow_surface = true;
  const ExtractResult followed = adaptive_extract(torus, s);
  CHECK(followed.followed_cells == 0);
  CHECK(followed.evaluations == plain.evaluations);
  CHECK(identical(plain.mesh, followed.mesh));
}

TEST_CASE("a surface leaving the box is capped, identically in both paths") {
  const BatchField big = pointwise([](const Vec3& p) { return sphere_sdf(p, Vec3(0.6, 0, 0), 0.9); });
  const ExtractSettings s = settings(49, 7);
  const ExtractResult dense = dense_extract(big, s);
  const ExtractResult adaptive = adaptive_extract(big, s);
  CHECK(identical(dense.mesh, adaptive.mesh));
  CHECK(bad_edges(adaptive.mesh) == 0);
  CHECK(euler_characteristic(adaptive.mesh) == 2);
  double max_x = -1;
  for (Eigen::Index v = 0; v < adaptive.mesh.V.rows(); ++v) max_x = std::max(max_x, adaptive.mesh.V(v, 0));
  CHECK(max_x == doctest::Approx(1.05));
}

TEST_CASE("iso value and bad settings / bad fields") {
  const BatchField sphere = pointwise([](const Vec3& p) { return p.norm(); });
  ExtractSettings s = settings(33, 5);
  s.iso = 0.5;  // the level set |p| = 0.5
  const ExtractResult r = adaptive_extract(sphere, s);
  CHECK(identical(r.mesh, dense_extract(sphere, s).mesh));
  for (Eigen::Index v = 0; v < r.mesh.V.rows(); ++v) CHECK(r.mesh.V.row(v).norm() == doctest::Approx(0.5).epsilon(0.02));

  ExtractSettings bad = settings(33, 7);  // 32 / 6 is not a power of two
  CHECK_THROWS_AS(adaptive_extract(sphere, bad), InvalidInput);
  const BatchField nan_field = pointwise([](const Vec3& p) { return p.x() > 0.3 ? std::nan("") : 1.0; });
  CHECK_THROWS_AS(adaptive_extract(nan_field, settings(33, 5)), InvalidInput);
  const BatchField short_field = [](const Points& p, Eigen::VectorXd& v) { v.setZero(p.rows() / 2); };
  CHECK_THROWS_AS(dense_extract(short_field, settings(9, 3)), InvalidInput);
}
