#include "core/primitives.h"
#include "core/random.h"
#include "sdf/winding.h"

#include <doctest/doctest.h>

using namespace sdfkit;

namespace {
Mesh open_box() {  // unit box without its top (+z) face
  Mesh b = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  Mesh out;
  out.V = b.V;
  std::vector<int> keep;
  for (int f = 0; f < b.F.rows(); ++f) {
    const double z = (b.V(b.F(f, 0), 2) + b.V(b.F(f, 1), 2) + b.V(b.F(f, 2), 2)) / 3;
    if (z < 0.49) keep.push_back(f);
  }
  out.F.resize(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t i = 0; i < keep.size(); ++i) out.F.row(static_cast<Eigen::Index>(i)) = b.F.row(keep[i]);
  return out;
}
}  // namespace

TEST_CASE("winding number: 1 inside, 0 outside a closed sphere, matches brute force everywhere") {
  const Mesh s = make_icosphere(Vec3(0.1, -0.2, 0.3), 0.8, 4);  // 5120 triangles
  const WindingNumber wn(s, 2.0);
  Rng rng(7);
  double max_err = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 p(rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5));
    const double ref = WindingNumber::brute_force(s, p);
    const double fast = wn(p);
    max_err = std::max(max_err, std::abs(ref - fast));
    const double d = (p - Vec3(0.1, -0.2, 0.3)).norm();
    if (d < 0.7) CHECK(ref == doctest::Approx(1.0).epsilon(1e-9));
    if (d > 0.9) CHECK(std::abs(ref) < 1e-9);
  }
  // Far-field expansion error (dipole + first order, beta = 2) stays far below the 0.5 decision margin.
  CHECK(max_err < 0.02);
  MESSAGE("max |fast - brute| on the sphere: " << max_err);
}

TEST_CASE("winding number: larger beta is more accurate, batch query equals single queries") {
  const Mesh t = make_torus(Vec3::Zero(), 0.7, 0.25, 48, 24);
  const WindingNumber coarse(t, 1.0), fine(t, 4.0);
  Rng rng(3);
  Points P(200, 3);
  for (int i = 0; i < 200; ++i) P.row(i) << rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.4, 0.4);
  double e_coarse = 0, e_fine = 0;
  for (int i = 0; i < 200; ++i) {
    const double ref = WindingNumber::brute_force(t, P.row(i).transpose());
    e_coarse = std::max(e_coarse, std::abs(coarse(P.row(i).transpose()) - ref));
    e_fine = std::max(e_fine, std::abs(fine(P.row(i).transpose()) - ref));
  }
  CHECK(e_fine <= e_coarse);
  CHECK(e_fine < 1e-3);
  const Eigen::VectorXd batch = fine.query(P);
  for (int i = 0; i < 200; ++i) CHECK(batch[i] == fine(P.row(i).transpose()));
}

TEST_CASE("winding number of an open box: inside the box above 0.5, outside below") {
  const Mesh b = open_box();
  const WindingNumber wn(b);
  // Centre of a cube seen through 5 of its 6 faces: 5/6 exactly.
  CHECK(wn(Vec3::Zero()) == doctest::Approx(5.0 / 6.0).epsilon(1e-6));
  CHECK(wn(Vec3(0, 0, -0.3)) > 0.5);
  CHECK(wn(Vec3(0, 0, 1.0)) < 0.5);
  CHECK(std::abs(wn(Vec3(2, 0, 0))) < 0.05);
}

TEST_CASE("solid angle sign: positive behind an outward face") {
  const Vec3 a(0, 0, 1), b(1, 0, 1), c(0, 1, 1);
  CHECK(triangle_solid_angle(Vec3::Zero(), a, b, c) > 0);
  CHECK(triangle_solid_angle(Vec3(0, 0, 2), a, b, c) < 0);
  CHECK(triangle_solid_angle(Vec3(3, 3, 1), a, b, c) == doctest::Approx(0.0));  // in the plane, outside
}
