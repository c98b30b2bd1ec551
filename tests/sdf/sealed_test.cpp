#include "core/error.h"
#include "core/mesh_io.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/orientation.h"
#include "sdf/samples.h"
#include "sdf/sealed.h"
#include "sdf/sparse_sdf.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

constexpr double kVoxel = 0.02;  // coarse grids keep the tests fast; sealing is defined in voxels
constexpr double kHalf = 0.5, kWall = 0.06;
const Vec3 kCavityLo = Vec3::Constant(-kHalf + kWall), kCavityHi = Vec3::Constant(kHalf - kWall);

/// test::slab_cabinet, validated and oriented as prep does.
Mesh cabinet(double gap) { return orient_consistently(validate_mesh(test::slab_cabinet(gap, kWall), "cabinet")); }

SparseSdf grid(const Mesh& m, bool seal, SparseSdfStats* stats = nullptr) {
  SparseSdfSettings s;
  s.voxel_size = kVoxel;
  s.seal = seal;
  return SparseSdf::from_mesh(m, s, stats);
}

/// Calls f(p, i, j, k) for every lattice voxel in [-r, r]^3.
template <class F>
void for_lattice(double r, F&& f) {
  const int n = static_cast<int>(std::lround(r / kVoxel));
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) f(Vec3(i, j, k) * kVoxel, i, j, k);
}

}  // namespace

TEST_CASE("sealed cavities: the exterior flood stops at walls, sealed voxels are inside") {
  // 7^3 voxels at h = 1: a shell of walls where a coordinate is 1 or 5 around 3^3 open voxels, one more wall at the
  // centre. Far from the mesh, so that no segment query sees a surface.
  const Mesh far = make_box(Vec3::Constant(100), Vec3::Constant(101));
  const MeshDistance exact(far);
  auto mask = [](bool hole) {
    std::vector<uint8_t> wall(343, 0);
    for (int x = 0; x < 7; ++x)
      for (int y = 0; y < 7; ++y)
        for (int z = 0; z < 7; ++z) {
          const bool inner = x >= 1 && x <= 5 && y >= 1 && y <= 5 && z >= 1 && z <= 5;
          const bool shell = inner && (x == 1 || x == 5 || y == 1 || y == 5 || z == 1 || z == 5);
          wall[static_cast<size_t>((x * 7 + y) * 7 + z)] = shell || (x == 3 && y == 3 && z == 3);
        }
    if (hole) wall[static_cast<size_t>((1 * 7 + 3) * 7 + 3)] = 0;  // (1, 3, 3) opened
    return wall;
  };
  const SealedCavities closed(Eigen::Vector3i::Zero(), Eigen::Vector3i::Constant(7), 0, 1.0, mask(false));
  CHECK(closed.sealed_voxels() == 26);
  CHECK(closed.wall_voxels() == 125 - 27 + 1);
  CHECK(closed.contains(Vec3(2, 2, 2), exact));
  CHECK(closed.contains(Vec3(4.3, 2.2, 3.4), exact));   // nearest voxel (4, 2, 3)
  CHECK(closed.contains(Vec3(3, 3, 3), exact));         // a wall voxel whose open neighbours are all sealed
  CHECK_FALSE(closed.contains(Vec3(5, 3, 3), exact));   // a wall voxel that sees the exterior
  CHECK_FALSE(closed.contains(Vec3(0, 0, 0), exact));
  CHECK_FALSE(closed.contains(Vec3(6.2, 3, 3), exact));
  CHECK_FALSE(closed.contains(Vec3(-40, 3, 3), exact));  // beyond the box
  const SealedCavities open(Eigen::Vector3i::Zero(), Eigen::Vector3i::Constant(7), 0, 1.0, mask(true));
  CHECK(open.sealed_voxels() == 0);
  CHECK_FALSE(open.contains(Vec3(2, 2, 2), exact));
  CHECK_FALSE(open.contains(Vec3(3, 3, 3), exact));
  // A surface between a wall voxel and the exterior hides it. With offset 10, index (i, j, k) sits at (i - 10, j - 10,
  // k - 10); a plate at x = -9.5 separates the voxels x = 0 (exterior) from the wall voxels x = 1.
  const Mesh plate = make_box(Vec3(-9.55, -20, -20), Vec3(-9.45, 20, 20));
  const MeshDistance plate_distance(plate);
  const SealedCavities shifted(Eigen::Vector3i::Zero(), Eigen::Vector3i::Constant(7), 10, 1.0, mask(false));
  CHECK_FALSE(shifted.contains(Vec3(-9, -7, -7), exact));  // voxel (1, 3, 3) sees (0, *, *)
  CHECK(shifted.contains(Vec3(-9, -7, -7), plate_distance));  // ... unless the plate hides it: (2, *, *) is sealed
  CHECK(shifted.contains(Vec3(-8, -7, -7), plate_distance));  // voxel (2, 3, 3)
  CHECK_THROWS_AS(SealedCavities(Eigen::Vector3i::Zero(), Eigen::Vector3i::Constant(7), 0, 1.0,
                                 std::vector<uint8_t>(300, 0)),
                  InvalidInput);
}

