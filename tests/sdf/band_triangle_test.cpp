#include "core/random.h"
#include "sdf/band_triangle.h"
#include "sdf/bvh.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <limits>
#include <vector>

using namespace sdfkit;

namespace {
/// Triangles of many shapes: random, right-angled, obtuse slivers, needles, one repeated corner, all collinear.
std::vector<std::array<Vec3, 3>> triangle_zoo() {
  Rng rng(5);
  auto rv = [&](double s) { return Vec3(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s)); };
  std::vector<std::array<Vec3, 3>> t;
  for (int i = 0; i < 40; ++i) t.push_back({rv(0.1), rv(0.1), rv(0.1)});
  t.push_back({Vec3(0, 0, 0), Vec3(0.05, 0, 0), Vec3(0, 0.05, 0)});                     // axis-aligned
  t.push_back({Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0.05, 1e-4, 0.0)});                 // obtuse sliver
  t.push_back({Vec3(0, 0, 0), Vec3(0.1, 0.0, 0.0), Vec3(0.1, 1e-9, 1e-9)});             // needle: not regular
  t.push_back({Vec3(0.01, 0.02, 0.03), Vec3(0.01, 0.02, 0.03), Vec3(0.05, 0.0, 0.0)});  // repeated corner
  t.push_back({Vec3(0, 0, 0), Vec3(0.02, 0.02, 0.02), Vec3(0.04, 0.04, 0.04)});         // collinear
  for (int i = 0; i < 10; ++i) {  // large triangles (a voxel row runs through them)
    t.push_back({rv(1.0), rv(1.0), rv(1.0)});
  }
  return t;
}
}  // namespace

TEST_CASE("band triangle: squared distance equals the Voronoi-region closest point everywhere") {
  Rng rng(9);
  long compared = 0;
  for (const auto& c : triangle_zoo()) {
    const BandTriangle t = BandTriangle::make(c[0], c[1], c[2]);
    for (int i = 0; i < 400; ++i) {
      const Vec3 p(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3));
      const double ref = (closest_point_on_triangle(p, c[0], c[1], c[2]) - p).squaredNorm();
      CHECK(std::sqrt(t.squared_distance(p)) == doctest::Approx(std::sqrt(ref)).epsilon(0).scale(0).epsilon(1e-12));
      ++compared;
    }
  }
  CHECK(compared > 10000);
  // Points on the triangle's plane, edges and corners: distance 0 (or round-off).
  const BandTriangle t = BandTriangle::make(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0));
  CHECK(t.regular);
  CHECK(t.squared_distance(Vec3(0.25, 0.25, 0)) == 0.0);
  CHECK(t.squared_distance(Vec3(0.5, 0.5, 0)) < 1e-30);
  CHECK(t.squared_distance(Vec3(1, 0, 0)) < 1e-30);
  CHECK(t.squared_distance(Vec3(2, 0, 0)) == doctest::Approx(1.0));
  CHECK(t.squared_distance(Vec3(-1, -1, 1)) == doctest::Approx(3.0));
  CHECK(t.squared_distance(Vec3(0.5, -2, 0)) == doctest::Approx(4.0));
  CHECK_FALSE(BandTriangle::make(Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2)).regular);
}

TEST_CASE("band triangle: a row update is the exact minimum wherever it lowers the row, and only lowers it") {
  Rng rng(11);
  const double h = 0.0125;
  const int32_t O = 2048;
  long lowered = 0, kept = 0;
  for (const auto& c : triangle_zoo()) {
    const BandTriangle t = BandTriangle::make(c[0], c[1], c[2]);
    for (int r = 0; r < 20; ++r) {
      const int32_t xi = static_cast<int32_t>(rng.below(40)) - 20 + O, yi = static_cast<int32_t>(rng.below(40)) - 20 + O;
      const int32_t z0 = static_cast<int32_t>(rng.below(40)) - 20 + O;
      const int32_t count = 1 + static_cast<int32_t>(rng.below(12));
      std::vector<double> best(static_cast<size_t>(count)), before;
      for (double& b : best) b = rng.uniform(0, 0.02);  // previous minima of other triangles
      before = best;
      const double px = (xi - O) * h, py = (yi - O) * h;
      // No row bound, a loose one, and the tightest allowed (the row's largest best value: clips the row to the
      // triangle's plane slab).
      const double tight = *std::max_element(before.begin(), before.end());
      t.row_min(px, py, z0, count, O, h, best.data(),
                r % 3 == 0 ? std::numeric_limits<double>::infinity() : r % 3 == 1 ? 0.02 : tight);
      for (int32_t k = 0; k < count; ++k) {
        const Vec3 p(px, py, (z0 + k - O) * h);
        const double ref = (closest_point_on_triangle(p, c[0], c[1], c[2]) - p).squaredNorm();
        const double want = std::min(before[static_cast<size_t>(k)], ref);
        CHECK(std::abs(best[static_cast<size_t>(k)] - want) <= 1e-14);
        (ref < before[static_cast<size_t>(k)] ? lowered : kept)++;
      }
    }
  }
  CHECK(lowered > 100);
  CHECK(kept > 100);
}
