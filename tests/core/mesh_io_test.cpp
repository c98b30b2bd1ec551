#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"

#include <doctest/doctest.h>

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
  const fs::path dir = fs::temp_directory_path() / "sdfkit_core_meshio";
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
