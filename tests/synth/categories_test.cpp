#include "synth/categories.h"

#include "core/error.h"
#include "core/primitives.h"
#include "sdf/normalize.h"
#include "synth_test_util.h"

#include <doctest/doctest.h>

#include <map>
#include <set>

using namespace sdfkit;

namespace {

int count_parts(const SynthShape& s, const std::string& name) {
  int n = 0;
  for (const auto& p : s.parts) n += p.name == name;
  return n;
}

constexpr int kSeeds = 12;

}  // namespace

TEST_CASE("the 13 categories of DISN's Table 1 with ShapeNet synset ids") {
  const auto& c = categories();
  REQUIRE(c.size() == 13);
  CHECK(c[0].synset == "02691156");
  CHECK(c[0].name == "plane");
  CHECK(c[4].name == "chair");
  CHECK(c[4].synset == "03001627");
  CHECK(c[12].synset == "04530566");
  std::set<std::string> ids;
  for (const auto& x : c) ids.insert(x.synset);
  CHECK(ids.size() == 13);
  CHECK(category_index("table") == 10);
  CHECK(category_index("04379243") == 10);
  CHECK_THROWS_AS(category_index("giraffe"), sdfkit::InvalidInput);
}

TEST_CASE("every category generates closed, outward-facing, coloured parts at many seeds") {
  for (size_t c = 0; c < categories().size(); ++c) {
    CAPTURE(categories()[c].name);
    for (uint64_t seed = 0; seed < kSeeds; ++seed) {
      CAPTURE(seed);
      const SynthShape s = generate_shape(c, seed * 7919 + 1);
      REQUIRE(s.mesh.has_colors());
      REQUIRE(s.mesh.V.allFinite());
      CHECK(s.parts.size() >= 3);
      // Modest triangle counts keep the whole pipeline fast.
      CHECK(s.mesh.F.rows() < 8000);
      for (size_t i = 0; i < s.parts.size(); ++i) {
        const Mesh part = part_mesh(s, i);
        CAPTURE(s.parts[i].name);
        CHECK(test::closed_and_oriented(part));
        CHECK(signed_volume(part) > 0);
        // One colour per part.
        CHECK((part.colors.rowwise() - part.colors.row(0)).cwiseAbs().maxCoeff() == 0.0f);
      }
      // In the unit-sphere frame every vertex lies in the unit sphere and the shape is not degenerate.
      const Normalization n = unit_sphere_normalization(s.mesh);
      const Mesh u = apply_normalization(s.mesh, n);
      double rmax = 0;
      for (Eigen::Index v = 0; v < u.V.rows(); ++v) rmax = std::max(rmax, u.V.row(v).norm());
      CHECK(rmax <= 1.0 + 1e-9);
      CHECK(rmax >= 1.0 - 1e-9);
      const Vec3 ext = u.V.colwise().maxCoeff() - u.V.colwise().minCoeff();
      CHECK(ext.minCoeff() > 0.05);
    }
  }
}

TEST_CASE("each category has its defining parts") {
  for (uint64_t seed = 0; seed < kSeeds; ++seed) {
    CAPTURE(seed);
    auto gen = [&](const char* name) { return generate_shape(category_index(name), seed); };
    const auto plane = gen("plane");
    CHECK(count_parts(plane, "fuselage") == 1);
    CHECK(count_parts(plane, "wing") == 2);
    CHECK(count_parts(plane, "stabilizer") == 2);
    CHECK(count_parts(plane, "fin") >= 1);
    const auto bench = gen("bench");
    CHECK(count_parts(bench, "seat_slat") + count_parts(bench, "seat") >= 1);
    const auto cabinet = gen("cabinet");
    CHECK(count_parts(cabinet, "side") == 2);
    CHECK(count_parts(cabinet, "back") == 1);
    const auto car = gen("car");
    CHECK(count_parts(car, "tyre") == 4);
    CHECK(count_parts(car, "glass") == 1);
    CHECK(count_parts(car, "a_pillar") == 2);
    const auto chair = gen("chair");
    CHECK(count_parts(chair, "seat") == 1);
    CHECK(count_parts(chair, "leg") + count_parts(chair, "column") + count_parts(chair, "sled_frame") >= 1);
    const auto display = gen("display");
    CHECK(count_parts(display, "screen") == 1);
    CHECK(count_parts(display, "bezel") == 4);
    const auto lamp = gen("lamp");
    CHECK(count_parts(lamp, "shade") >= 1);
    const auto speaker = gen("speaker");
    CHECK(count_parts(speaker, "cabinet") + count_parts(speaker, "body") == 1);
    const auto rifle = gen("rifle");
    CHECK(count_parts(rifle, "barrel") == 1);
    CHECK(count_parts(rifle, "trigger_guard") == 1);
    CHECK(count_parts(rifle, "stock") + count_parts(rifle, "stock_bar") >= 1);
    const auto sofa = gen("sofa");
    CHECK(count_parts(sofa, "seat_cushion") >= 1);
    CHECK(count_parts(sofa, "back") == 1);
    const auto table = gen("table");
    CHECK(count_parts(table, "top") == 1);
    const auto phone = gen("phone");
    CHECK(count_parts(phone, "body") == 1);
    CHECK(count_parts(phone, "screen") == 1);
    const auto boat = gen("watercraft");
    CHECK(count_parts(boat, "hull") == 1);
  }
}

