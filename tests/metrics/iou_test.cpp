#include "metrics/iou.h"

#include "core/error.h"
#include "core/primitives.h"
#include "core/random.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {

// Volume of the intersection of two balls of radii R, r whose centres are d apart (0 < d < R + r).
double lens_volume(double R, double r, double d) {
  if (d >= R + r) return 0;
  if (d <= std::abs(R - r)) return 4.0 / 3.0 * M_PI * std::pow(std::min(R, r), 3);
  return M_PI * std::pow(R + r - d, 2) * (d * d + 2 * d * r - 3 * r * r + 2 * d * R + 6 * r * R - 3 * R * R) / (12 * d);
}

Mesh open_box_top(const Vec3& lo, const Vec3& hi) {  // a box without its two top triangles
  Mesh m = make_box(lo, hi);
  Mesh open;
  open.V = m.V;
  open.F.resize(m.F.rows() - 2, 3);
  Eigen::Index k = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    bool top = true;
    for (int c = 0; c < 3; ++c) top = top && m.V(m.F(f, c), 2) == hi.z();
    if (!top) open.F.row(k++) = m.F.row(f);
  }
  REQUIRE(k == open.F.rows());
  return open;
}

}  // namespace

TEST_CASE("triangle/box overlap against dense point sampling of the triangle") {
  Rng rng(3);
  const Vec3 c(0, 0, 0), h(0.5, 0.5, 0.5);
  int overlaps = 0;
  for (int t = 0; t < 300; ++t) {
    Vec3 p[3];
    for (auto& v : p) v = Vec3(rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5));
    // sampled points inside the box prove overlap; the SAT must agree whenever a sample is clearly inside
    bool sample_inside = false;
    for (int s = 0; s < 2000 && !sample_inside; ++s) {
      double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
      const Vec3 q = (1 - r1) * p[0] + r1 * (1 - r2) * p[1] + r1 * r2 * p[2];
      sample_inside = (q.cwiseAbs().array() < 0.499).all();
    }
    const bool sat = triangle_box_overlap(p[0], p[1], p[2], c, h);
    if (sample_inside) CHECK(sat);
    overlaps += sat;
    // and a shrunken box (by 2%) overlapping implies the full box overlaps (monotone)
    if (triangle_box_overlap(p[0], p[1], p[2], c, 0.98 * h)) CHECK(sat);
  }
  CHECK(overlaps > 30);
  // separated by a diagonal plane only (bounding boxes overlap, triangle normal separates)
  CHECK_FALSE(triangle_box_overlap(Vec3(1.2, 0, 0), Vec3(0, 1.2, 0), Vec3(0, 0, 1.2) + Vec3(0, 0, 0.5), c,
                                   Vec3(0.3, 0.3, 0.3)));
  CHECK(triangle_box_overlap(Vec3(-2, -2, 0.1), Vec3(2, -2, 0.1), Vec3(0, 3, 0.1), c, h));
}

TEST_CASE("voxelised boxes: exact cell counts and IoU, DISN's indexing") {
  const VoxelGridSpec spec;  // (v + 1.1) / 2.4 * 110
  const double h = spec.cell();
  CHECK(h == doctest::Approx(2.4 / 110));
  // Box faces at cell centres: cells 10..29 in x, 20..39 in y, 30..59 in z are solid, nothing else.
  auto centre = [&](int i) { return spec.origin + (i + 0.5) * h; };
  const Mesh a = make_box(Vec3(centre(10), centre(20), centre(30)), Vec3(centre(29), centre(39), centre(59)));
  const VoxelGrid ga = voxelize_solid(a, spec);
  CHECK(ga.count() == 20L * 20 * 30);
  CHECK(ga.solid[(static_cast<size_t>(45) * 110 + 30) * 110 + 20] == 1);  // inside, filled
  CHECK(ga.solid[(static_cast<size_t>(45) * 110 + 30) * 110 + 30] == 0);
  const Mesh b = make_box(Vec3(centre(20), centre(20), centre(30)), Vec3(centre(39), centre(39), centre(59)));
  // overlap in x: cells 20..29 (10 of 20): IoU = 10 / 30
  CHECK(voxel_iou(a, b, spec) == doctest::Approx(1.0 / 3.0));
  CHECK(voxel_iou(a, a, spec) == 1.0);
}

TEST_CASE("voxel IoU of concentric spheres is near the closed form (r1/r2)^3") {
  const Mesh s1 = make_icosphere(Vec3::Zero(), 0.5, 5), s2 = make_icosphere(Vec3::Zero(), 0.7, 5);
  const double iou = voxel_iou(s1, s2);
  // The surface shell (cells touched by the surface count as solid) adds about half a cell (0.011) to both radii:
  // ((0.5 + 0.011) / (0.7 + 0.011))^3 = 0.371 against the exact 0.364: 3% covers it.
  CHECK(iou == doctest::Approx(std::pow(0.5 / 0.7, 3)).epsilon(0.03));
  const VoxelGrid g = voxelize_solid(s2);
  const double volume = g.count() * std::pow(g.spec.cell(), 3);
  CHECK(volume == doctest::Approx(4.0 / 3.0 * M_PI * std::pow(0.7, 3)).epsilon(0.06));
}

TEST_CASE("point IoU of two overlapping spheres matches the lens-volume closed form within 1%") {
  const double R = 0.6, r = 0.45, d = 0.35;
  const Mesh a = make_icosphere(Vec3::Zero(), R, 4), b = make_icosphere(Vec3(d, 0, 0), r, 4);
  PointIouSettings s;
  s.points = 100000;
  const PointIou p = point_iou(a, b, 11, s);
  const double inter = lens_volume(R, r, d);
  const double expected = inter / (4.0 / 3.0 * M_PI * (R * R * R + r * r * r) - inter);
  CHECK(p.iou == doctest::Approx(expected).epsilon(0.01));
  CHECK(point_iou(a, b, 11, s).iou == p.iou);  // deterministic
  // identical meshes
  CHECK(point_iou(a, a, 1, PointIouSettings{20000}).iou == 1.0);
}

TEST_CASE("point IoU works for an open mesh, voxel IoU leaks through holes larger than a cell") {
  const Mesh closed = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  const Mesh open = open_box_top(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  // A box missing one face: the winding number inside is 5/6 (five of six faces' solid angle): still inside.
  CHECK(point_iou(open, closed, 5, PointIouSettings{20000}).iou > 0.97);
  CHECK(voxel_iou(open, closed) < 0.5);  // documented limitation of flood fill
}

TEST_CASE("IoU refuses empty and NaN meshes") {
  const Mesh ok = make_box(Vec3::Zero(), Vec3::Ones());
  Mesh nan = ok;
  nan.V(1, 1) = std::nan("");
  CHECK_THROWS_WITH_AS(voxel_iou(Mesh{}, ok), doctest::Contains("prediction: empty mesh"), InvalidInput);
  CHECK_THROWS_WITH_AS(point_iou(ok, nan, 1), doctest::Contains("ground truth: non-finite"), InvalidInput);
}
