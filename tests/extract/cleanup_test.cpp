#include "extract/cleanup.h"

#include "core/error.h"
#include "core/primitives.h"
#include "core/mesh_io.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("components: count, sizes by faces and by area, DISN's 30% rule") {
  // Three disjoint closed parts: a big sphere, a box with 12 faces, a medium icosphere.
  const Mesh big = make_icosphere(Vec3::Zero(), 1.0, 3);             // 1280 faces, area ~ 4 pi
  const Mesh box = make_box(Vec3(3, 0, 0), Vec3(3.5, 0.5, 0.5));      // 12 faces, area 1.5
  const Mesh medium = make_icosphere(Vec3(-3, 0, 0), 0.8, 2);         // 320 faces, area ~ 4 pi 0.64
  const Mesh all = concatenate(concatenate(big, box), medium);
  int count = 0;
  const auto comp = face_components(all, &count);
  CHECK(count == 3);
  CHECK(comp.front() == 0);
  CHECK(comp.back() == 2);
  const auto faces = component_sizes(all, comp, count, ComponentMeasure::kFaces);
  CHECK(faces[0] == 1280);
  CHECK(faces[1] == 12);
  CHECK(faces[2] == 320);
  const auto area = component_sizes(all, comp, count, ComponentMeasure::kArea);
  CHECK(area[0] == doctest::Approx(surface_area(big)));
  CHECK(area[1] == doctest::Approx(1.5));
  CHECK(area[2] == doctest::Approx(surface_area(medium)));

  // By faces: 320 / 1280 = 25% < 30% -> only the big sphere survives.
  CleanupReport rep;
  Mesh kept = cleanup(all, {0.3, ComponentMeasure::kFaces}, &rep);
  CHECK(rep.components == 3);
  CHECK(rep.kept_components == 1);
  CHECK(kept.F.rows() == 1280);
  CHECK(kept.V.rows() == big.V.rows());
  CHECK(kept.V == big.V);
  CHECK(kept.F == big.F);
  // By area: the medium sphere has 64% of the big one's area (minus tessellation), the box ~12%.
  kept = cleanup(all, {0.3, ComponentMeasure::kArea}, &rep);
  CHECK(rep.kept_components == 2);
  CHECK(kept.F.rows() == 1280 + 320);
  CHECK(signed_volume(kept) == doctest::Approx(signed_volume(big) + signed_volume(medium)));
  // Fraction 0 keeps all.
  CHECK(cleanup(all, {0.0, ComponentMeasure::kFaces}).F.rows() == all.F.rows());
}

TEST_CASE("components connect through shared vertices only") {
  // Two triangles sharing one vertex are one component; a third touching nothing is another.
  Mesh m;
  m.V.resize(8, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0, 5, 5, 5, 6, 5, 5, 5, 6, 5;
  m.F.resize(3, 3);
  m.F << 0, 1, 2, 0, 3, 4, 5, 6, 2;
  int count = 0;
  auto comp = face_components(m, &count);
  CHECK(count == 1);  // the third triangle shares vertex 2 with the first
  m.F.row(2) << 5, 6, 7;
  comp = face_components(m, &count);
  CHECK(count == 2);
}

TEST_CASE("unreferenced vertices are removed, colours follow, faces are re-indexed") {
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 9, 9, 9, 1, 0, 0, 0, 1, 0, 8, 8, 8;
  m.colors.resize(5, 3);
  m.colors << 0.1f, 0, 0, 0.2f, 0, 0, 0.3f, 0, 0, 0.4f, 0, 0, 0.5f, 0, 0;
  m.F.resize(1, 3);
  m.F << 0, 2, 3;
  std::vector<int32_t> map;
  const Mesh out = remove_unreferenced_vertices(m, &map);
  CHECK(out.V.rows() == 3);
  CHECK(out.F(0, 0) == 0);
  CHECK(out.F(0, 1) == 1);
  CHECK(out.F(0, 2) == 2);
  CHECK(out.colors(1, 0) == 0.3f);
  CHECK(map[1] == -1);
  CHECK(map[4] == -1);
  CHECK(map[3] == 2);
  Mesh bad = m;
  bad.F(0, 1) = 7;
  CHECK_THROWS_AS(cleanup(bad), InvalidInput);
  CHECK_THROWS_AS(cleanup(m, {1.5, ComponentMeasure::kFaces}), InvalidInput);
}
