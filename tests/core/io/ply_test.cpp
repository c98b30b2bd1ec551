#include "core/error.h"
#include "core/files.h"
#include "core/io/ply.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A unit cube as 8 vertices and 6 quads (outward), with per-vertex colours.
struct QuadCube {
  std::vector<double> v = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
  std::vector<std::vector<int>> f = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                     {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
  std::vector<int> rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120, 0, 0, 0};
};

/// Header shared by the three encodings: doubles for x/y/z, a normal property and a list property to skip, an
/// extra element before the faces, faces with a flag before their ushort-count / uint-index list.
std::string cube_header(const std::string& format) {
  return "ply\nformat " + format +
         " 1.0\ncomment made by the sdfkit test\nelement vertex 8\nproperty double x\nproperty float nx\n"
         "property double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
         "property list uchar short junk\nelement material 2\nproperty float k\nproperty list int uchar ids\n"
         "element face 6\nproperty uchar flags\nproperty list ushort uint vertex_indices\nend_header\n";
}

template <typename T>
void put(std::string& s, T value, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big)
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  s.append(b, sizeof(T));
}

std::string cube_binary(bool big) {
  const QuadCube c;
  std::string s = cube_header(big ? "binary_big_endian" : "binary_little_endian");
  for (int i = 0; i < 8; ++i) {
    put<double>(s, c.v[3 * i], big);
    put<float>(s, 0.25f, big);
    put<double>(s, c.v[3 * i + 1], big);
    put<double>(s, c.v[3 * i + 2], big);
    for (int k = 0; k < 3; ++k) put<uint8_t>(s, static_cast<uint8_t>(c.rgb[3 * i + k]), big);
    put<uint8_t>(s, 2, big);  // junk list: two shorts
    put<int16_t>(s, -7, big);
    put<int16_t>(s, 300, big);
  }
  for (int m = 0; m < 2; ++m) {
    put<float>(s, 1.5f, big);
    put<int32_t>(s, 3, big);
    for (int k = 0; k < 3; ++k) put<uint8_t>(s, 9, big);
  }
  for (const auto& q : c.f) {
    put<uint8_t>(s, 1, big);
    put<uint16_t>(s, static_cast<uint16_t>(q.size()), big);
    for (int i : q) put<uint32_t>(s, static_cast<uint32_t>(i), big);
  }
  return s;
}

std::string cube_ascii() {
  const QuadCube c;
  std::string s = cube_header("ascii");
  for (int i = 0; i < 8; ++i) {
    s += std::to_string(c.v[3 * i]) + " 0.25 " + std::to_string(c.v[3 * i + 1]) + " " +
         std::to_string(c.v[3 * i + 2]);
    for (int k = 0; k < 3; ++k) s += " " + std::to_string(c.rgb[3 * i + k]);
    s += " 2 -7 300\n";
  }
  s += "1.5 3 9 9 9\n1.5 3 9 9 9\n";
  for (const auto& q : c.f) {
    s += "1 " + std::to_string(q.size());
    for (int i : q) s += " " + std::to_string(i);
    s += "\n";
  }
  return s;
}

void check_cube(const Mesh& m) {
  const QuadCube c;
  REQUIRE(m.num_vertices() == 8);
  REQUIRE(m.num_faces() == 12);  // six quads fanned
  REQUIRE(m.has_colors());
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 3; ++k) {
      CHECK(m.V(i, k) == c.v[3 * i + k]);
      CHECK(m.colors(i, k) == doctest::Approx(c.rgb[3 * i + k] / 255.0));
    }
  // Fans of the quads, in file order, keep the orientation: total signed volume of the unit cube is +1.
  double vol = 0;
  for (int f = 0; f < 12; ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), d = m.V.row(m.F(f, 2));
    vol += a.dot(b.cross(d)) / 6.0;
  }
  CHECK(vol == doctest::Approx(1.0));
  CHECK(m.F(0, 0) == 0);
  CHECK(m.F(0, 1) == 3);
  CHECK(m.F(0, 2) == 2);
  CHECK(m.F(1, 0) == 0);
  CHECK(m.F(1, 1) == 2);
  CHECK(m.F(1, 2) == 1);
}

