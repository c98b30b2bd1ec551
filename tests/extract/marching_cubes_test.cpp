#include "extract/marching_cubes.h"

#include "core/error.h"
#include "core/primitives.h"
#include "core/random.h"
#include "extract/mc_core.h"
#include "mesh_checks.h"

#include <doctest/doctest.h>

#include <cmath>
#include <algorithm>
#include <array>
#include <functional>
#include <vector>

using namespace sdfkit;
using sdfkit::test::bad_edges;
using sdfkit::test::degenerate_faces;
using sdfkit::test::duplicate_vertices;
using sdfkit::test::euler_characteristic;
using sdfkit::test::unreferenced_vertices;

namespace {

DenseGrid sample(const std::function<double(const Vec3&)>& f, const Vec3& lo, double voxel, int n) {
  DenseGrid g(lo, voxel, n, n, n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) g.at(i, j, k) = static_cast<float>(f(g.point(i, j, k)));
  return g;
}

void check_clean_closed(const Mesh& m) {
  CHECK(m.F.rows() > 0);
  CHECK(bad_edges(m) == 0);
  CHECK(degenerate_faces(m) == 0);
  CHECK(duplicate_vertices(m) == 0);
  CHECK(unreferenced_vertices(m) == 0);
}

}  // namespace

TEST_CASE("case table: sizes, and loops that need a centre vertex are the exception") {
  const auto st = detail::table_stats();
  // 256 cases, plus one extra entry per combination of ambiguous-face decisions.
  CHECK(st.entries > 256);
  CHECK(st.entries_with_centre_vertex > 0);               // e.g. the saddle strip below
  CHECK(st.entries_with_centre_vertex < st.entries / 4);  // most loops triangulate on their own vertices
  CHECK(st.max_loop_length <= 12);
  CHECK(st.max_loop_length >= 6);
}

TEST_CASE("saddle strip: a loop with two segments on each of two faces gets a centre vertex, still closed") {
  // Inside corners 0, 3 (bottom face diagonal, separated by the decider) and 4, 7 (top diagonal, joined): one
  // octagonal loop whose every triangulation would put a diagonal into the bottom or top face.
  DenseGrid g(Vec3::Zero(), 1.0, 2, 2, 2);
  g.at(0, 0, 0) = -0.1f, g.at(1, 1, 0) = -0.1f, g.at(1, 0, 0) = 1.0f, g.at(0, 1, 0) = 1.0f;
  g.at(0, 0, 1) = -1.0f, g.at(1, 1, 1) = -1.0f, g.at(1, 0, 1) = 0.1f, g.at(0, 1, 1) = 0.1f;
  MarchingCubesStats st;
  const Mesh open = marching_cubes(g, {0.0, false}, &st);
  CHECK(st.centre_vertices == 1);
  CHECK(open.V.rows() == 9);
  CHECK(open.F.rows() == 8);
  const Mesh closed = marching_cubes(g);
  check_clean_closed(closed);
  CHECK(signed_volume(closed) > 0);
}

TEST_CASE("sphere SDF at 128^3: closed, oriented outward, Euler 2, vertices within 1e-3 of the sphere") {
  const Vec3 c(0.03, -0.02, 0.01);
  const double r = 0.6;
  const DenseGrid g = sample([&](const Vec3& p) { return sphere_sdf(p, c, r); }, Vec3::Constant(-1), 2.0 / 127, 128);
  MarchingCubesStats st;
  const Mesh m = marching_cubes(g, {}, &st);
  check_clean_closed(m);
  CHECK(euler_characteristic(m) == 2);
  double worst = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    worst = std::max(worst, std::abs((m.V.row(v).transpose() - c).norm() - r));
  CHECK(worst < 1e-3);
  // Outward orientation: positive signed volume close to the ball's.
  CHECK(signed_volume(m) == doctest::Approx(4.0 / 3.0 * M_PI * r * r * r).epsilon(3e-3));
  CHECK(st.cells_with_surface > 0);
}