TEST_CASE("sealed cavities: a hollow behind a gap under a voxel is inside, behind a wide gap outside") {
  for (double gap : {0.01, 0.1}) {
    CAPTURE(gap);
    const Mesh m = cabinet(gap);
    SparseSdfStats st;
    const SparseSdf sealed = grid(m, true, &st), plain = grid(m, false);
    REQUIRE(sealed.sealed() != nullptr);
    CHECK(plain.sealed() == nullptr);
    const bool closes = gap < 1.7 * kVoxel;
    CHECK(plain.value(Vec3::Zero()) > 0);
    CHECK((sealed.value(Vec3::Zero()) < 0) == closes);
    // Only signs change, and only in the hollow (within a voxel of it) or the gap's slit.
    long changed = 0, deep = 0;
    for_lattice(0.62, [&](const Vec3& p, int i, int j, int k) {
      const double a = sealed.voxel(i, j, k), b = plain.voxel(i, j, k);
      CHECK(std::abs(a) == std::abs(b));
      const double to_hollow = box_sdf(p, kCavityLo, kCavityHi);
      const bool slit = std::abs(p.x()) <= gap / 2 + kVoxel && p.z() >= kHalf - kWall - kVoxel;
      if (to_hollow < -1.5 * kVoxel) {
        ++deep;
        CHECK((a < 0) == closes);
        CHECK(b > 0);
      }
      if ((a < 0) != (b < 0)) {
        ++changed;
        CHECK(closes);
        CHECK((to_hollow < kVoxel || slit));
        CHECK(a < 0);
      }
    });
    CHECK(deep > 1000);
    if (closes) CHECK(changed >= deep);
  }
}

TEST_CASE("sealed cavities: a small hollow at the end of a long slit is inside to its walls") {
  // Walls 0.35 thick around a 0.3 hollow: the hollow's band is a small part of the band. The slit, 1.5 voxels wide,
  // is sealed (its mid-plane voxels are walls, 0.75 voxel from both sides), and its voxels, neighbours with
  // distances summing to more than a voxel, join the hollow's band to the exterior's without a surface in between:
  // no component may span both.
  const double t = 0.35;
  const Mesh m = orient_consistently(validate_mesh(test::slab_cabinet(1.5 * kVoxel, t), "thick cabinet"));
  const SparseSdf sealed = grid(m, true);
  const Vec3 lo = Vec3::Constant(-kHalf + t), hi = Vec3::Constant(kHalf - t);
  long hollow = 0, wrong = 0;
  for_lattice(0.2, [&](const Vec3& p, int i, int j, int k) {
    if (box_sdf(p, lo, hi) >= -0.25 * kVoxel) return;
    ++hollow;
    wrong += sealed.voxel(i, j, k) >= 0;
  });
  CHECK(hollow > 2000);
  CHECK(wrong == 0);
}

TEST_CASE("sealed cavities: nothing changes where the surface seals no cavity") {
  for (const auto& c : test::hard_cases()) {
    CAPTURE(c.name);
    const Mesh m = orient_consistently(validate_mesh(c.mesh, c.name));
    const SparseSdf sealed = grid(m, true), plain = grid(m, false);
    long differ = 0;
    for_lattice(0.72, [&](const Vec3&, int i, int j, int k) { differ += sealed.voxel(i, j, k) != plain.voxel(i, j, k); });
    CHECK(differ == 0);
  }
}

TEST_CASE("sealed cavities: samples in a sealed hollow are negative and stay exact") {
  const Mesh m = cabinet(0.01);
  const MeshDistance exact(m);
  SampleSettings ss;
  ss.count = 4000;
  ss.seed = 3;
  for (bool seal : {true, false}) {
    CAPTURE(seal);
    const SparseSdf sdf = grid(m, seal);
    const MatrixXfR S = disn_samples(m, sdf, ss);
    REQUIRE(S.rows() == 4000);
    long hollow = 0, bad_distance = 0, bad_sign = 0;
    for (Eigen::Index r = 0; r < S.rows(); ++r) {
      const Vec3 p = S.row(r).head<3>().cast<double>().transpose();
      const double v = S(r, 3);
      if (std::abs(std::abs(v) - exact(p)) > 1e-4) ++bad_distance;
      if (box_sdf(p, kCavityLo, kCavityHi) < -0.01) {
        ++hollow;
        if ((v < 0) != seal) ++bad_sign;
      } else if (box_sdf(p, Vec3::Constant(-kHalf), Vec3::Constant(kHalf)) > 0.01 && v < 0) {
        ++bad_sign;
      }
    }
    CHECK(hollow > 500);
    CHECK(bad_distance == 0);
    CHECK(bad_sign == 0);
  }
}

