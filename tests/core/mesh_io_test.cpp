#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <tuple>
#include <vector>

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

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const unsigned b0 = static_cast<unsigned char>(bytes[i]);
    const unsigned b1 = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0;
    const unsigned b2 = i + 2 < bytes.size() ? static_cast<unsigned char>(bytes[i + 2]) : 0;
    const unsigned v = (b0 << 16) | (b1 << 8) | b2;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? k[v & 63] : '=';
  }
  return out;
}

/// The tetrahedron as a glTF 2.0 file with an embedded buffer and a material of base colour `rgb`.
std::string tetra_gltf(const float rgb[3]) {
  const Mesh t = tetra();
  std::string buf;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) {
      const float f = static_cast<float>(t.V(i, k));
      buf.append(reinterpret_cast<const char*>(&f), 4);
    }
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 3; ++k) {
      const uint16_t v = static_cast<uint16_t>(t.F(f, k));
      buf.append(reinterpret_cast<const char*>(&v), 2);
    }
  char colour[96];
  std::snprintf(colour, sizeof colour, "[%g, %g, %g, 1]", rgb[0], rgb[1], rgb[2]);
  return std::string(R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
"meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
"materials": [{"pbrMetallicRoughness": {"baseColorFactor": )") + colour + R"(}}],
"buffers": [{"byteLength": 72, "uri": "data:application/octet-stream;base64,)" + base64(buf) + R"("}],
"bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 24}],
"accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]},
              {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]})";
}
}  // namespace

