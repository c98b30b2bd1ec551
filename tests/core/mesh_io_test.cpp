#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
Mesh tetra() {
  Mesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}
}  // namespace

TEST_CASE("mesh writers and the reader round-trip every format") {
  const fs::path dir = test::scratch_dir("core_meshio");
  fs::create_directories(dir);
  Mesh m = tetra();
  m.colors = Colors::Constant(4, 3, 0.5f);
  for (const char* ext : {"obj", "ply", "off"}) {
    const std::string path = (dir / (std::string("t.") + ext)).string();
    write_mesh(path, m);
    const Mesh back = read_mesh(path);
    CHECK(back.num_vertices() == 4);
    CHECK(back.num_faces() == 4);
    // Same triangles as point triples (the reader may reorder vertices).
    double area_in = 0, area_out = 0;
    for (int f = 0; f < 4; ++f) {
      area_in += (m.V.row(m.F(f, 1)) - m.V.row(m.F(f, 0))).cross(m.V.row(m.F(f, 2)) - m.V.row(m.F(f, 0))).norm();
      area_out += (back.V.row(back.F(f, 1)) - back.V.row(back.F(f, 0)))
                      .cross(back.V.row(back.F(f, 2)) - back.V.row(back.F(f, 0)))
                      .norm();
    }
    CHECK(area_out == doctest::Approx(area_in).epsilon(1e-6));
  }
  fs::remove_all(dir);
}

TEST_CASE("validation: errors for unusable meshes, counts for handled problems") {
  Mesh m = tetra();
  MeshReport r;
  CHECK(validate_mesh(m, "t", &r).num_faces() == 4);
  CHECK(r.degenerate_faces == 0);

  Mesh dup = m;
  dup.F.conservativeResize(6, 3);
  dup.F.row(4) << 1, 0, 2;  // same vertex set as face 0
  dup.F.row(5) << 1, 1, 2;  // repeated index
  const Mesh cleaned = validate_mesh(dup, "t", &r);
  CHECK(cleaned.num_faces() == 4);
  CHECK(r.duplicate_faces == 1);
  CHECK(r.degenerate_faces == 1);

  Mesh bad = m;
  bad.F(0, 0) = 9;
  CHECK_THROWS_AS(validate_mesh(bad, "t", nullptr), InvalidInput);
  Mesh nan = m;
  nan.V(1, 1) = std::nan("");
  CHECK_THROWS_AS(validate_mesh(nan, "t", nullptr), InvalidInput);
  CHECK_THROWS_AS(validate_mesh(Mesh{}, "t", nullptr), InvalidInput);
  CHECK_THROWS_AS(write_mesh("/tmp/sdfkit_nan.obj", nan), InvalidInput);
  CHECK_FALSE(fs::exists("/tmp/sdfkit_nan.obj"));
}

TEST_CASE("reader errors name the file") {
  CHECK_THROWS_WITH_AS(read_mesh("/nonexistent/x.obj"), doctest::Contains("/nonexistent/x.obj"), IoError);
  CHECK_THROWS_WITH_AS(read_mesh("/tmp/x.abc"), doctest::Contains("unknown mesh extension"), IoError);
}

namespace {
std::string ply_binary(const std::vector<float>& v, const std::vector<std::array<int32_t, 3>>& f, size_t cut = 0) {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(v.size() / 3) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(f.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  s.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
  for (const auto& t : f) {
    s.push_back(3);
    s.append(reinterpret_cast<const char*>(t.data()), 12);
  }
  if (cut > 0) s.resize(s.size() - cut);
  return s;
}
}  // namespace

TEST_CASE("reader: broken files give clear errors naming the file (assimp alone is lax or crashes)") {
  const fs::path dir = test::scratch_dir("core_badmeshes");
  fs::create_directories(dir);
  const std::vector<float> tet = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::array<int32_t, 3>> faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  std::vector<float> nan_tet = tet;
  nan_tet[7] = std::nanf("");
  std::vector<std::array<int32_t, 3>> bad_faces = faces;
  bad_faces[3][2] = 99;
  struct Bad {
    std::string name, content, message;
    bool io;  // IoError (malformed file) or InvalidInput (unusable content)
  };
  const std::vector<Bad> cases = {
      {"empty.obj", "", "empty file", true},
      {"blank.ply", "\n  \n", "empty file", true},
      {"empty.stl", "", "empty file", true},
      {"nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "non-finite", false},
      {"inf.off", "OFF\n3 1 0\n0 0 0\n1 0 0\ninf 1 0\n3 0 1 2\n", "non-finite", false},
      {"index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "out of range", false},
      {"negative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9\n", "out of range", false},
      {"index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "out of range", false},
      {"short.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n", "truncated", true},
      {"nan_bin.ply", ply_binary(nan_tet, faces), "non-finite", false},
      {"index_bin.ply", ply_binary(tet, bad_faces), "out of range", false},
      {"truncated_faces.ply", ply_binary(tet, faces, 30), "truncated binary PLY", true},
      {"truncated_vertices.ply", ply_binary(tet, faces, 60), "truncated binary PLY", true},
      {"cut.stl", std::string(80, ' ') + std::string("\x05\0\0\0", 4) + std::string(120, '\0'), "truncated", true},
  };
  for (const auto& c : cases) {
    CAPTURE(c.name);
    const std::string path = (dir / c.name).string();
    write_file_atomic(path, [&](std::ostream& o) { o << c.content; });
    std::string message;
    bool io = false, invalid = false;
    try {
      read_mesh(path);
    } catch (const IoError& e) {
      message = e.what();
      io = true;
    } catch (const InvalidInput& e) {
      message = e.what();
      invalid = true;
    }
    CHECK(message.rfind(path + ": ", 0) == 0);
    CHECK(message.find(c.message) != std::string::npos);
    CHECK(io == c.io);
    CHECK(invalid == !c.io);
  }
  // The well-formed binary PLY next to them reads fine.
  const std::string good = (dir / "good.ply").string();
  write_file_atomic(good, [&](std::ostream& o) { o << ply_binary(tet, faces); });
  CHECK(read_mesh(good).num_faces() == 4);
  fs::remove_all(dir);
}
