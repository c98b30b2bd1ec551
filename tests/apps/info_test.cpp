// CLI-level tests of `sdfkit info`: validation findings in text and JSON, --up.
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
// A closed tetrahedron (outward faces), as OBJ text; `faces` picks which of its 4 faces to write (open when < 4),
// `flip_first` reverses the first face (inconsistent orientation), `scale_z` stretches it along z.
std::string tetra_obj(int faces = 4, bool flip_first = false, double scale_z = 1.0) {
  std::string s = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 " + std::to_string(scale_z) + "\n";
  const char* f[4] = {"f 1 3 2\n", "f 1 2 4\n", "f 1 4 3\n", "f 2 3 4\n"};
  for (int i = 0; i < faces; ++i) s += (i == 0 && flip_first) ? "f 1 2 3\n" : f[i];
  return s;
}
}  // namespace

TEST_CASE("sdfkit info: closed, open and mis-oriented meshes, components, in text and JSON, --up") {
  const fs::path dir = test::scratch_dir("info_cli");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string closed = (dir / "closed.obj").string(), open = (dir / "open.obj").string(),
                    flipped = (dir / "flipped.obj").string(), two = (dir / "two.obj").string();
  write_text_atomic(closed, tetra_obj());
  write_text_atomic(open, tetra_obj(3));
  write_text_atomic(flipped, tetra_obj(4, true));
  std::string pair = tetra_obj();
  pair += "v 5 0 0\nv 6 0 0\nv 5 1 0\nv 5 0 1\nf 5 7 6\nf 5 6 8\nf 5 8 7\nf 6 7 8\n";
  write_text_atomic(two, pair);
  const test::CliRun r = test::run_sdfkit("info " + closed + " " + open + " " + flipped + " " + two + " --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  REQUIRE(j.size() == 4);
  CHECK(j[0]["validation"]["closed_and_oriented"].get<bool>());
  CHECK(j[0]["validation"]["components"].get<long>() == 1);
  CHECK(j[0]["validation"]["inside_out_components"].get<long>() == 0);
  CHECK_FALSE(j[1]["validation"]["closed_and_oriented"].get<bool>());
  CHECK_FALSE(j[1]["validation"]["closed_after_orienting"].get<bool>());
  CHECK_FALSE(j[2]["validation"]["closed_and_oriented"].get<bool>());
  CHECK(j[2]["validation"]["closed_after_orienting"].get<bool>());
  CHECK(j[2]["validation"]["faces_to_flip"].get<long>() >= 1);
  CHECK(j[3]["validation"]["components"].get<long>() == 2);
  CHECK(j[3]["validation"]["closed_components"].get<long>() == 2);
  const test::CliRun text = test::run_sdfkit("info " + open);
  REQUIRE(text.code == 0);
  CHECK(text.out.find("validation: open") != std::string::npos);
  // --up z: the file's z extent (3) becomes the height.
  write_text_atomic((dir / "tall.obj").string(), tetra_obj(4, false, 3.0));
  const test::CliRun up = test::run_sdfkit("info " + (dir / "tall.obj").string() + " --up z --json");
  REQUIRE(up.code == 0);
  const Json u = Json::parse(up.out);
  CHECK(u[0]["bbox_max"][1].get<double>() == doctest::Approx(3.0));
  CHECK(u[0]["bbox_min"][2].get<double>() == doctest::Approx(-1.0));
  const test::CliRun bad = test::run_sdfkit("info " + closed + " --up w");
  CHECK(bad.code == 1);
}

// Issue 79: a folder named like a mesh was "no such file", and assimp's own words reached the user bare.
TEST_CASE("sdfkit info and render: a folder named like a mesh is called a folder, assimp's reasons name the file") {
  const fs::path dir = test::scratch_dir("info_cli") / "folder_named_obj";
  fs::remove_all(dir);
  fs::create_directories(dir / "shape.obj");
  for (const std::string& cmd : {"info " + (dir / "shape.obj").string(),
                                 "render " + (dir / "shape.obj").string() + " -o " + (dir / "views").string()}) {
    CAPTURE(cmd);
    const test::CliRun r = test::run_sdfkit(cmd);
    CHECK(r.code == 1);
    CHECK(r.err == "sdfkit: error: " + (dir / "shape.obj").string() + ": is a folder, not a mesh file\n");
  }
  CHECK(!fs::exists(dir / "views"));
  test::CliRun r = test::run_sdfkit("info " + (dir / "absent.obj").string());
  CHECK(r.code == 1);
  CHECK(r.err.find("absent.obj: no such file") != std::string::npos);
  // An OBJ too short for assimp (one vertex line passes sdfkit's checks): sdfkit's words, the file, assimp's reason.
  const std::string small = (dir / "small.obj").string();
  write_text_atomic(small, "v 0 0 0\n");
  r = test::run_sdfkit("info " + small);
  CHECK(r.code == 1);
  CHECK(r.err == "sdfkit: error: " + small + ": cannot read mesh: OBJ-file is too small.\n");
}
