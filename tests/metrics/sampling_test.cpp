#include "metrics/sampling.h"

#include "core/error.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <set>

using namespace sdfkit;

TEST_CASE("surface samples lie on the surface, carry the face normal, and are deterministic") {
  const Mesh sphere = make_icosphere(Vec3(0.2, -0.1, 0.3), 0.7, 3);
  const SurfaceSamples s = sample_surface(sphere, 5000, 42);
  REQUIRE(s.points.rows() == 5000);
  for (Eigen::Index i = 0; i < s.points.rows(); ++i) {
    const int f = s.faces(i);
    const Vec3 a = sphere.V.row(sphere.F(f, 0)), b = sphere.V.row(sphere.F(f, 1)), c = sphere.V.row(sphere.F(f, 2));
    const Vec3 n = (b - a).cross(c - a).normalized();
    const Vec3 p = s.points.row(i);
    CHECK(std::abs(n.dot(p - a)) < 1e-12);  // in the face's plane
    // inside the triangle: barycentric coordinates all >= 0
    const double area = (b - a).cross(c - a).dot(n);
    CHECK((b - p).cross(c - p).dot(n) / area > -1e-9);
    CHECK((c - p).cross(a - p).dot(n) / area > -1e-9);
    CHECK((a - p).cross(b - p).dot(n) / area > -1e-9);
    CHECK((Vec3(s.normals.row(i)) - n).norm() < 1e-12);
  }
  const SurfaceSamples again = sample_surface(sphere, 5000, 42);
  CHECK(again.points == s.points);
  const SurfaceSamples other = sample_surface(sphere, 5000, 43);
  CHECK(other.points != s.points);
}

TEST_CASE("surface sampling is area-weighted") {
  // Two unit-height boxes side by side: one with 4x the surface area of the other... use two faces instead:
  // a big and a small triangle; the share of samples on each must match the area ratio.
  Mesh m;
  m.V.resize(6, 3);
  m.V << 0, 0, 0, 3, 0, 0, 0, 3, 0,  // area 4.5
      10, 0, 0, 11, 0, 0, 10, 1, 0;  // area 0.5
  m.F.resize(3, 3);
  m.F << 0, 1, 2, 3, 4, 5, 3, 3, 4;  // the last face is degenerate: never chosen
  const long n = 200000;
  const SurfaceSamples s = sample_surface(m, n, 7);
  long big = 0, degenerate = 0;
  for (long i = 0; i < n; ++i) {
    big += s.faces(i) == 0;
    degenerate += s.faces(i) == 2;
  }
  CHECK(degenerate == 0);
  const double share = static_cast<double>(big) / n;
  // binomial standard deviation sqrt(0.9 * 0.1 / n) = 6.7e-4: 5 sigma
  CHECK(std::abs(share - 0.9) < 3.4e-3);
  // Within the big triangle, the mean of uniform samples is the centroid (1, 1, 0).
  Vec3 mean = Vec3::Zero();
  for (long i = 0; i < n; ++i)
    if (s.faces(i) == 0) mean += s.points.row(i).transpose();
  mean /= static_cast<double>(big);
  CHECK((mean - Vec3(1, 1, 0)).norm() < 0.01);
}

TEST_CASE("vertex sampling with replacement draws every vertex about equally often") {
  Points v(4, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  const Points s = sample_with_replacement(v, 40000, 3);
  long counts[4] = {0, 0, 0, 0};
  for (Eigen::Index i = 0; i < s.rows(); ++i) {
    int k = -1;
    for (int j = 0; j < 4; ++j)
      if (s.row(i) == v.row(j)) k = j;
    REQUIRE(k >= 0);
    ++counts[k];
  }
  for (long c : counts) CHECK(std::abs(c - 10000) < 500);  // sd = 87
  CHECK(sample_with_replacement(v, 40000, 3) == s);
}

TEST_CASE("sampling refuses empty, NaN and zero-area input with a message naming the input") {
  Mesh empty;
  CHECK_THROWS_WITH_AS(sample_surface(empty, 10, 1, "pred.obj"), doctest::Contains("pred.obj"), InvalidInput);
  Mesh nan = make_box(Vec3::Zero(), Vec3::Ones());
  nan.V(0, 0) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH_AS(sample_surface(nan, 10, 1, "gt.obj"), doctest::Contains("non-finite"), InvalidInput);
  Mesh flat;
  flat.V = Points::Zero(3, 3);
  flat.F.resize(1, 3);
  flat.F << 0, 1, 2;
  CHECK_THROWS_WITH_AS(sample_surface(flat, 10, 1), doctest::Contains("zero area"), InvalidInput);
  CHECK_THROWS_AS(sample_with_replacement(Points(0, 3), 10, 1), InvalidInput);
}

TEST_CASE("sampling without replacement draws distinct rows of the set, in order, seeded") {
  Points pts(1000, 3);
  for (int i = 0; i < 1000; ++i) pts.row(i) << i, 0, 0;
  const Points a = sample_without_replacement(pts, 600, 5), b = sample_without_replacement(pts, 600, 5);
  CHECK(a == b);
  CHECK(a != sample_without_replacement(pts, 600, 6));
  for (int i = 0; i < 600; ++i) {
    CHECK(a(i, 0) == std::floor(a(i, 0)));  // a row of the set
    if (i > 0) CHECK(a(i, 0) > a(i - 1, 0));  // distinct, and in the set's order
  }
  CHECK(sample_without_replacement(pts, 1000, 1) == pts);  // all of them: the set itself
  CHECK_THROWS_AS(sample_without_replacement(pts, 1001, 1), InvalidInput);
  CHECK_THROWS_AS(sample_without_replacement(pts, 0, 1), InvalidInput);
}

TEST_CASE("point clouds become n points: as given, subsampled without replacement, or padded keeping every point") {
  Points pts(100, 3);
  for (int i = 0; i < 100; ++i) pts.row(i) << i, 2 * i, 0;
  CloudSampling how = CloudSampling::kPadded;
  CHECK(sample_cloud(pts, 100, 3, &how) == pts);
  CHECK(how == CloudSampling::kAsGiven);
  const Points sub = sample_cloud(pts, 40, 3, &how);
  CHECK(how == CloudSampling::kSubsampled);
  CHECK(to_string(how) == "subsampled");
  std::set<double> xs;
  for (int i = 0; i < 40; ++i) xs.insert(sub(i, 0));
  CHECK(xs.size() == 40);  // no point twice
  const Points pad = sample_cloud(pts, 250, 3, &how);
  CHECK(how == CloudSampling::kPadded);
  REQUIRE(pad.rows() == 250);
  CHECK(pad.topRows(100) == pts);  // every point once, then repeats of points of the set
  for (int i = 100; i < 250; ++i) CHECK(pad(i, 1) == 2 * pad(i, 0));
}
