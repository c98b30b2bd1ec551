// End-to-end tests of `sdfkit prep` (exit codes, manifest, resume, reproducibility) through the real binary.
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/prepare.h"
#include "cli_run.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
/// `sdfkit prep ARGS`; stdout and stderr kept apart (test::run_sdfkit).
test::CliRun prep(const std::string& args) {
  return test::run_sdfkit("prep " + args);
}
int run(const std::string& args) { return prep(args).code; }
const char* kFast = " --voxel 0.03 --band 0.14 --samples 800 --views 0 ";

std::string all_bytes(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::string out;
  for (const auto& f : files) out += fs::relative(f, dir).string() + "\n" + read_file(f.string());
  return out;
}
}  // namespace

TEST_CASE("sdfkit prep: a batch with bad files exits 2, writes the good shapes and reports the bad ones") {
  const fs::path dir = test::scratch_dir("prep_cli");
  fs::remove_all(dir);
  write_mesh((dir / "in" / "boxes" / "a.obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "boxes" / "b.off").string(), make_torus(Vec3::Zero(), 1, 0.3, 32, 16));
  write_text_atomic((dir / "in" / "boxes" / "empty.obj").string(), "");
  write_text_atomic((dir / "in" / "other" / "nan.obj").string(), "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  const fs::path out = dir / "out";
  CHECK(run((dir / "in").string() + " -o " + out.string() + kFast) == 2);
  CHECK(shape_is_complete((out / "boxes" / "a").string()));
  CHECK(shape_is_complete((out / "boxes" / "b").string()));
  CHECK_FALSE(shape_is_complete((out / "boxes" / "empty").string()));
  const Json m = read_json((out / "manifest.json").string());
  REQUIRE(m["shapes"].size() == 4);
  int failed = 0;
  for (const auto& s : m["shapes"])
    if (s["status"] == "failed") {
      ++failed;
      CHECK(s["reason"].get<std::string>().find(s["source"].get<std::string>()) != std::string::npos);
    }
  CHECK(failed == 2);
  CHECK(m["counts"]["ok"] == 2);

  // A single bad file: exit 1. Unknown extension: exit 1. Bad flags: exit 1.
  const test::CliRun empty = prep((dir / "in" / "boxes" / "empty.obj").string() + " -o " + (dir / "o1").string());
  CHECK(empty.code == 1);
  CHECK(empty.err.find("empty.obj") != std::string::npos);  // the error names the file
  write_text_atomic((dir / "x.abc").string(), "abc");
  const test::CliRun unknown = prep((dir / "x.abc").string() + " -o " + (dir / "o2").string());
  CHECK(unknown.code == 1);
  CHECK(unknown.err.find("x.abc") != std::string::npos);
  CHECK(run((dir / "in").string() + " -o " + (dir / "o3").string() + " --shard 3/2") == 1);
  CHECK(run((dir / "in").string() + " -o " + (dir / "o3").string() + " --band 0.005") == 1);  // narrower than a voxel
  fs::remove_all(dir);
}

TEST_CASE("sdfkit prep: same command twice gives byte-identical outputs, reruns resume, shards split the work") {
  const fs::path dir = test::scratch_dir("prep_cli_repro");
  fs::remove_all(dir);
  write_mesh((dir / "in" / "c" / "box.obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "c" / "ring.ply").string(), make_torus(Vec3::Zero(), 1, 0.3, 32, 16));
  CHECK(run((dir / "in").string() + " -o " + (dir / "a").string() + kFast + "--jobs 1") == 0);
  CHECK(run((dir / "in").string() + " -o " + (dir / "b").string() + kFast + "--jobs 2") == 0);
  CHECK(all_bytes(dir / "a") == all_bytes(dir / "b"));
  // Resume: complete shapes are skipped, the result is unchanged.
  const auto stamp = fs::last_write_time(dir / "a" / "c" / "box" / "sdf.vdb");
  CHECK(run((dir / "in").string() + " -o " + (dir / "a").string() + kFast) == 0);
  CHECK(fs::last_write_time(dir / "a" / "c" / "box" / "sdf.vdb") == stamp);
  CHECK(all_bytes(dir / "a") == all_bytes(dir / "b"));
  // Two shards cover both shapes exactly once.
  CHECK(run((dir / "in").string() + " -o " + (dir / "s").string() + kFast + "--shard 0/2") == 0);
  CHECK(run((dir / "in").string() + " -o " + (dir / "s").string() + kFast + "--shard 1/2") == 0);
  CHECK(shape_is_complete((dir / "s" / "c" / "box").string()));
  CHECK(shape_is_complete((dir / "s" / "c" / "ring").string()));
  CHECK(read_json((dir / "s" / "manifest.0of2.json").string())["shapes"].size() == 1);
  CHECK(read_file((dir / "s" / "c" / "ring" / "samples.npy").string()) ==
        read_file((dir / "a" / "c" / "ring" / "samples.npy").string()));
  fs::remove_all(dir);
}
