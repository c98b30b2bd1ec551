// End-to-end tests of `sdfkit prep` (exit codes, manifest, resume, reproducibility) through the real binary.
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "sdf/prepare.h"
#include "test_meshes.h"

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

namespace {
/// The files directly in `dir` (not in sub-folders): a prepared shape must never write there.
std::vector<std::string> loose_files(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (!e.is_directory() && e.path().filename().string().rfind("manifest", 0) != 0)
      out.push_back(e.path().filename().string());
  return out;
}
}  // namespace

TEST_CASE("sdfkit prep: symlinked meshes keep the id of their link, each in its own folder") {
  const fs::path dir = test::scratch_dir("prep_cli_links");
  write_mesh((dir / "src" / "bunny.obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "src" / "deep" / "teapot.off").string(), make_torus(Vec3::Zero(), 1, 0.3, 32, 16));
  fs::create_directories(dir / "in" / "cat");
  fs::create_directories(dir / "in" / "cat2");
  fs::create_symlink(dir / "src" / "bunny.obj", dir / "in" / "cat" / "bunny.obj");
  fs::create_symlink(dir / "src" / "deep" / "teapot.off", dir / "in" / "cat" / "pot.off");
  fs::create_symlink(dir / "src" / "bunny.obj", dir / "in" / "cat2" / "rabbit.obj");  // same target, other id
  const fs::path out = dir / "out";
  const test::CliRun r = prep((dir / "in").string() + " -o " + out.string() + kFast);
  CHECK(r.code == 0);
  CHECK(r.out.find("3 prepared") != std::string::npos);
  // The shape id is the link's stem (the link target's path used to give the id "..": files written into out/).
  CHECK(shape_is_complete((out / "cat" / "bunny").string()));
  CHECK(shape_is_complete((out / "cat" / "pot").string()));
  CHECK(shape_is_complete((out / "cat2" / "rabbit").string()));
  CHECK(loose_files(out).empty());
  CHECK(loose_files(out / "cat").empty());
  const Json m = read_json((out / "manifest.json").string());
  REQUIRE(m["shapes"].size() == 3);
  for (const auto& s : m["shapes"]) CHECK(s["status"] == "ok");
}

TEST_CASE("sdfkit prep: symlinked shape and category folders are walked, a link cycle is not") {
  const fs::path dir = test::scratch_dir("prep_cli_dirlinks");
  // ShapeNet layout <category>/<id>/models/model_normalized.obj, with the id folder a link to elsewhere.
  write_mesh((dir / "store" / "s1" / "models" / "model_normalized.obj").string(),
             make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "chairs" / "s2" / "models" / "model_normalized.obj").string(),
             make_torus(Vec3::Zero(), 1, 0.3, 32, 16));
  fs::create_directory_symlink(dir / "store" / "s1", dir / "in" / "chairs" / "s1");
  fs::create_directory_symlink(dir / "in" / "chairs", dir / "in" / "chairs" / "s2" / "loop");  // a cycle
  // A whole category folder that is a link.
  write_mesh((dir / "elsewhere" / "tables" / "t.obj").string(), make_box(Vec3::Constant(-1), Vec3(2, 1, 1)));
  fs::create_directory_symlink(dir / "elsewhere" / "tables", dir / "in" / "tables");
  const fs::path out = dir / "out";
  const test::CliRun r = prep((dir / "in").string() + " -o " + out.string() + kFast);
  CHECK(r.code == 0);
  CHECK(shape_is_complete((out / "chairs" / "s1").string()));  // behind a link: used to be skipped silently
  CHECK(shape_is_complete((out / "chairs" / "s2").string()));
  CHECK(shape_is_complete((out / "tables" / "t").string()));
  CHECK(read_json((out / "manifest.json").string())["shapes"].size() == 3);
  CHECK(loose_files(out).empty());
}

TEST_CASE("sdfkit prep: duplicate shape ids fail as items naming both files, across shards too") {
  const fs::path dir = test::scratch_dir("prep_cli_dups");
  write_mesh((dir / "in" / "c" / "x.obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "c" / "x.off").string(), make_torus(Vec3::Zero(), 1, 0.3, 32, 16));
  write_mesh((dir / "in" / "c" / "y.obj").string(), make_box(Vec3::Constant(-1), Vec3(2, 1, 1)));
  const std::string x_obj = (dir / "in" / "c" / "x.obj").string(), x_off = (dir / "in" / "c" / "x.off").string();
  const test::CliRun r = prep((dir / "in").string() + " -o " + (dir / "out").string() + kFast);
  CHECK(r.code == 2);
  CHECK(r.out.find("2 prepared, 0 already complete, 1 failed of 3") != std::string::npos);
  CHECK(r.err.find(x_off + ": duplicate shape id 'c/x', already taken by " + x_obj) != std::string::npos);
  // The folder holds the first file's shape (the box: 12 triangles), not a mix or the torus.
  CHECK(read_mesh((dir / "out" / "c" / "x" / "gt.obj").string()).num_faces() == 12);
  // With two shards the two files land in different shards; each shard sees the clash.
  CHECK(run((dir / "in").string() + " -o " + (dir / "s").string() + kFast + "--shard 0/3") == 0);
  const test::CliRun s1 = prep((dir / "in").string() + " -o " + (dir / "s").string() + kFast + "--shard 1/3");
  CHECK(s1.code == 1);  // its only shape failed
  CHECK(s1.err.find("duplicate shape id 'c/x'") != std::string::npos);
  CHECK(read_mesh((dir / "s" / "c" / "x" / "gt.obj").string()).num_faces() == 12);
}

TEST_CASE("sdfkit prep: ids with '..' or '.' are items that fail, never folders outside their place") {
  const fs::path dir = test::scratch_dir("prep_cli_dotdot");
  // "...obj" has the stem ".." and "..obj" the stem ".": as ids they name out/<category>/.. and out/<category>/.
  write_mesh((dir / "in" / "c" / "...obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "c" / "..obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "c" / "good.obj").string(), make_box(Vec3::Constant(-1), Vec3(2, 1, 1)));
  const fs::path out = dir / "out";
  const test::CliRun r = prep((dir / "in").string() + " -o " + out.string() + kFast);
  CHECK(r.code == 2);
  CHECK(shape_is_complete((out / "c" / "good").string()));
  CHECK(loose_files(out).empty());
  CHECK(loose_files(out / "c").empty());
  CHECK(r.err.find((dir / "in" / "c" / "...obj").string() +
                   ": shape id '..' cannot be a folder of its own in the output (it names the parent folder)") !=
        std::string::npos);
  CHECK(r.err.find((dir / "in" / "c" / "..obj").string() +
                   ": shape id '.' cannot be a folder of its own in the output (it names the folder itself)") !=
        std::string::npos);
  // A single such mesh: exit 1, nothing written into out/.
  const test::CliRun one = prep((dir / "in" / "c" / "...obj").string() + " -o " + (dir / "o1").string() + kFast);
  CHECK(one.code == 1);
  CHECK(loose_files(dir / "o1").empty());
  // A list file: a '..' category is refused with the line number, a '..' stem fails as an item.
  write_text_atomic((dir / "bad_category.lst").string(), "..\tin/c/good.obj\n");
  const test::CliRun cat = prep((dir / "bad_category.lst").string() + " -o " + (dir / "o2").string() + kFast);
  CHECK(cat.code == 1);
  CHECK(cat.err.find("bad_category.lst:1: bad category '..'") != std::string::npos);
  write_text_atomic((dir / "bad_stem.lst").string(), "c\tin/c/...obj\nc\tin/c/good.obj\n");
  const test::CliRun stem = prep((dir / "bad_stem.lst").string() + " -o " + (dir / "o3").string() + kFast);
  CHECK(stem.code == 2);
  CHECK(loose_files(dir / "o3").empty());
  CHECK(shape_is_complete((dir / "o3" / "c" / "good").string()));
}

TEST_CASE("sdfkit prep: a shape another prep is preparing is left to it and reported, then done by a rerun") {
  const fs::path dir = test::scratch_dir("prep_cli_lock");
  fs::remove_all(dir);
  write_mesh((dir / "in" / "boxes" / "a.obj").string(), make_box(Vec3::Constant(-1), Vec3(1, 2, 1)));
  write_mesh((dir / "in" / "boxes" / "b.obj").string(), make_box(Vec3::Constant(-1), Vec3(2, 1, 1)));
  const fs::path out = dir / "out";
  {
    // This process plays the other prep: it holds shape a's folder.
    const FolderLock other((out / "boxes" / "a").string());
    REQUIRE(other.locked());
    const test::CliRun r = prep((dir / "in").string() + " -o " + out.string() + kFast);
    CHECK(r.code == 2);
    CHECK(r.err.find("boxes/a: another sdfkit prep is preparing this shape") != std::string::npos);
    CHECK_FALSE(shape_is_complete((out / "boxes" / "a").string()));
    CHECK(shape_is_complete((out / "boxes" / "b").string()));
  }
  // Released: the rerun prepares a and keeps b.
  const test::CliRun r = prep((dir / "in").string() + " -o " + out.string() + kFast);
  CHECK_MESSAGE(r.code == 0, r.err);
  CHECK(shape_is_complete((out / "boxes" / "a").string()));
  CHECK(r.out.find("1 prepared, 1 already complete, 0 failed") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("sdfkit prep --sign flood: a cabinet's hollow behind door gaps is inside, in the grid and the ground truth") {
  const fs::path dir = test::scratch_dir("prep_cli_flood");
  fs::remove_all(dir);
  // Slabs 0.06 thick around [-0.5, 0.5]^3, two doors in front with a 0.01 gap (a third of a voxel once normalised).
  write_mesh((dir / "in" / "cabinet" / "c.obj").string(), test::slab_cabinet(0.01));
  const fs::path out = dir / "out", shape = out / "cabinet" / "c";
  const std::string base = (dir / "in").string() + " -o " + out.string() + kFast;
  long inner[2] = {0, 0};
  // The second run asks for another sign in the same folder: the complete shape is prepared again.
  for (int flood = 0; flood < 2; ++flood) {
    CAPTURE(flood);
    const test::CliRun r = prep(base + (flood ? "--sign flood" : "--sign auto"));
    REQUIRE(r.code == 0);
    CHECK((r.out.find("prepared again: its norm.json had another grid.sealed") != std::string::npos) == (flood == 1));
    const Json norm = read_json((shape / "norm.json").string());
    CHECK(norm["grid"]["sealed"].get<bool>() == (flood == 1));
    CHECK(norm["grid"]["sign"] == "winding_number");
    CHECK((SparseSdf::read((shape / "sdf.vdb").string()).value(Vec3::Zero()) < 0) == (flood == 1));
    // The iso-surface ground truth: the hollow's walls (between the inner faces at 0.51 and the outer at 0.58 once
    // normalised) only without the flood, apart from the slit.
    const Mesh gt = read_mesh((shape / "gt.obj").string());
    for (Eigen::Index v = 0; v < gt.V.rows(); ++v) inner[flood] += gt.V.row(v).cwiseAbs().maxCoeff() < 0.54;
  }
  CHECK(inner[0] > 100);
  CHECK(inner[1] * 10 < inner[0]);
  // Same settings again: skipped. Other samples: prepared again, naming the key.
  CHECK(prep(base + "--sign flood").out.find("0 prepared, 1 already complete") != std::string::npos);
  const test::CliRun more = prep((dir / "in").string() + " -o " + out.string() +
                                 " --voxel 0.03 --band 0.14 --samples 900 --views 0 --sign flood");
  CHECK(more.out.find("another samples.count") != std::string::npos);
  CHECK(read_json((shape / "norm.json").string())["samples"]["count"] == 900);
  CHECK(run((dir / "in").string() + " -o " + (dir / "bad").string() + kFast + "--sign sealed") == 1);
  fs::remove_all(dir);
}