TEST_CASE("torus SDF at 128^3: closed, Euler 0, vertices within 1e-3") {
  const double R = 0.6, r = 0.2;
  const DenseGrid g =
      sample([&](const Vec3& p) { return torus_sdf(p, Vec3::Zero(), R, r); }, Vec3::Constant(-1), 2.0 / 127, 128);
  const Mesh m = marching_cubes(g);
  check_clean_closed(m);
  CHECK(euler_characteristic(m) == 0);
  double worst = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) worst = std::max(worst, std::abs(torus_sdf(m.V.row(v), Vec3::Zero(), R, r)));
  CHECK(worst < 1e-3);
  CHECK(signed_volume(m) == doctest::Approx(2 * M_PI * M_PI * R * r * r).epsilon(5e-3));
}

TEST_CASE("normals point towards increasing values (negated field flips orientation)") {
  DenseGrid g = sample([](const Vec3& p) { return p.norm() - 0.5; }, Vec3::Constant(-1), 0.1, 21);
  const Mesh a = marching_cubes(g, {0.0, false});
  for (auto& v : g.values) v = -v;
  const Mesh b = marching_cubes(g, {0.0, false});
  CHECK(signed_volume(a) > 0.4);
  CHECK(signed_volume(b) == doctest::Approx(-signed_volume(a)).epsilon(0.02));
}

TEST_CASE("random fields: closed and consistently oriented for every ambiguous configuration") {
  // Uniform noise makes ambiguous faces and cells everywhere; padded extraction must still be closed.
  for (uint64_t seed = 0; seed < 40; ++seed) {
    Rng rng(seed);
    const int n = 7;
    DenseGrid g(Vec3::Zero(), 1.0, n, n, n);
    for (auto& v : g.values) v = static_cast<float>(rng.uniform(-1, 1));
    const Mesh m = marching_cubes(g);
    INFO("seed " << seed);
    CHECK(bad_edges(m) == 0);
    CHECK(degenerate_faces(m) == 0);
    CHECK(duplicate_vertices(m) == 0);
    // Without padding the surface is open only at the grid boundary: every boundary edge lies on a box face.
    const Mesh open = marching_cubes(g, {0.0, false});
    CHECK(degenerate_faces(open) == 0);
  }
}

TEST_CASE("values exactly at the iso value: merged vertices, no degenerate triangles, still closed") {
  // Quantised noise: a third of the samples equal the iso value exactly, so vertices snap onto grid points from
  // several edges at once.
  for (uint64_t seed = 0; seed < 60; ++seed) {
    Rng rng(1000 + seed);
    const int n = 6;
    DenseGrid g(Vec3::Zero(), 0.5, n, n, n);
    for (auto& v : g.values) v = static_cast<float>(0.25 * (static_cast<int>(rng.below(3)) - 1)) + 0.25f;
    MarchingCubesStats st;
    const Mesh m = marching_cubes(g, {0.25, true}, &st);
    INFO("seed " << seed);
    CHECK(bad_edges(m) == 0);
    CHECK(degenerate_faces(m) == 0);
    CHECK(duplicate_vertices(m) == 0);
    CHECK(unreferenced_vertices(m) == 0);
  }
}

TEST_CASE("a diagonal plane through grid points: vertices exactly on those points, closed after capping") {
  // f = i + j - 6 (integer, exact): zero on the grid points with i + j = 6, each of which ends two crossed edges.
  const int n = 9;
  DenseGrid g(Vec3(-1, -2, -3), 1.0, n, n, n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) g.at(i, j, k) = static_cast<float>(i + j - 6);
  MarchingCubesStats st;
  const Mesh m = marching_cubes(g, {}, &st);
  check_clean_closed(m);
  CHECK(euler_characteristic(m) == 2);
  CHECK(st.snapped_vertices > 0);
  // The slanted part of the surface lies exactly on the plane x + y = 6 - 3 (grid offset -1, -2).
  long on_plane = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (m.V(v, 0) + m.V(v, 1) == 3.0) ++on_plane;
  CHECK(on_plane == 7 * n);  // grid points (i, 6 - i) for i = 0..6, on every k layer
  // Closed solid: volume of the prism {i + j <= 6} clipped to the grid box = 18 * 8 (area of the triangle with
  // legs 6 in the (i, j) plane, times the 8 cells along k).
  CHECK(signed_volume(m) == doctest::Approx(18.0 * 8));
}

