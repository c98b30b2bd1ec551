// Binary glTF output (core/glb.h, write_mesh's .glb): read back through read_mesh (assimp), parsed by hand
// against the spec's container layout, deterministic, and refusing what it must not write.
#include "core/error.h"
#include "core/files.h"
#include "core/glb.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

uint32_t u32_at(const std::string& d, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, d.data() + at, 4);
  return v;
}

/// A box with a different colour at every corner (sRGB values in (0, 1)).
Mesh coloured_box() {
  Mesh m = make_box(Vec3(-0.5, -0.25, -1), Vec3(0.75, 0.5, 0.125));
  m.colors.resize(m.V.rows(), 3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    m.colors.row(i) << 0.1f + 0.1f * static_cast<float>(i), 0.9f - 0.1f * static_cast<float>(i), 0.5f;
  return m;
}

}  // namespace

TEST_CASE("GLB: srgb_to_linear and linear_to_srgb are the IEC 61966-2-1 curves and invert each other") {
  CHECK(srgb_to_linear(0.f) == 0.f);
  CHECK(srgb_to_linear(1.f) == doctest::Approx(1.f));
  CHECK(srgb_to_linear(0.5f) == doctest::Approx(0.214041f).epsilon(1e-5));  // ((0.5 + 0.055) / 1.055)^2.4
  CHECK(srgb_to_linear(0.04f) == doctest::Approx(0.04f / 12.92f));
  for (float c = 0; c <= 1.f; c += 0.05f) CHECK(linear_to_srgb(srgb_to_linear(c)) == doctest::Approx(c).epsilon(1e-5));
}

TEST_CASE("GLB: a coloured box reads back through assimp with its vertices, faces and colours") {
  const fs::path dir = test::scratch_dir("core_glb");
  fs::create_directories(dir);
  const Mesh m = coloured_box();
  const std::string path = (dir / "box.glb").string();
  write_mesh(path, m);
  const Mesh r = read_mesh(path);
  REQUIRE(r.num_vertices() == m.num_vertices());
  REQUIRE(r.num_faces() == m.num_faces());
  REQUIRE(r.has_colors());
  // Vertices by position (the reader may renumber them): each written vertex is found with its colour.
  std::map<std::array<float, 3>, Eigen::Index> at;
  for (Eigen::Index i = 0; i < r.V.rows(); ++i)
    at[{static_cast<float>(r.V(i, 0)), static_cast<float>(r.V(i, 1)), static_cast<float>(r.V(i, 2))}] = i;
  std::vector<Eigen::Index> to_read(static_cast<size_t>(m.V.rows()));
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const auto it = at.find({static_cast<float>(m.V(i, 0)), static_cast<float>(m.V(i, 1)), static_cast<float>(m.V(i, 2))});
    REQUIRE(it != at.end());
    to_read[static_cast<size_t>(i)] = it->second;
    for (int k = 0; k < 3; ++k) CHECK(r.colors(it->second, k) == doctest::Approx(m.colors(i, k)).epsilon(1e-4));
  }
  // The same triangles, in the same orientation (the box's volume keeps its sign).
  std::map<std::array<Eigen::Index, 3>, int> faces;
  for (Eigen::Index f = 0; f < r.F.rows(); ++f) faces[{r.F(f, 0), r.F(f, 1), r.F(f, 2)}] = 1;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    std::array<Eigen::Index, 3> t{to_read[static_cast<size_t>(m.F(f, 0))], to_read[static_cast<size_t>(m.F(f, 1))],
                                  to_read[static_cast<size_t>(m.F(f, 2))]};
    bool found = false;
    for (int rot = 0; rot < 3 && !found; ++rot, std::rotate(t.begin(), t.begin() + 1, t.end())) found = faces.count(t) > 0;
    CHECK(found);
  }
  CHECK(signed_volume(r) == doctest::Approx(signed_volume(m)));
  fs::remove_all(dir);
}

