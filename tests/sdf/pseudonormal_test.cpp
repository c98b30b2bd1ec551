#include "core/error.h"
#include "core/primitives.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/orientation.h"
#include "sdf/pseudonormal.h"
#include "sdf/sparse_sdf.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

using namespace sdfkit;

namespace {
std::vector<std::pair<std::string, Mesh>> closed_meshes() {
  return {{"icosphere", make_icosphere(Vec3(0.05, -0.03, 0.02), 0.6, 3)},
          {"box", make_box(Vec3(-0.6, -0.4, -0.3), Vec3(0.5, 0.45, 0.35))},
          {"torus", make_torus(Vec3::Zero(), 0.55, 0.2, 48, 24)},
          {"uv sphere", make_sphere(Vec3::Zero(), 0.7, 12, 24)}};
}
}  // namespace

TEST_CASE("pseudo-normal sign equals the brute-force winding-number sign on closed meshes, also at edges and corners") {
  for (const auto& named : closed_meshes()) {
    const auto& name = named.first;
    const auto& mesh = named.second;
    CAPTURE(name);
    REQUIRE(pseudo_normal_sign_applies(mesh));
    const PseudoNormals normals(mesh);
    const MeshDistance dist(mesh);
    Rng rng(3);
    long checked = 0, disagree = 0, at_vertex = 0, at_edge = 0;
    for (int i = 0; i < 3000; ++i) {
      // Points near vertices (whose closest feature is then often the vertex or an edge), and random points.
      Vec3 p;
      if (i % 2 == 0) {
        const Vec3 v = mesh.V.row(static_cast<Eigen::Index>(rng.below(static_cast<uint64_t>(mesh.V.rows()))));
        p = v + Vec3(rng.normal(), rng.normal(), rng.normal()) * 0.03;
      } else {
        p = Vec3(rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9));
      }
      const ClosestPoint cp = dist.closest(p);
      if (cp.distance < 1e-9) continue;
      at_vertex += cp.region <= kVertexC;
      at_edge += cp.region >= kEdgeAB && cp.region <= kEdgeCA;
      const bool wn_inside = WindingNumber::brute_force(mesh, p) > 0.5;
      disagree += normals.inside(p, cp) != wn_inside;
      ++checked;
    }
    CHECK(checked > 2900);
    CHECK(disagree == 0);
    CHECK(at_vertex > 50);  // the test really exercises vertex and edge pseudo-normals
    CHECK(at_edge > 100);
    CHECK(pseudo_normal_agrees_with_winding(mesh, dist, normals, 0.01));
    bool tree_built = false;
    const auto fallback = [&]() -> const WindingNumber& {
      tree_built = true;
      static const WindingNumber none(make_box(Vec3::Constant(-1), Vec3::Constant(1)));
      return none;
    };
    CHECK(pseudo_normal_agrees_with_rays(mesh, dist, normals, 0.01, fallback, 1000));
    CHECK_FALSE(tree_built);  // random rays never needed the hierarchy
  }
}

TEST_CASE("pseudo-normals apply only to closed, consistently oriented, one-part meshes") {
  CHECK_FALSE(pseudo_normal_sign_applies(test::open_box()));
  CHECK_THROWS_AS(PseudoNormals{test::open_box()}, InvalidInput);
  const Mesh two = concatenate(make_box(Vec3::Constant(-0.5), Vec3::Constant(0.1)),
                               make_box(Vec3::Constant(-0.1), Vec3::Constant(0.5)));
  CHECK(is_closed_oriented(two));
  CHECK_FALSE(pseudo_normal_sign_applies(two));  // closed, but two parts that interpenetrate
  CHECK_FALSE(pseudo_normal_sign_applies(test::flip_every(make_icosphere(Vec3::Zero(), 0.5, 2), 7)));
  CHECK(pseudo_normal_sign_applies(orient_consistently(test::flip_every(make_icosphere(Vec3::Zero(), 0.5, 2), 7))));
  // resolve_sign_method: Auto picks pseudo-normals only where they apply; explicit methods stay.
  CHECK(resolve_sign_method(make_torus(Vec3::Zero(), 0.55, 0.2, 48, 24), SignMethod::kAuto, 0.02) ==
        SignMethod::kPseudoNormal);
  CHECK(resolve_sign_method(test::open_box(), SignMethod::kAuto, 0.02) == SignMethod::kWindingNumber);
  CHECK(resolve_sign_method(two, SignMethod::kAuto, 0.02) == SignMethod::kWindingNumber);
  CHECK(resolve_sign_method(test::open_box(), SignMethod::kPseudoNormal, 0.02) == SignMethod::kWindingNumber);
  CHECK(resolve_sign_method(make_box(Vec3::Constant(-1), Vec3::Constant(1)), SignMethod::kWindingNumber, 0.02) ==
        SignMethod::kWindingNumber);
}

TEST_CASE("a self-intersecting closed one-part mesh fails the agreement guard and falls back to winding numbers") {
  // A box whose top face is pushed down through the bottom: closed, oriented, one part, but the top sheet
  // crosses the bottom one, so the pseudo-normal sign is wrong in places.
  Mesh m = make_box(Vec3(-0.5, -0.5, -0.1), Vec3(0.5, 0.5, 0.1));
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (m.V(i, 2) > 0 && m.V(i, 0) > 0) m.V(i, 2) = -0.4;  // two top corners below the bottom face
  REQUIRE(pseudo_normal_sign_applies(m));
  const MeshDistance dist(m);
  const PseudoNormals normals(m);
  CHECK_FALSE(pseudo_normal_agrees_with_winding(m, dist, normals, 0.02, 2000));
  // The same guard with ray-crossing winding numbers (what MeshQueries uses for closed meshes).
  bool tree_built = false;
  const WindingNumber wn(m);
  const auto fallback = [&]() -> const WindingNumber& {
    tree_built = true;
    return wn;
  };
  CHECK_FALSE(pseudo_normal_agrees_with_rays(m, dist, normals, 0.02, fallback, 2000));
  CHECK(resolve_sign_method(m, SignMethod::kAuto, 0.02) == SignMethod::kWindingNumber);
}

TEST_CASE("grids signed by pseudo-normals and by winding numbers agree on closed meshes") {
  for (const auto& named : closed_meshes()) {
    const auto& name = named.first;
    const auto& mesh = named.second;
    CAPTURE(name);
    SparseSdfSettings s;
    s.voxel_size = 0.03;
    s.sign = SignMethod::kPseudoNormal;
    SparseSdfStats st_pn, st_wn;
    const SparseSdf a = SparseSdf::from_mesh(mesh, s, &st_pn);
    s.sign = SignMethod::kWindingNumber;
    const SparseSdf b = SparseSdf::from_mesh(mesh, s, &st_wn);
    CHECK(st_pn.sign == SignMethod::kPseudoNormal);
    CHECK(st_wn.sign == SignMethod::kWindingNumber);
    REQUIRE(a.active_voxel_count() == b.active_voxel_count());
    long differ = 0, voxels = 0;
    const auto ga = vdb_grid(a);
    auto acc_b = vdb_grid(b)->getConstAccessor();
    for (auto leaf = ga->tree().cbeginLeaf(); leaf; ++leaf)
      for (auto it = leaf->cbeginValueAll(); it; ++it) {
        ++voxels;
        const float vb = acc_b.getValue(it.getCoord());
        if (*it != vb && std::abs(*it) > 1e-6f) ++differ;
      }
    CHECK(voxels > 1000);
    CHECK(differ == 0);
    CHECK(a.value(Vec3(5, 5, 5)) == b.value(Vec3(5, 5, 5)));
  }
}
