#include "metrics/grid_nn.h"

#include "core/error.h"
#include "core/primitives.h"
#include "metrics/sampling.h"
#include "test_util.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace sdfkit;
using namespace sdfkit::testing;

namespace {

// Every query's answer must be the brute-force minimum exactly (same double arithmetic) and, among equidistant
// points, the smallest index (brute_nearest keeps the first minimum it meets).
void check_against_brute(const NearestGrid& grid, const Points& set, const Points& queries) {
  Eigen::VectorXi idx;
  Eigen::VectorXd d2;
  grid.nearest(queries, idx, d2);
  REQUIRE(idx.size() == queries.rows());
  long wrong = 0;
  for (Eigen::Index i = 0; i < queries.rows(); ++i) {
    const auto [j, bd2] = brute_nearest(set, queries.row(i));
    wrong += d2(i) != bd2;
    const auto [j1, d1] = grid.nearest(Vec3(queries.row(i).transpose()));
    wrong += d1 != bd2 || j1 != idx(i);
    if (grid.fallback_count() == 0) wrong += idx(i) != j;
  }
  CHECK(wrong == 0);
}

}  // namespace

TEST_CASE("nearest grid: exact against brute force on random and surface clouds") {
  SUBCASE("uniform random clouds, queries also outside the box") {
    const Points set = random_cloud(4000, 1), queries = random_cloud(1500, 2, 1.4);
    const NearestGrid grid(set);
    check_against_brute(grid, set, queries);
  }
  SUBCASE("two nearby torus surfaces (the Chamfer situation): no query needs the fallback") {
    const Points set = sample_surface(make_torus(Vec3::Zero(), 0.65, 0.30), 5000, 3).points;
    const Points queries = sample_surface(make_torus(Vec3(0.02, -0.01, 0.015), 0.62, 0.32), 2000, 4).points;
    const NearestGrid grid(set);
    check_against_brute(grid, set, queries);
    CHECK(grid.fallback_count() == 0);
  }
  SUBCASE("far outliers go to the KD-tree and stay exact") {
    const Points set = random_cloud(3000, 5, 0.5);
    Points queries = random_cloud(300, 6, 50.0);
    queries.row(0) << 1e6, -1e6, 3e5;
    const NearestGrid grid(set);
    Eigen::VectorXi idx;
    Eigen::VectorXd d2;
    grid.nearest(queries, idx, d2);
    CHECK(grid.fallback_count() > 0);
    for (Eigen::Index i = 0; i < queries.rows(); ++i) CHECK(d2(i) == brute_nearest(set, queries.row(i)).second);
  }
}

TEST_CASE("nearest grid: degenerate sets and ties") {
  SUBCASE("one point") {
    Points set(1, 3);
    set << 0.3, -0.2, 5.0;
    const NearestGrid grid(set);
    check_against_brute(grid, set, random_cloud(200, 7, 3.0));
  }
  SUBCASE("all points equal: the smallest index wins") {
    const Points set = Points::Constant(50, 3, 0.25);
    const NearestGrid grid(set);
    CHECK(grid.nearest(Vec3(1, 2, 3)).first == 0);
    check_against_brute(grid, set, random_cloud(100, 8));
  }
  SUBCASE("flat and line-like sets") {
    Points plane = random_cloud(2000, 9);
    plane.col(2).setConstant(0.1);
    check_against_brute(NearestGrid(plane), plane, random_cloud(500, 10, 1.2));
    Points line = random_cloud(500, 11);
    line.col(1).setZero();
    line.col(2).setZero();
    check_against_brute(NearestGrid(line), line, random_cloud(300, 12, 1.2));
  }
  SUBCASE("integer lattice with duplicates, queried at half-integers: many exact ties") {
    Points set(2 * 6 * 6 * 6, 3);
    Eigen::Index k = 0;
    for (int copy = 0; copy < 2; ++copy)
      for (int z = 0; z < 6; ++z)
        for (int y = 0; y < 6; ++y)
          for (int x = 0; x < 6; ++x) set.row(k++) << x, y, z;
    Points queries(7 * 7 * 7, 3);
    k = 0;
    for (int z = 0; z < 7; ++z)
      for (int y = 0; y < 7; ++y)
        for (int x = 0; x < 7; ++x) queries.row(k++) << x - 0.5, y - 0.5, z - 0.5;
    const NearestGrid grid(set);
    check_against_brute(grid, set, queries);
    check_against_brute(grid, set, set);  // every point finds itself (the first copy), at distance 0
  }
}

TEST_CASE("nearest grid: same answers with one or two threads, bad input") {
  const Points set = random_cloud(5000, 13), queries = random_cloud(5000, 14, 1.1);
  const NearestGrid grid(set);
  Eigen::VectorXi i1, i2;
  Eigen::VectorXd d1, d2;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    grid.nearest(queries, i1, d1);
  }
  grid.nearest(queries, i2, d2);
  CHECK(i1 == i2);
  CHECK(d1 == d2);

  CHECK_THROWS_AS(NearestGrid(Points(0, 3)), InvalidInput);
  Points bad = random_cloud(10, 15);
  bad(3, 1) = std::nan("");
  CHECK_THROWS_AS(NearestGrid(bad, "prediction"), InvalidInput);
  CHECK_THROWS_AS(grid.nearest(bad, i1, d1), InvalidInput);
}