std::string error_of(const std::string& bytes, bool* io = nullptr) {
  try {
    parse_ply(bytes, "bad.ply");
  } catch (const IoError& e) {
    if (io) *io = true;
    return e.what();
  } catch (const InvalidInput& e) {
    if (io) *io = false;
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("PLY: ascii, binary little endian and hand-built big endian bytes give the same mesh") {
  PlyInfo info;
  const Mesh a = parse_ply(cube_ascii(), "a.ply", &info);
  CHECK(info.format == "ascii");
  CHECK(info.polygons == 6);
  CHECK(info.skipped_elements == 1);
  check_cube(a);
  const Mesh le = parse_ply(cube_binary(false), "le.ply", &info);
  CHECK(info.format == "binary_little_endian");
  check_cube(le);
  const Mesh be = parse_ply(cube_binary(true), "be.ply", &info);
  CHECK(info.format == "binary_big_endian");
  check_cube(be);
  CHECK(le.F == a.F);
  CHECK(be.F == a.F);
  CHECK(le.V == be.V);
  // The big-endian bytes really are big endian: the first x (double 0.0) is zeros, the second vertex x = 1.0
  // starts with 0x3f 0xf0.
  const std::string b = cube_binary(true);
  const size_t body = b.find("end_header\n") + 11;
  const size_t stride = 8 + 4 + 8 + 8 + 3 + 1 + 4;
  CHECK(static_cast<unsigned char>(b[body + stride]) == 0x3f);
  CHECK(static_cast<unsigned char>(b[body + stride + 1]) == 0xf0);
}

TEST_CASE("PLY: round trip through write_mesh (binary, float xyz + uchar colours, the synth benchmark's layout)") {
  // The procedural benchmark writes exactly this layout (write_mesh .ply with colours); assimp 5.2 misread such
  // files (e.g. synth20/display/display_0006.ply). A coloured closed shape with several hundred vertices.
  Mesh m = concatenate(make_icosphere(Vec3(0.1, 0.2, 0.3), 0.5, 2), make_box(Vec3(-1, -1, -1), Vec3(-0.5, -0.2, 0.1)));
  m.colors.resize(m.V.rows(), 3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    m.colors.row(i) << static_cast<float>(i % 7) / 6.f, static_cast<float>(i % 5) / 4.f, static_cast<float>(i % 3) / 2.f;
  const fs::path dir = test::scratch_dir("ply_test");
  fs::create_directories(dir);
  const std::string path = (dir / "shape.ply").string();
  write_mesh(path, m);
  PlyInfo info;
  const Mesh raw = read_ply(path, &info);
  CHECK(info.format == "binary_little_endian");
  REQUIRE(raw.num_vertices() == m.num_vertices());
  REQUIRE(raw.num_faces() == m.num_faces());
  CHECK(raw.F == m.F);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      CHECK(raw.V(i, k) == static_cast<double>(static_cast<float>(m.V(i, k))));
      CHECK(std::abs(raw.colors(i, k) - m.colors(i, k)) <= 0.5f / 255.f + 1e-6f);
    }
  // read_mesh (weld + validation) on top: nothing to weld or remove on this mesh.
  MeshReport report;
  const Mesh back = read_mesh(path, &report);
  CHECK(back.num_vertices() == m.num_vertices());
  CHECK(back.num_faces() == m.num_faces());
  CHECK(report.degenerate_faces == 0);
  CHECK(report.duplicate_faces == 0);
  // ascii re-encoding of the same file reads back identically.
  std::string ascii = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(raw.V.rows()) +
                      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                      std::to_string(raw.F.rows()) + "\nproperty list uchar int vertex_index\nend_header\n";
  char buf[128];
  for (Eigen::Index i = 0; i < raw.V.rows(); ++i) {
    std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g\r\n", raw.V(i, 0), raw.V(i, 1), raw.V(i, 2));
    ascii += buf;
  }
  for (Eigen::Index f = 0; f < raw.F.rows(); ++f)
    ascii += "3 " + std::to_string(raw.F(f, 0)) + " " + std::to_string(raw.F(f, 1)) + " " +
             std::to_string(raw.F(f, 2)) + "\n";
  const Mesh from_ascii = parse_ply(ascii, "ascii.ply");
  CHECK(from_ascii.V.cast<float>() == raw.V.cast<float>());  // %.9g round-trips float32
  CHECK(from_ascii.F == raw.F);
  CHECK(!from_ascii.has_colors());
  fs::remove_all(dir);
}

TEST_CASE("PLY: malformed, truncated and unusable files give errors naming the file") {
  const std::string good = cube_binary(false);
  bool io = false;
  // Truncated anywhere in the body: in the faces, in the extra element, in the vertices.
  for (size_t cut : {size_t(1), size_t(20), size_t(60), size_t(200)}) {
    CAPTURE(cut);
    const std::string msg = error_of(good.substr(0, good.size() - cut), &io);
    CHECK(msg.rfind("bad.ply: truncated binary PLY", 0) == 0);
    CHECK(io);
  }
  const std::string ascii = cube_ascii();
  CHECK(error_of(ascii.substr(0, ascii.size() - 4), &io).rfind("bad.ply: truncated PLY", 0) == 0);
  CHECK(io);
  // More data than declared (counts do not match).
  CHECK(error_of(ascii + "1 3 0 1 2\n", &io).find("more data than its header declares") != std::string::npos);
  CHECK(error_of(good + std::string("\x01\x02", 2), &io).find("more data than its header declares") !=
        std::string::npos);
  // Header problems.
  std::string s = good;
  s.replace(s.find("binary_little_endian"), 20, "binary_middle_endian");
  CHECK(error_of(s, &io).find("unknown PLY format 'binary_middle_endian'") != std::string::npos);
  CHECK(io);
  CHECK(error_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n0\n").find("unknown PLY type") !=
        std::string::npos);
  CHECK(error_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n").find("no end_header") !=
        std::string::npos);
  CHECK(error_of("solid x\n").find("not a PLY file") != std::string::npos);
  CHECK(error_of("").find("empty file") != std::string::npos);
  CHECK(error_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n")
            .find("lacks an x, y or z") != std::string::npos);
  CHECK(error_of("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 0 0 0 1 0\n3 0 x 2\n")
            .find("malformed PLY value 'x'") != std::string::npos);
  // Unusable content: InvalidInput.
  const std::string tri = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  CHECK(error_of(tri + "0 0 0 1 nan 0 0 1 0\n3 0 1 2\n", &io).find("non-finite vertex coordinates (NaN or Inf) at vertex 1") !=
        std::string::npos);
  CHECK(!io);
  CHECK(error_of(tri + "0 0 0 1 0 0 0 1 0\n3 0 1 3\n", &io).find("face index out of range") != std::string::npos);
  CHECK(!io);
  CHECK(error_of(tri + "0 0 0 1 0 0 0 1 0\n3 0 -1 2\n", &io).find("face index out of range") != std::string::npos);
  // A huge declared vertex count in a tiny file is truncation, not an allocation failure.
  CHECK(error_of("ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
                 "property float z\nend_header\n\x01\x02")
            .find("truncated binary PLY") != std::string::npos);
  // Through read_mesh: the file's path leads the message.
  const fs::path dir = test::scratch_dir("ply_bad");
  fs::create_directories(dir);
  const std::string path = (dir / "cut.ply").string();
  write_file_atomic(path, [&](std::ostream& o) { o << good.substr(0, good.size() - 20); });
  CHECK_THROWS_WITH_AS(read_mesh(path), doctest::Contains((path + ": truncated binary PLY").c_str()), IoError);
  fs::remove_all(dir);
}

TEST_CASE("PLY: points and lines are skipped, faces without a surface leave an empty mesh for validation") {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0 1 0 0 0 1 0 0 0 1\n";
  PlyInfo info;
  const Mesh m = parse_ply(head + "1 0\n2 0 1\n3 0 1 2\n", "pl.ply", &info);
  CHECK(m.num_faces() == 1);
  CHECK(info.skipped_faces == 2);
  CHECK(m.num_vertices() == 4);
}

TEST_CASE("PLY: list lengths that are not small non-negative integers are IoErrors, never casts of 1e30 or NaN") {
  const std::string tri = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                          "0 0 0 1 0 0 0 1 0\n";
  for (const std::string count : {"1e30", "nan", "inf", "-inf", "2.5", "-1", "1e9"}) {
    CAPTURE(count);
    bool io = false;
    const std::string msg = error_of(tri + count + " 0 1 2\n", &io);
    CHECK(msg.rfind("bad.ply: bad PLY list length", 0) == 0);
    CHECK(io);
  }
  // The same in a list that is skipped (not the face indices) and in another element.
  const std::string extra = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                            "property list uchar float texcoord\nelement edge 1\nproperty list uchar int v\n"
                            "end_header\n0 0 0 1 0 0 0 1 0\n";
  CHECK(error_of(extra + "3 0 1 2 1e30 0 0\n2 0 1\n").rfind("bad.ply: bad PLY list length", 0) == 0);
  CHECK(error_of(extra + "3 0 1 2 0\nnan 0 1\n").rfind("bad.ply: bad PLY list length", 0) == 0);
  // A NaN face index is out of range (it used to pass every comparison).
  bool io = true;
  CHECK(error_of(tri + "3 0 nan 2\n", &io).find("face index out of range") != std::string::npos);
  CHECK(!io);
  // An element count beyond a long is a malformed header.
  CHECK(error_of("ply\nformat ascii 1.0\nelement vertex 99999999999999999999\nproperty float x\nend_header\n")
            .find("malformed PLY header line") != std::string::npos);
}

TEST_CASE("PLY: a tiny file declaring 50 million faces fails before allocating for them") {
  // 3 vertices and 1 face of data, 50,000,000 faces declared. The reader used to reserve 3 x 4 bytes per declared
  // face (600 MB) before reading the first one. Here the address space is capped 256 MB above what the process
  // already maps, so such an allocation throws std::bad_alloc instead of the IoError expected.
  std::string bytes = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 50000000\nproperty list uchar int vertex_indices\nend_header\n";
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  bytes.append(reinterpret_cast<const char*>(v), sizeof v);
  const int32_t f[3] = {0, 1, 2};
  bytes.push_back(3);
  bytes.append(reinterpret_cast<const char*>(f), sizeof f);
  long pages = 0;
  {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    REQUIRE(statm != nullptr);
    REQUIRE(std::fscanf(statm, "%ld", &pages) == 1);
    std::fclose(statm);
  }
  rlimit old{};
  REQUIRE(getrlimit(RLIMIT_AS, &old) == 0);
  rlimit capped = old;
  const rlim_t cap = static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE)) + (rlim_t(256) << 20);
  if (old.rlim_cur == RLIM_INFINITY || old.rlim_cur > cap) capped.rlim_cur = cap;
  REQUIRE(setrlimit(RLIMIT_AS, &capped) == 0);
  std::string msg;
  try {
    parse_ply(bytes, "tiny.ply");
    msg = "no error";
  } catch (const IoError& e) {
    msg = e.what();
  } catch (const std::exception& e) {
    msg = std::string("not an IoError: ") + e.what();
  }
  REQUIRE(setrlimit(RLIMIT_AS, &old) == 0);
  CHECK(msg.rfind("tiny.ply: truncated binary PLY", 0) == 0);
  CHECK(msg.find("50000000") != std::string::npos);
}
