#include "camera/texture.h"

#include "cli_run.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
/// 2 x 2 RGB: top-left red, top-right green, bottom-left blue, bottom-right white.
Image quad() {
  Image im(2, 2, 3, 0.f);
  im.at(0, 0, 0) = 1;
  im.at(1, 0, 1) = 1;
  im.at(0, 1, 2) = 1;
  for (int c = 0; c < 3; ++c) im.at(1, 1, c) = 1;
  return im;
}
}  // namespace

TEST_CASE("sample_texture: texel centres, v up, wrapping, bilinear in between") {
  const Image im = quad();
  auto near = [](const Eigen::Vector3f& a, float r, float g, float b) {
    return (a - Eigen::Vector3f(r, g, b)).cwiseAbs().maxCoeff() < 1e-6f;
  };
  CHECK(near(sample_texture(im, {0.25f, 0.75f}), 1, 0, 0));  // top-left texel: v = 0.75 is the upper row
  CHECK(near(sample_texture(im, {0.75f, 0.75f}), 0, 1, 0));
  CHECK(near(sample_texture(im, {0.25f, 0.25f}), 0, 0, 1));
  CHECK(near(sample_texture(im, {0.75f, 0.25f}), 1, 1, 1));
  CHECK(near(sample_texture(im, {1.25f, -0.25f}), 1, 0, 0));  // wraps to (0.25, 0.75)
  CHECK(near(sample_texture(im, {0.5f, 0.75f}), 0.5f, 0.5f, 0));  // halfway between red and green
}

TEST_CASE("read_mesh with image_texture_sampler: an OBJ's map_Kd colours its vertices, a missing texture is reported") {
  const fs::path dir = test::scratch_dir("camera_texture");
  fs::create_directories(dir);
  write_image((dir / "quad.png").string(), quad());
  write_text_atomic((dir / "t.mtl").string(), "newmtl tex\nKd 1 1 1\nmap_Kd quad.png\n");
  // A square whose four corners sit on the four texel centres.
  write_text_atomic((dir / "t.obj").string(),
                    "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0.25 0.25\nvt 0.75 0.25\nvt 0.75 0.75\n"
                    "vt 0.25 0.75\nusemtl tex\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  MeshReport report;
  const Mesh m = read_mesh((dir / "t.obj").string(), &report, image_texture_sampler());
  REQUIRE(m.has_colors());
  CHECK(report.textured_parts == 1);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const double x = m.V(i, 0), y = m.V(i, 1);
    CAPTURE(i);
    // Vertex (x, y) has texture coordinate (0.25 + x / 2, 0.25 + y / 2): blue, white, green, red.
    const Eigen::Vector3f want = x == 0 && y == 0 ? Eigen::Vector3f(0, 0, 1)
                                 : x == 1 && y == 0 ? Eigen::Vector3f(1, 1, 1)
                                 : x == 1 && y == 1 ? Eigen::Vector3f(0, 1, 0)
                                                    : Eigen::Vector3f(1, 0, 0);
    CHECK((m.colors.row(i).transpose() - want).cwiseAbs().maxCoeff() < 1e-5f);
  }
  // Without a sampler the material's Kd colours the part; with a missing file it is reported.
  CHECK((read_mesh((dir / "t.obj").string()).colors.array() == 1.f).all());
  fs::remove(dir / "quad.png");
  MeshReport missing;
  const Mesh g = read_mesh((dir / "t.obj").string(), &missing, image_texture_sampler());
  REQUIRE(missing.missing_textures.size() == 1);
  CHECK(missing.missing_textures[0].find("quad.png") != std::string::npos);
  CHECK((g.colors.array() == 1.f).all());
  fs::remove_all(dir);
}

TEST_CASE("textures named as real catalogues name them are found, and a missing one is one warning in prep and in render") {
  const fs::path dir = test::scratch_dir("camera_texture_names");
  fs::remove_all(dir);
  fs::create_directories(dir / "Maps");
  write_image((dir / "Maps" / "Quad.PNG").string(), quad());
  // Trailing tabs, a Windows path with a drive letter, another case; the second material's file does not exist and
  // two parts use it.
  write_text_atomic((dir / "t.mtl").string(),
                    "newmtl tex\nKd 1 1 1\nmap_Kd f:\\work\\chair\\maps\\quad.png\t\t\n"
                    "newmtl gone\nKd 0.5 0.5 0.5\nmap_Kd K:/textures/Gone.jpg\t\n");
  write_text_atomic((dir / "t.obj").string(),
                    "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                    "v 0 0 2\nv 1 0 2\nv 1 1 2\n"
                    "vt 0.25 0.25\nvt 0.75 0.25\nvt 0.75 0.75\nvt 0.25 0.75\n"
                    "o a\nusemtl tex\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
                    "o b\nusemtl gone\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n"
                    "o c\nusemtl gone\nf 9/1 10/2 11/3\n");
  MeshReport report;
  const Mesh m = read_mesh((dir / "t.obj").string(), &report, image_texture_sampler());
  CHECK(report.textured_parts == 1);
  REQUIRE(report.missing_textures.size() == 1);
  CHECK(report.missing_textures[0] == (dir / "K:/textures/Gone.jpg").string());
  REQUIRE(m.has_colors());
  bool blue = false;  // the textured square's corner (0, 0, 0) samples the blue texel
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (m.V.row(i).isZero()) blue = (m.colors.row(i) - Eigen::RowVector3f(0, 0, 1)).cwiseAbs().maxCoeff() < 1e-5f;
  CHECK(blue);

  const auto warnings = [](const std::string& err) {
    size_t n = 0;
    for (size_t at = err.find("Gone.jpg"); at != std::string::npos; at = err.find("Gone.jpg", at + 1)) ++n;
    return n;
  };
  const test::CliRun render = test::run_sdfkit("render " + (dir / "t.obj").string() + " -o " +
                                               (dir / "views").string() + " --views 1 --size 32");
  CHECK_MESSAGE(render.code == 0, render.err);
  CHECK(warnings(render.err) == 1);
  const test::CliRun prep = test::run_sdfkit("prep " + (dir / "t.obj").string() + " -o " + (dir / "prep").string() +
                                             " --views 1 --voxel 0.05 --samples 100 -q");
  CHECK_MESSAGE(prep.code == 0, prep.err);
  CHECK(warnings(prep.err) == 1);
  CHECK(prep.err.find("cannot be read") != std::string::npos);
  fs::remove_all(dir);
}