TEST_CASE("iso value hit exactly at a grid point: the vertex is that point") {
  DenseGrid g(Vec3::Zero(), 0.25, 5, 5, 5, 1.0f);
  g.at(2, 2, 2) = -1.0f;  // a single inside point
  g.at(3, 2, 2) = 0.0f;   // its +x neighbour exactly on the iso value (outside by convention)
  const Mesh m = marching_cubes(g, {0.0, false});
  check_clean_closed(m);
  bool found = false;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (m.V.row(v) == Vec3(0.75, 0.5, 0.5).transpose()) found = true;
  CHECK(found);
  CHECK(m.V.rows() == 6);  // octahedron: one vertex per crossed edge
  CHECK(m.F.rows() == 8);
}

TEST_CASE("closing the boundary: a field inside everywhere gives the grid box, closed and outward") {
  DenseGrid g(Vec3(1, 2, 3), 0.5, 4, 5, 6, -1.0f);
  const Mesh m = marching_cubes(g);
  check_clean_closed(m);
  CHECK(euler_characteristic(m) == 2);
  CHECK(signed_volume(m) == doctest::Approx(1.5 * 2.0 * 2.5));
  // Without closing there is nothing to extract.
  CHECK(marching_cubes(g, {0.0, false}).F.rows() == 0);
}

TEST_CASE("bad input is refused with a clear message") {
  DenseGrid g(Vec3::Zero(), 1.0, 3, 3, 3, 1.0f);
  g.values[5] = std::nanf("");
  CHECK_THROWS_AS(marching_cubes(g), InvalidInput);
  DenseGrid small(Vec3::Zero(), 1.0, 1, 3, 3, 1.0f);
  CHECK_THROWS_AS(marching_cubes(small), InvalidInput);
  DenseGrid mismatch(Vec3::Zero(), 1.0, 3, 3, 3, 1.0f);
  mismatch.values.pop_back();
  CHECK_THROWS_AS(marching_cubes(mismatch), InvalidInput);
}

TEST_CASE("builders of consecutive chunks, appended in order, give exactly the serial mesh") {
  // Noise (ambiguous faces, centre vertices) and quantised noise (vertices snapped onto grid points, merged in
  // finish): every chunk size must reproduce the single builder's vertices, faces and counts bit for bit.
  for (uint64_t seed = 0; seed < 12; ++seed) {
    Rng rng(500 + seed);
    const int n = 7;
    std::vector<float> v(size_t(n) * n * n);
    for (auto& x : v)
      x = seed % 2 ? static_cast<float>(rng.uniform(-1, 1)) : static_cast<float>(static_cast<int>(rng.below(3)) - 1);
    auto at = [&](int i, int j, int k) { return double(v[size_t(i) + size_t(n) * (size_t(j) + size_t(n) * k)]); };
    std::vector<std::array<int, 3>> cells;
    for (int k = 0; k + 1 < n; ++k)
      for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) cells.push_back({i, j, k});
    auto add = [&](detail::McBuilder& b, const std::array<int, 3>& c) {
      double s[detail::kCorners];
      for (int corner = 0; corner < detail::kCorners; ++corner)
        s[corner] = at(c[0] + (corner & 1), c[1] + ((corner >> 1) & 1), c[2] + ((corner >> 2) & 1));
      b.add_cell(c[0], c[1], c[2], s);
    };
    detail::McBuilder serial;
    for (const auto& c : cells) add(serial, c);
    MarchingCubesStats serial_stats;
    const Mesh expected = serial.finish(Vec3(0.5, -1, 2), 0.25, &serial_stats);
    REQUIRE(expected.F.rows() > 0);
    for (size_t chunk : {size_t(1), size_t(7), size_t(50), cells.size()}) {
      INFO("seed " << seed << ", chunk " << chunk);
      detail::McBuilder joined;
      for (size_t begin = 0; begin < cells.size(); begin += chunk) {
        detail::McBuilder part;
        for (size_t c = begin; c < std::min(cells.size(), begin + chunk); ++c) add(part, cells[c]);
        joined.append(part);
      }
      MarchingCubesStats stats;
      const Mesh m = joined.finish(Vec3(0.5, -1, 2), 0.25, &stats);
      CHECK(m.V == expected.V);
      CHECK(m.F == expected.F);
      CHECK(stats.snapped_vertices == serial_stats.snapped_vertices);
      CHECK(stats.centre_vertices == serial_stats.centre_vertices);
      CHECK(stats.cells_with_surface == serial_stats.cells_with_surface);
      CHECK(stats.collapsed_triangles == serial_stats.collapsed_triangles);
    }
  }
}
