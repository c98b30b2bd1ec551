// CLI-level tests of `sdfkit extract`: the mesh of a sphere's sparse grid against the closed form (radius + iso),
// one grid and dataset modes, a failed shape in a batch (exit 2, named), flags that do not apply (exit 1).
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/orientation.h"
#include "sdf/sparse_sdf.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
// Smallest and largest distance of the mesh's vertices from the origin.
std::pair<double, double> radius_range(const Mesh& m) {
  double lo = 1e9, hi = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const double r = m.V.row(i).norm();
    lo = std::min(lo, r);
    hi = std::max(hi, r);
  }
  return {lo, hi};
}
}  // namespace

TEST_CASE("sdfkit extract: a sphere's grid gives the sphere of radius r + iso, per grid and per dataset") {
  const fs::path dir = test::scratch_dir("extract_cli");
  fs::remove_all(dir);
  const fs::path data = dir / "data";
  fs::create_directories(data / "ball" / "small");
  fs::create_directories(data / "ball" / "broken");
  const double r = 0.5;
  SparseSdf::from_mesh(make_icosphere(Vec3::Zero(), r, 5)).write((data / "ball" / "small" / "sdf.vdb").string());
  write_text_atomic((data / "ball" / "broken" / "sdf.vdb").string(), "not a vdb file\n");
  write_text_atomic((data / "test.lst").string(), "ball/small\nball/broken\n");
  const std::string grid = (data / "ball" / "small" / "sdf.vdb").string();

  // One grid, the default iso 0.003 and 65^3: every vertex within a few thousandths of radius r + 0.003 (MC's
  // linear interpolation of a trilinear field over 0.033-wide cells), a closed mesh.
  const std::string one = (dir / "one.ply").string();
  const test::CliRun a = test::run_sdfkit("extract " + grid + " -o " + one + " --json");
  REQUIRE_MESSAGE(a.code == 0, a.err);
  const Json ja = Json::parse(a.out);
  const Mesh m = read_mesh(one);
  CHECK(ja["vertices"].get<long>() == m.num_vertices());
  CHECK(ja["evaluations"].get<long>() == 65L * 65 * 65);
  CHECK(is_closed_oriented(m));
  auto [lo, hi] = radius_range(m);
  CHECK(lo > r + 0.003 - 0.004);
  CHECK(hi < r + 0.003 + 0.004);
  // A level inside the stored band moves the surface by exactly that much.
  const test::CliRun b = test::run_sdfkit("extract " + grid + " -o " + one + " --iso 0.015 --res 129");
  REQUIRE_MESSAGE(b.code == 0, b.err);
  std::tie(lo, hi) = radius_range(read_mesh(one));
  CHECK(lo > r + 0.015 - 0.003);
  CHECK(hi < r + 0.015 + 0.003);
  // A level beyond the band (the grid holds +-background there): no surface, one line naming the file.
  const test::CliRun far = test::run_sdfkit("extract " + grid + " -o " + one + " --iso 0.2");
  CHECK(far.code == 1);
  CHECK(far.err.find(grid) != std::string::npos);
  CHECK(far.err.find("no surface") != std::string::npos);

  // Dataset + split: the good shape is written where `eval` looks, the broken one is reported and the exit is 2.
  const fs::path out = dir / "meshes";
  const test::CliRun d = test::run_sdfkit("extract " + data.string() + " --split test -o " + out.string() + " --json");
  CHECK(d.code == 2);
  CHECK(d.err.find("ball/broken") != std::string::npos);
  const Json jd = Json::parse(d.out);
  REQUIRE(jd["failed"].size() == 1);
  CHECK(jd["failed"][0].get<std::string>() == "ball/broken");
  CHECK(fs::exists(out / "ball" / "small.obj"));
  CHECK_FALSE(fs::exists(out / "ball" / "broken.obj"));
  CHECK(read_mesh((out / "ball" / "small.obj").string()).num_faces() == m.num_faces());

  // Flags that do not apply, and outputs of the wrong kind.
  CHECK(test::run_sdfkit("extract " + grid + " -o " + one + " --split test").code == 1);
  CHECK(test::run_sdfkit("extract " + grid + " -o " + (dir / "folder").string()).code == 1);
  CHECK(test::run_sdfkit("extract " + data.string() + " -o " + one).code == 1);
  const test::CliRun missing = test::run_sdfkit("extract " + (dir / "nothing.vdb").string() + " -o " + one);
  CHECK(missing.code == 1);
  CHECK(missing.err.find("nothing.vdb") != std::string::npos);
}