TEST_CASE("GLB: the container, accessors and bounds follow the glTF 2.0 spec, and the same mesh gives the same bytes") {
  const Mesh m = coloured_box();
  const std::string glb = encode_glb(m);
  REQUIRE(glb.size() > 28);
  CHECK(glb.compare(0, 4, "glTF") == 0);
  CHECK(u32_at(glb, 4) == 2);
  CHECK(u32_at(glb, 8) == glb.size());
  const uint32_t json_len = u32_at(glb, 12);
  CHECK(json_len % 4 == 0);
  CHECK(u32_at(glb, 16) == 0x4E4F534Au);
  const Json j = Json::parse(glb.substr(20, json_len));
  const size_t bin_at = 20 + json_len;
  const uint32_t bin_len = u32_at(glb, bin_at);
  CHECK(bin_len % 4 == 0);
  CHECK(u32_at(glb, bin_at + 4) == 0x004E4942u);
  CHECK(bin_at + 8 + bin_len == glb.size());
  CHECK(j["buffers"][0]["byteLength"].get<size_t>() <= bin_len);
  const Json& prim = j["meshes"][0]["primitives"][0];
  const Json& pos = j["accessors"][prim["attributes"]["POSITION"].get<int>()];
  CHECK(pos["count"] == m.num_vertices());
  for (int k = 0; k < 3; ++k) {
    CHECK(pos["min"][k].get<double>() == doctest::Approx(m.V.col(k).minCoeff()));
    CHECK(pos["max"][k].get<double>() == doctest::Approx(m.V.col(k).maxCoeff()));
  }
  CHECK(j["accessors"][prim["indices"].get<int>()]["count"] == 3 * m.num_faces());
  // COLOR_0 holds linear values: read vertex 3's red straight from the BIN chunk.
  const Json& col = j["accessors"][prim["attributes"]["COLOR_0"].get<int>()];
  const Json& view = j["bufferViews"][col["bufferView"].get<int>()];
  float red = 0;
  std::memcpy(&red, glb.data() + bin_at + 8 + view["byteOffset"].get<size_t>() + 3 * 12, 4);
  CHECK(red == doctest::Approx(srgb_to_linear(m.colors(3, 0))));
  // Normals are unit vectors.
  const Json& nview = j["bufferViews"][j["accessors"][prim["attributes"]["NORMAL"].get<int>()]["bufferView"].get<int>()];
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    float n[3];
    std::memcpy(n, glb.data() + bin_at + 8 + nview["byteOffset"].get<size_t>() + 12 * static_cast<size_t>(i), 12);
    CHECK(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) == doctest::Approx(1.0));
  }
  CHECK(encode_glb(m) == glb);
}

TEST_CASE("GLB: a mesh without colours has no COLOR_0 and reads back grey") {
  const fs::path dir = test::scratch_dir("core_glb_grey");
  fs::create_directories(dir);
  const Mesh m = make_icosphere(Vec3(0, 0, 0), 1.0, 2);
  const std::string glb = encode_glb(m);
  const Json j = Json::parse(glb.substr(20, u32_at(glb, 12)));
  CHECK_FALSE(j["meshes"][0]["primitives"][0]["attributes"].contains("COLOR_0"));
  write_mesh((dir / "s.glb").string(), m);
  const Mesh r = read_mesh((dir / "s.glb").string());
  CHECK(r.num_faces() == m.num_faces());
  CHECK(surface_area(r) == doctest::Approx(surface_area(m)).epsilon(1e-5));
  if (r.has_colors()) CHECK(r.colors(0, 0) == doctest::Approx(0.7f));
  fs::remove_all(dir);
}

TEST_CASE("GLB: a NaN coordinate or colour is refused and nothing is written") {
  const fs::path dir = test::scratch_dir("core_glb_nan");
  fs::create_directories(dir);
  Mesh m = coloured_box();
  m.V(2, 1) = std::nan("");
  CHECK_THROWS_AS(write_mesh((dir / "a.glb").string(), m), InvalidInput);
  CHECK_FALSE(fs::exists(dir / "a.glb"));
  m = coloured_box();
  m.colors(1, 2) = std::nanf("");
  CHECK_THROWS_AS(write_mesh((dir / "b.glb").string(), m), InvalidInput);
  CHECK_FALSE(fs::exists(dir / "b.glb"));
  CHECK(fs::is_empty(dir));
  fs::remove_all(dir);
}
