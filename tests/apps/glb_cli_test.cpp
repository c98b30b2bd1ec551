// The commands that write meshes take a .glb path: render --mesh-out keeps the colours its textures and materials
// give (read back through read_mesh), and `sdfkit report` turns recon's JSON into a page or names what is wrong.
#include "cli_run.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

TEST_CASE("render --mesh-out x.glb writes the rendered mesh with its colours, as the .ply of the same run") {
  const fs::path dir = test::scratch_dir("apps_glb");
  fs::create_directories(dir);
  Mesh box = make_box(Vec3(-1, -0.5, -0.25), Vec3(1, 0.5, 0.25));
  box.colors.resize(box.V.rows(), 3);
  for (Eigen::Index i = 0; i < box.V.rows(); ++i) box.colors.row(i) << 0.2f + 0.1f * static_cast<float>(i), 0.6f, 0.3f;
  const std::string src = (dir / "box.ply").string();
  write_mesh(src, box);
  const test::CliRun a = test::run_sdfkit("render " + src + " -o " + (dir / "v1").string() + " --views 1 --mesh-out " +
                                          (dir / "m.glb").string());
  REQUIRE_MESSAGE(a.code == 0, a.err);
  const test::CliRun b = test::run_sdfkit("render " + src + " -o " + (dir / "v2").string() + " --views 1 --mesh-out " +
                                          (dir / "m.ply").string());
  REQUIRE_MESSAGE(b.code == 0, b.err);
  const Mesh g = read_mesh((dir / "m.glb").string()), p = read_mesh((dir / "m.ply").string());
  REQUIRE(p.has_colors());
  REQUIRE(g.has_colors());
  CHECK(g.num_vertices() == p.num_vertices());
  CHECK(g.num_faces() == p.num_faces());
  CHECK(surface_area(g) == doctest::Approx(surface_area(p)).epsilon(1e-5));
  // The PLY stores 8-bit colours: the GLB's (float) agree within half a step.
  CHECK((g.colors.colwise().mean() - p.colors.colwise().mean()).cwiseAbs().maxCoeff() < 0.5 / 255 + 1e-4);
  fs::remove_all(dir);
}

TEST_CASE("report: a file that is not recon's JSON is one line naming it") {
  const fs::path dir = test::scratch_dir("apps_report_bad");
  fs::create_directories(dir / "viewer");
  write_text_atomic((dir / "viewer" / "model-viewer-umd.min.js").string(), "//\n");
  write_text_atomic((dir / "r.json").string(), "{\"no\": 1}");
  const test::CliRun r = test::run_sdfkit_under("SDFKIT_VIEWER_DIR=" + (dir / "viewer").string(),
                                                "report " + (dir / "r.json").string() + " -o " + (dir / "out").string());
  CHECK(r.code == 1);
  CHECK(r.err.find((dir / "r.json").string() + ": not a record of sdfkit recon --json") != std::string::npos);
  const test::CliRun m = test::run_sdfkit_under("SDFKIT_VIEWER_DIR=" + (dir / "none").string(),
                                                "report " + (dir / "r.json").string() + " -o " + (dir / "out").string());
  CHECK(m.code == 1);
  CHECK(m.err.find("run scripts/vendor_viewer") != std::string::npos);
  fs::remove_all(dir);
}