TEST_CASE("standing furniture rests on the floor y = 0") {
  for (const char* name : {"chair", "table", "bench", "sofa", "cabinet", "speaker", "display"}) {
    CAPTURE(name);
    for (uint64_t seed = 0; seed < kSeeds; ++seed) {
      CAPTURE(seed);
      const SynthShape s = generate_shape(category_index(name), seed);
      CHECK(std::abs(s.mesh.V.col(1).minCoeff()) < 0.01);
    }
  }
}

TEST_CASE("shapes of a category differ visibly across seeds") {
  for (size_t c = 0; c < categories().size(); ++c) {
    CAPTURE(categories()[c].name);
    std::set<std::map<std::string, int>> structures;
    double lo = 1e300, hi = 0;
    for (uint64_t seed = 0; seed < 16; ++seed) {
      const SynthShape s = generate_shape(c, seed);
      std::map<std::string, int> structure;
      for (const auto& p : s.parts) ++structure[p.name];
      structures.insert(structure);
      // Proportions: height over the larger horizontal extent.
      const Vec3 ext = s.mesh.V.colwise().maxCoeff() - s.mesh.V.colwise().minCoeff();
      const double ratio = ext.y() / std::max(ext.x(), ext.z());
      lo = std::min(lo, ratio);
      hi = std::max(hi, ratio);
    }
    CHECK(structures.size() >= 5);  // part counts / part presence vary
    CHECK(hi / lo > 1.3);           // proportions vary
  }
}

TEST_CASE("chair slats are thin: below 2 voxels at 64^3, above 1 voxel at 256^3") {
  // Voxel = 2.4 / res in the unit-sphere frame (DISN's box is 1.2x the unit sphere).
  const double vox64 = 2.4 / 64, vox256 = 2.4 / 256;
  int chairs_with_slats = 0;
  double smallest = 1e300, largest = 0;
  for (uint64_t seed = 0; seed < 60; ++seed) {
    const SynthShape s = generate_shape(category_index("chair"), seed);
    const Normalization n = unit_sphere_normalization(s.mesh);
    double w = 1e300;
    for (size_t i = 0; i < s.parts.size(); ++i)
      if (s.parts[i].name == "back_slat") w = std::min(w, test::min_width(part_mesh(s, i)) / n.radius);
    if (w == 1e300) continue;
    ++chairs_with_slats;
    CAPTURE(seed);
    CHECK(w < 2 * vox64);
    CHECK(w > vox256);
    smallest = std::min(smallest, w);
    largest = std::max(largest, w);
  }
  CHECK(chairs_with_slats >= 20);
  MESSAGE("normalised chair slat widths: " << smallest << " .. " << largest << " (2 voxels at 64^3 = " << 2 * vox64
                                           << ", 1 voxel at 256^3 = " << vox256 << ")");
}

TEST_CASE("same seed -> identical shape, different seeds -> different shapes") {
  for (size_t c = 0; c < categories().size(); ++c) {
    CAPTURE(categories()[c].name);
    const SynthShape a = generate_shape(c, 42), b = generate_shape(c, 42), d = generate_shape(c, 43);
    CHECK(a.mesh.V == b.mesh.V);
    CHECK(a.mesh.F == b.mesh.F);
    CHECK(a.mesh.colors == b.mesh.colors);
    CHECK((a.mesh.V.rows() != d.mesh.V.rows() || a.mesh.V != d.mesh.V));
  }
  CHECK_THROWS_AS(generate_shape(13, 0), sdfkit::InvalidInput);
}