TEST_CASE("sealed cavities: sealing needs a sign") {
  SparseSdfSettings s;
  s.voxel_size = kVoxel;
  s.seal = true;
  s.sign = SignMethod::kNone;
  CHECK_THROWS_AS(SparseSdf::from_mesh(cabinet(0.01), s), InvalidInput);
}

TEST_CASE("sealed cavities: contains() agrees with a slow reference on random walls behind plates") {
  // 9^3 voxels at h = 1, offset 4 (index i at i - 4), 70% walls at random (open voxels below the percolation
  // threshold, so most open voxels are sealed pockets; the exterior reaches in from the faces).
  // Two plates hide some neighbours from some points. Reference: an independent breadth-first flood and
  // the rule of sealed.h, every neighbour tried.
  constexpr int n = 9;
  Rng rng(17);
  std::vector<uint8_t> wall(n * n * n);
  for (uint8_t& w : wall) w = rng.uniform() < 0.7;
  const Mesh plates =
      concatenate(make_box(Vec3(-1.2, -5, -5), Vec3(-1.1, 5, 5)), make_box(Vec3(-5, 0.6, -5), Vec3(5, 0.7, 5)));
  const MeshDistance exact(plates);
  const SealedCavities sealed(Eigen::Vector3i::Zero(), Eigen::Vector3i::Constant(n), 4, 1.0, wall);

  // 0 sealed, 1 wall, 2 exterior, as a breadth-first flood from the box's faces finds them.
  auto at = [&](int x, int y, int z) { return static_cast<size_t>((x * n + y) * n + z); };
  auto inside_box = [&](int x, int y, int z) { return x >= 0 && y >= 0 && z >= 0 && x < n && y < n && z < n; };
  std::vector<uint8_t> state(wall.size());
  std::vector<std::array<int, 3>> queue;
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y)
      for (int z = 0; z < n; ++z) {
        state[at(x, y, z)] = wall[at(x, y, z)];
        const bool face = x == 0 || y == 0 || z == 0 || x == n - 1 || y == n - 1 || z == n - 1;
        if (face && !wall[at(x, y, z)]) {
          state[at(x, y, z)] = 2;
          queue.push_back({x, y, z});
        }
      }
  for (size_t q = 0; q < queue.size(); ++q) {
    const auto [x, y, z] = queue[q];
    const int step[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const auto& d : step) {
      const int a = x + d[0], b = y + d[1], c = z + d[2];
      if (inside_box(a, b, c) && state[at(a, b, c)] == 0) {
        state[at(a, b, c)] = 2;
        queue.push_back({a, b, c});
      }
    }
  }
  auto voxel_of = [](const Vec3& p) {  // the nearest voxel's box indices
    return std::array<int, 3>{static_cast<int>(std::lround(p.x())) + 4, static_cast<int>(std::lround(p.y())) + 4,
                              static_cast<int>(std::lround(p.z())) + 4};
  };
  auto reference = [&](const Vec3& p) {
    const auto [x, y, z] = voxel_of(p);
    if (!inside_box(x, y, z)) return false;
    if (state[at(x, y, z)] != 1) return state[at(x, y, z)] == 0;
    bool seen_exterior = false, seen_sealed = false;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const int a = x + dx, b = y + dy, c = z + dz;
          const int s = inside_box(a, b, c) ? state[at(a, b, c)] : 2;
          if (s == 1 || exact.segment_may_cross(p, Vec3(a - 4, b - 4, c - 4))) continue;
          (s == 2 ? seen_exterior : seen_sealed) = true;
        }
    return seen_sealed && !seen_exterior;
  };
  long mismatches = 0, wall_in = 0, wall_out_beside_cavity = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 p(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    const bool want = reference(p);
    mismatches += sealed.contains(p, exact) != want;
    const auto [x, y, z] = voxel_of(p);
    if (!inside_box(x, y, z) || state[at(x, y, z)] != 1) continue;
    bool cavity_beside = false;
    for (int d = 0; d < 27; ++d) {
      const int a = x + d / 9 - 1, b = y + d / 3 % 3 - 1, c = z + d % 3 - 1;
      cavity_beside |= inside_box(a, b, c) && state[at(a, b, c)] == 0;
    }
    wall_in += want;
    wall_out_beside_cavity += !want && cavity_beside;
  }
  CHECK(mismatches == 0);
  CHECK(wall_in > 100);                 // both outcomes of the neighbour rule occur
  CHECK(wall_out_beside_cavity > 100);
}