TEST_CASE("GLB: a container whose lengths do not fit the file is refused before assimp allocates them") {
  // Found by scripts/fuzz glb: a 748-byte GLB whose chunk length said 4 GB made assimp allocate 4 GB.
  const fs::path dir = test::scratch_dir("core_glb");
  fs::create_directories(dir);
  const auto glb = [](uint32_t version, int32_t length_delta, uint32_t chunk_length, const std::string& type) {
    const std::string json = R"({"asset":{"version":"2.0"}})";
    std::string b = "glTF";
    const auto put = [&b](uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
    put(version);
    put(static_cast<uint32_t>(12 + 8 + json.size() + length_delta));
    put(chunk_length);
    b += type;
    b += json;
    return b;
  };
  const uint32_t json_size = 27;  // {"asset":{"version":"2.0"}}
  const std::vector<std::pair<std::string, std::string>> cases = {
      {glb(2, 0, 0xFFFF0000u, "JSON"), "binary glTF chunk 0 says 4294901760 bytes, the file has 27 after its header"},
      {glb(2, 5, json_size, "JSON"), "binary glTF header says 52 bytes, the file has 47"},
      {glb(1, 0, json_size, "JSON"), "binary glTF version 1"},
      {glb(2, 0, json_size, std::string("BIN\0", 4)), "first chunk is not JSON"},
      {std::string("glTF\2\0\0\0", 8), "truncated binary glTF file (8 bytes)"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    CAPTURE(i);
    const std::string path = (dir / ("bad" + std::to_string(i) + ".glb")).string();
    write_text_atomic(path, cases[i].first);
    try {
      (void)read_mesh(path);
      FAIL("accepted");
    } catch (const IoError& e) {
      const std::string msg = e.what();
      CHECK(msg.rfind(path + ": ", 0) == 0);
      CHECK_MESSAGE(msg.find(cases[i].second) != std::string::npos, msg);
    }
  }
}

TEST_CASE("glTF: only JSON that names glTF version 2 reaches assimp, in .gltf files and GLB chunks") {
  // Found by scripts/fuzz gltf: a 41-byte .gltf that is not JSON; assimp's glTF importer declined it and another
  // importer, tried on its content, read past its buffer.
  const fs::path dir = test::scratch_dir("core_gltf_json");
  fs::create_directories(dir);
  const std::string fuzzed("objsse?\": {\x9d\"vt\0;\0@\x01\0vertexarray (attrib:", 41);
  const auto glb = [](const std::string& json) {
    std::string b = "glTF";
    const auto put = [&b](uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
    put(2);
    put(static_cast<uint32_t>(12 + 8 + json.size()));
    put(static_cast<uint32_t>(json.size()));
    b += "JSON";
    return b + json;
  };
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"gltf", fuzzed, "not a glTF file (the file is not a JSON object)"},
      {"gltf", "[1, 2]", "not a glTF file (the file is not a JSON object)"},
      {"gltf", R"({"scenes": []})", "not a glTF file (no asset.version)"},
      {"gltf", R"({"asset": {"version": 2}})", "not a glTF file (no asset.version)"},
      {"gltf", R"({"asset": {"version": "1.0"}})", "glTF version '1.0' (only version 2 is read)"},
      {"glb", glb("{\"asset\": "), "not a glTF file (its JSON chunk is not a JSON object)"},
      {"glb", glb(R"({"asset": {"version": "1.0"}})"), "glTF version '1.0' (only version 2 is read)"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& [ext, bytes, expected] = cases[i];
    CAPTURE(i);
    const std::string path = (dir / ("bad" + std::to_string(i) + "." + ext)).string();
    write_text_atomic(path, bytes);
    try {
      (void)read_mesh(path);
      FAIL("accepted");
    } catch (const IoError& e) {
      const std::string msg = e.what();
      CHECK(msg.rfind(path + ": ", 0) == 0);
      CHECK_MESSAGE(msg.find(expected) != std::string::npos, msg);
    }
  }
  fs::remove_all(dir);
}

TEST_CASE("glTF: a tetrahedron reads with its faces and its material's base colour") {
  const fs::path dir = test::scratch_dir("core_gltf");
  fs::create_directories(dir);
  const float rgb[3] = {0.25f, 0.5f, 0.75f};
  const std::string path = (dir / "t.gltf").string();
  write_text_atomic(path, tetra_gltf(rgb));
  const Mesh m = read_mesh(path);
  CHECK(m.num_vertices() == 4);
  CHECK(m.num_faces() == 4);
  REQUIRE(m.has_colors());
  for (int k = 0; k < 3; ++k) CHECK(m.colors(0, k) == doctest::Approx(rgb[k]));
  double volume = 0;  // closed, outward: the tetrahedron's volume 1/6
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    volume += m.V.row(m.F(f, 0)).dot(m.V.row(m.F(f, 1)).cross(m.V.row(m.F(f, 2)))) / 6.0;
  CHECK(std::abs(volume) == doctest::Approx(1.0 / 6.0));
  write_text_atomic((dir / "bad.glb").string(), "not a glb at all");
  CHECK_THROWS_WITH_AS(read_mesh((dir / "bad.glb").string()), doctest::Contains("bad.glb"), IoError);
  fs::remove_all(dir);
}

TEST_CASE("OBJ materials: Kd becomes the vertex colour, an OBJ without materials has none") {
  const fs::path dir = test::scratch_dir("core_objmtl");
  fs::create_directories(dir);
  write_text_atomic((dir / "t.mtl").string(), "newmtl red\nKd 0.9 0.1 0.2\nnewmtl blue\nKd 0.1 0.2 0.8\n");
  write_text_atomic((dir / "t.obj").string(),
                    "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl red\nf 1 3 2\nf 1 2 4\n"
                    "usemtl blue\nf 1 4 3\nf 2 3 4\n");
  const Mesh m = read_mesh((dir / "t.obj").string());
  REQUIRE(m.has_colors());
  CHECK(m.num_faces() == 4);
  int red = 0, blue = 0;
  for (Eigen::Index i = 0; i < m.colors.rows(); ++i) {
    red += std::abs(m.colors(i, 0) - 0.9f) < 1e-6f && std::abs(m.colors(i, 2) - 0.2f) < 1e-6f;
    blue += std::abs(m.colors(i, 0) - 0.1f) < 1e-6f && std::abs(m.colors(i, 2) - 0.8f) < 1e-6f;
  }
  CHECK(red > 0);
  CHECK(blue > 0);
  CHECK(red + blue == m.colors.rows());
  write_text_atomic((dir / "plain.obj").string(), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  CHECK_FALSE(read_mesh((dir / "plain.obj").string()).has_colors());
  fs::remove_all(dir);
}

TEST_CASE("up axes: z-up and x-up meshes turn to +y by proper rotations") {
  const Mesh t = tetra();
  const Mesh z = to_y_up(t, UpAxis::kZ), x = to_y_up(t, UpAxis::kX);
  // The file's up axis (vertex 3 for z, vertex 1 for x) becomes +y.
  CHECK((z.V.row(3) - Eigen::RowVector3d(0, 1, 0)).norm() < 1e-12);
  CHECK((x.V.row(1) - Eigen::RowVector3d(0, 1, 0)).norm() < 1e-12);
  for (const Mesh* m : {&z, &x}) {  // lengths and the signed volume (orientation) are kept
    double volume = 0;
    for (Eigen::Index f = 0; f < m->F.rows(); ++f)
      volume += m->V.row(m->F(f, 0)).dot(m->V.row(m->F(f, 1)).cross(m->V.row(m->F(f, 2))));
    double ref = 0;
    for (Eigen::Index f = 0; f < t.F.rows(); ++f) ref += t.V.row(t.F(f, 0)).dot(t.V.row(t.F(f, 1)).cross(t.V.row(t.F(f, 2))));
    CHECK(volume == doctest::Approx(ref));
  }
  CHECK((to_y_up(t, UpAxis::kY).V - t.V).norm() == 0);
  CHECK(parse_up_axis("+z") == UpAxis::kZ);
  CHECK_THROWS_AS(parse_up_axis("w"), InvalidInput);
}

TEST_CASE("mesh writers and the reader round-trip every format") {
  const fs::path dir = test::scratch_dir("core_meshio");
  fs::create_directories(dir);
  Mesh m = tetra();
  m.colors = Colors::Constant(4, 3, 0.5f);
  for (const char* ext : {"obj", "ply", "off", "stl"}) {
    CAPTURE(ext);
    const std::string path = (dir / (std::string("t.") + ext)).string();
    write_mesh(path, m);
    const Mesh back = read_mesh(path);
    if (std::string(ext) == "stl")  // STL stores each triangle's corners: 4 to 12 vertices after reading
      CHECK((back.num_vertices() >= 4 && back.num_vertices() <= 12));
    else
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
      {"index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
       "line 5: face index out of range: face 2 uses vertex 7 but the file has 3 vertices (OBJ indices count from 1)",
       false},
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

namespace {
/// read_mesh of `content` written to DIR/NAME; the error message ("" when none) and whether it was an IoError.
std::string read_error(const fs::path& dir, const std::string& name, const std::string& content, bool* io = nullptr) {
  const std::string path = (dir / name).string();
  write_text_atomic(path, content);
  try {
    read_mesh(path);
  } catch (const IoError& e) {
    if (io) *io = true;
    return e.what();
  } catch (const InvalidInput& e) {
    if (io) *io = false;
    return e.what();
  }
  return "";
}

/// Signed volume of a closed triangle mesh (1 for the unit cube, outward faces).
double signed_volume(const Mesh& m) {
  double vol = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    vol += m.V.row(m.F(f, 0)).dot(m.V.row(m.F(f, 1)).cross(m.V.row(m.F(f, 2)))) / 6.0;
  return vol;
}

const char* kCubeVertices = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n";
const char* kCubeQuads = "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n";
}  // namespace

TEST_CASE("OFF: sdfkit's reader takes headers, comments, polygons, colours, and skips points and lines") {
  const fs::path dir = test::scratch_dir("core_off");
  const std::vector<std::string> variants = {
      std::string("OFF\n8 6 12\n") + kCubeVertices + kCubeQuads,
      std::string("OFF 8 6 12\n") + kCubeVertices + kCubeQuads,                       // counts on the header line
      std::string("8 6 0\n") + kCubeVertices + kCubeQuads,                            // no header
      std::string("# a cube\nOFF\r\n\n# counts\n8 6 0 # trailing comment\n") + kCubeVertices + "\n" + kCubeQuads,
      std::string("OFF\n8 8 0\n") + kCubeVertices + kCubeQuads + "1 0\n2 0 1\n",     // a point and a line
  };
  for (const std::string& text : variants) {
    CAPTURE(text);
    write_text_atomic((dir / "cube.off").string(), text);
    const Mesh m = read_mesh((dir / "cube.off").string());
    CHECK(m.num_vertices() == 8);
    CHECK(m.num_faces() == 12);  // 6 quads fanned
    CHECK(signed_volume(m) == doctest::Approx(1.0));
    CHECK_FALSE(m.has_colors());
  }
  // COFF: r g b [a] after the position, 0-255 or 0-1.
  const std::string coff = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n";
  write_text_atomic((dir / "tri.off").string(), coff);
  const Mesh c = read_mesh((dir / "tri.off").string());
  REQUIRE(c.has_colors());
  CHECK(c.colors.rowwise().sum().isApproxToConstant(1.f));
  CHECK(c.colors.maxCoeff() == 1.f);
}

TEST_CASE("OFF: hostile counts and broken lines are errors naming the file and the line, never a crash") {
  const fs::path dir = test::scratch_dir("core_off_bad");
  struct Bad {
    std::string content, message;
    bool io;
  };
  const std::string tri = "0 0 0\n1 0 0\n0 1 0\n";
  const std::vector<Bad> cases = {
      // nv + nf overflowed a signed long and passed the old truncation check
      {"OFF\n3 9223372036854775807 0\n" + tri + "3 0 1 2\n", "line 2: truncated OFF file", true},
      {"OFF\n9223372036854775807 9223372036854775807 0\n" + tri, "line 2: malformed OFF counts line", true},
      {"OFF\n2000000000 1 0\n" + tri + "3 0 1 2\n", "line 2: truncated OFF file (2000000000 vertices", true},
      {"OFF\n-3 1 0\n" + tri + "3 0 1 2\n", "line 2: malformed OFF counts line", true},
      {"OFF\nthree 1 0\n" + tri + "3 0 1 2\n", "line 2: malformed OFF counts line", true},
      {"OFF\n# c\n3 1 0\n" + tri + "\n3 0 1 9\n", "line 8: face index out of range: face 1 uses vertex 9 but the file has 3 vertices (OFF indices count from 0)", false},
      {"OFF\n3 1 0\n" + tri + "3 0 1 -1\n", "line 6: face index out of range", false},
      {"OFF\n3 1 0\n" + tri + "3 0 1 99999999999999999999999\n", "line 6: face index out of range", false},
      {"OFF\n3 1 0\n" + tri + "3 0 1\n", "line 6: truncated OFF face line", true},
      {"OFF\n3 1 0\n" + tri + "3000000000000 0 1 2\n", "line 6: truncated OFF face line", true},
      {"OFF\n3 1 0\n" + tri + "3 0 1.5 2\n", "line 6: malformed OFF face line", true},
      {"OFF\n3 1 0\n" + tri + "x 0 1 2\n", "line 6: malformed OFF face line", true},
      {"OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", "line 4: malformed OFF vertex line", true},
      {"OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "line 4: non-finite coordinates (NaN or Inf) of vertex 2", false},
      {"4OFF\n3 1 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n", "line 1: unsupported OFF variant '4OFF'", true},
      {"OFF BINARY\n", "line 1: binary OFF is not supported", true},
      {"PLY\n3 1 0\n" + tri + "3 0 1 2\n", "line 1: not an OFF file", true},
      {"OFF\n", "line 1: truncated OFF file (no vertex/face counts)", true},
      {"# only a comment\n", "empty file", true},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.content);
    bool io = false;
    const std::string path = (dir / "bad.off").string();
    const std::string msg = read_error(dir, "bad.off", c.content, &io);
    CHECK(msg.rfind(path + ": ", 0) == 0);
    CHECK(msg.find(c.message) != std::string::npos);
    CHECK(io == c.io);
  }
}

TEST_CASE("sdfkit info: hostile OFF files exit 1 with one line naming the file and the line") {
  // "1000000000 1 0 OFF" on line 1 with a valid file below: the old pre-check took its counts from line 2 and
  // passed the file on to assimp, which took line 1's counts and zero-filled 12 GB for 10^9 vertices before failing
  // (under the 1 GB address-space cap below: std::bad_alloc). No OFF file reaches assimp any more.
  const fs::path dir = test::scratch_dir("core_off_cli");
  const std::string tri = "0 0 0\n1 0 0\n0 1 0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"1000000000 1 0 OFF\n3 1 0\n" + tri + "3 0 1 2\n", "line 1: not an OFF file"},
      {"OFF\n3 9223372036854775807 0\n" + tri + "3 0 1 2\n", "line 2: truncated OFF file"},
      {"OFF\n3 1 0\n" + tri + "3 0 1 9\n", "line 6: face index out of range"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    CAPTURE(cases[i].first);
    const std::string path = (dir / ("hostile" + std::to_string(i) + ".off")).string();
    write_text_atomic(path, cases[i].first);
    const std::string err = (dir / "stderr.txt").string();
    // AddressSanitizer reserves terabytes of address space for its shadow memory, so the cap applies to plain builds
    // only; under ASan an allocation of 12 GB is refused by the sanitizer's allocator instead.
    const std::string cap = test::kAddressSanitizer ? "" : "ulimit -v 1000000; ";
    const int status = std::system((cap + std::string(SDFKIT_EXE) + " info " + path + " > /dev/null 2> " + err).c_str());
    REQUIRE(WIFEXITED(status));  // no signal (segmentation fault, abort)
    CHECK(WEXITSTATUS(status) == 1);
    const std::string msg = read_file(err);
    CHECK(msg.rfind("sdfkit: error: " + path + ": " + cases[i].second, 0) == 0);
    CHECK(std::count(msg.begin(), msg.end(), '\n') == 1);
  }
}
