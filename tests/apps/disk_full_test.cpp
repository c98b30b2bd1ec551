// A full disk under prep, render, recon and training: each must fail with one line on stderr and a non-zero exit,
// leaving no temporary file, no half-written file and no half shape behind.
//
// The full disk is a small tmpfs mounted on the output folder in a private mount namespace (`unshare -rm`: no
// privileges needed where user namespaces are allowed). Where they are not, every file the command writes is capped
// instead (RLIMIT_FSIZE with SIGXFSZ ignored, so a write past the cap fails with EFBIG as it would with ENOSPC).
#include "cli_run.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

struct FullDiskRun {
  int code = -1;
  std::string err;
  std::vector<std::string> files;  ///< what the command left in the output folder (paths relative to it)
};

/// `sdfkit ARGS` writing into `dir`, a disk of `kb` kilobytes.
FullDiskRun run_on_full_disk(const fs::path& dir, int kb, const std::string& args) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path side = dir.parent_path() / (dir.filename().string() + ".run");
  fs::create_directories(side);
  const std::string script = (side / "run.sh").string();
  // $1 = output folder, $2 = size in KB, $3 = side folder; the rest is the command.
  write_text_atomic(script,
                    "#!/bin/bash\n"
                    "dir=$1 kb=$2 side=$3; shift 3\n"
                    "inner() { \"$@\" > \"$side/out\" 2> \"$side/err\"; echo $? > \"$side/rc\"; "
                    "(cd \"$dir\" && find . -type f | sort) > \"$side/files\"; }\n"
                    "if unshare -rm true 2> /dev/null; then\n"
                    "  export -f inner; export dir kb side\n"
                    "  unshare -rm bash -c 'mount -t tmpfs -o size='\"$kb\"'k none \"$dir\" && inner \"$@\"' _ \"$@\"\n"
                    "else\n"
                    "  trap '' XFSZ; ulimit -f \"$kb\"; inner \"$@\"\n"
                    "fi\n");
  const std::string cmd = "bash " + script + " " + dir.string() + " " + std::to_string(kb) + " " + side.string() +
                          " " + SDFKIT_EXE + " " + args;
  REQUIRE(std::system(cmd.c_str()) == 0);
  FullDiskRun r;
  REQUIRE(fs::exists(side / "rc"));
  r.code = std::stoi(read_file((side / "rc").string()));
  r.err = read_file((side / "err").string());
  std::istringstream files(read_file((side / "files").string()));
  for (std::string line; std::getline(files, line);) r.files.push_back(line.substr(2));  // drop "./"
  return r;
}

/// The checks every command shares: non-zero exit, one line on stderr, no temporary file left.
void check_clean_failure(const FullDiskRun& r) {
  CHECK(r.code != 0);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  for (const std::string& f : r.files) CHECK_MESSAGE(f.find(".tmp.") == std::string::npos, f);
}

bool has(const std::vector<std::string>& files, const std::string& f) {
  return std::find(files.begin(), files.end(), f) != files.end();
}

}  // namespace

TEST_CASE("full disk: prep leaves no half shape, render no view without its image, recon no half mesh") {
  const fs::path dir = test::scratch_dir("disk_full");
  const std::string mesh = (dir / "in" / "box.obj").string();
  write_mesh(mesh, make_torus(Vec3::Zero(), 1, 0.3, 48, 24));

  // prep: 40 KB holds the samples but not the grid.
  FullDiskRun r = run_on_full_disk(dir / "prep", 40,
                                   "prep " + mesh + " -o " + (dir / "prep").string() +
                                       " --voxel 0.02 --band 0.1 --samples 2000 --views 0");
  INFO(r.err);
  check_clean_failure(r);
  CHECK(r.err.find("box") != std::string::npos);
  for (const char* f : {"box/sdf.vdb", "box/samples.npy", "box/gt.obj", "box/norm.json"})
    CHECK_MESSAGE(!has(r.files, f), f);

  // render: 24 views of 137 px do not fit in 30 KB; every camera file written has its image.
  r = run_on_full_disk(dir / "render", 30, "render " + mesh + " -o " + (dir / "render").string());
  INFO(r.err);
  check_clean_failure(r);
  int views = 0;
  for (const std::string& f : r.files)
    if (f.size() == 7 && f.substr(2) == ".json") {
      ++views;
      CHECK_MESSAGE(has(r.files, f.substr(0, 2) + ".png"), f);
    }
  CHECK(views < 24);

  // recon: the mesh does not fit in 4 KB; nothing half-written stays.
  const std::string image = (dir / "render_ok" / "00.png").string();
  REQUIRE(test::run_sdfkit("render " + mesh + " -o " + (dir / "render_ok").string() + " --views 1").code == 0);
  r = run_on_full_disk(dir / "recon", 4, "recon " + image + " -o " + (dir / "recon" / "m.obj").string() +
                                             " --res 33 --no-preview");
  INFO(r.err);
  check_clean_failure(r);
  CHECK(!has(r.files, "m.obj"));
  fs::remove_all(dir);
}

TEST_CASE("full disk: a training run that cannot write its checkpoint fails cleanly, leaving no model file") {
  const fs::path dir = test::scratch_dir("disk_full_train");
  write_mesh((dir / "in" / "c" / "box.obj").string(), make_box(Vec3(-1, -0.5, -0.7), Vec3(1, 0.6, 0.8)));
  const fs::path data = dir / "data";
  const test::CliRun p = test::run_sdfkit("prep " + (dir / "in").string() + " -o " + data.string() +
                                          " --voxel 0.03 --band 0.14 --samples 800 --views 2");
  REQUIRE_MESSAGE(p.code == 0, p.err);
  write_text_atomic((data / "train.lst").string(), "c/box\n");
  const FullDiskRun r = run_on_full_disk(
      dir / "model", 16,
      "train sdf --data " + data.string() + " --split train --val-split '' --steps 2 --val-every 1 --batch 1 "
      "--points 64 --encoder 8,16 --global 32 --point-mlp 16 --decoder 16 -o " + (dir / "model" / "m.ckpt").string());
  INFO(r.err);
  check_clean_failure(r);
  CHECK(r.err.find("m.ckpt") != std::string::npos);
  CHECK(!has(r.files, "m.ckpt"));
  fs::remove_all(dir);
}
