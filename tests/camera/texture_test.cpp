#include "camera/texture.h"

#include "core/files.h"
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
