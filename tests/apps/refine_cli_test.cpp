// CLI-level tests of `sdfkit refine`: a view set made by `render --mesh-out`, the outputs beside the mesh, the JSON
// summary, `eval` of the result against the rendered mesh, and one-line errors.
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A fresh scratch folder `tag` holding box.obj (1.4 x 0.8 x 1.0) and its view set: `render --views 8 --size SIZE
/// --elevation -20 50` into views/, the rendered mesh as gt.obj.
fs::path box_view_set(const std::string& tag, int size) {
  const fs::path dir = test::scratch_dir(tag);
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_text_atomic((dir / "box.obj").string(),
                    "v -0.7 -0.4 -0.5\nv 0.7 -0.4 -0.5\nv 0.7 0.4 -0.5\nv -0.7 0.4 -0.5\n"
                    "v -0.7 -0.4 0.5\nv 0.7 -0.4 0.5\nv 0.7 0.4 0.5\nv -0.7 0.4 0.5\n"
                    "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n"
                    "f 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n");
  const test::CliRun r = test::run_sdfkit("render " + (dir / "box.obj").string() + " -o " + (dir / "views").string() +
                                          " --views 8 --size " + std::to_string(size) +
                                          " --elevation -20 50 --mesh-out " + (dir / "gt.obj").string());
  REQUIRE_MESSAGE(r.code == 0, r.err);
  REQUIRE(fs::exists(dir / "gt.obj"));
  return dir;
}

}  // namespace

TEST_CASE("sdfkit refine: a sphere fitted to a rendered box, files beside the mesh, scored by eval") {
  const fs::path dir = box_view_set("refine_cli", 40);
  const std::string views = (dir / "views").string(), gt = (dir / "gt.obj").string();
  const std::string out = (dir / "out" / "box.ply").string();
  test::CliRun r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 120 --sphere-level 2 --views-per-step 3 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  CHECK(j.at("steps") == 120);
  CHECK(j.at("vertices") == 162);
  CHECK(j.at("seconds_per_step").get<double>() > 0);
  CHECK(j.at("loss").at("silhouette").get<double>() < 0.05);
  // From a sphere the exact silhouette takes over after three quarters of the steps.
  CHECK(j.at("exact_silhouette") == 3);
  CHECK(j.at("exact_after") == 90);
  CHECK(j.at("rgb_moves_vertices") == false);  // the colour term fits the colours only
  for (const char* f : {"box.ply", "box.loss.csv", "box.loss.svg", "box.preview.png"})
    CHECK_MESSAGE(fs::exists(dir / "out" / f), f);
  // 12 rows (every 10 steps) under the header.
  const std::string csv = read_file((dir / "out" / "box.loss.csv").string());
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 13);
  r = test::run_sdfkit("eval " + out + " " + gt + " --json --no-emd");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("metrics").at("iou").get<double>() > 70);
  // The same command gives the same bytes.
  const std::string first = read_file(out);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 120 --sphere-level 2 --views-per-step 3");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(read_file(out) == first);

  // Errors: one line, non-zero exit, naming the problem.
  r = test::run_sdfkit("refine " + views + " -o " + (dir / "x.txt").string());
  CHECK(r.code != 0);
  CHECK(r.err.find("x.txt: give a mesh path ending in .obj, .ply, .off, .stl or .glb") != std::string::npos);
  r = test::run_sdfkit("refine " + (dir / "nothing").string() + " -o " + out);
  CHECK(r.code != 0);
  CHECK(r.err.find("nothing: not a folder of views") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --init " + (dir / "missing.obj").string());
  CHECK(r.code != 0);
  CHECK(r.err.find("missing.obj") != std::string::npos);
  r = test::run_sdfkit("render " + (dir / "box.obj").string() + " -o " + views + " --mesh-out " + (dir / "g.xyz").string());
  CHECK(r.code != 0);
  CHECK(r.err.find("g.xyz: give a mesh path") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("sdfkit refine --carve: the starting sphere cut to the views' visual hull, reported in the JSON") {
  const fs::path dir = box_view_set("refine_cli_carve", 48);
  const std::string views = (dir / "views").string(), gt = (dir / "gt.obj").string();
  const std::string out = (dir / "carved.obj").string();
  test::CliRun r = test::run_sdfkit("refine " + views + " -o " + out +
                       " --carve --carve-res 41 --iters 10 --views-per-step 2 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  const Json& c = j.at("carve");
  CHECK(c.at("resolution") == 41);
  // The box (volume 1.31 after `render`'s unit-sphere normalisation) is far smaller than the radius-1 sphere (4.19).
  CHECK(c.at("init_volume").get<double>() == doctest::Approx(4.19).epsilon(0.02));
  CHECK(c.at("volume").get<double>() < 0.5 * c.at("init_volume").get<double>());
  CHECK(j.at("vertices") == c.at("vertices"));
  CHECK(j.at("exact_after") == 5);  // from the sphere cut to the hull: the exact error over the last half
  CHECK(j.at("weights").at("edge") == 0.1);
  r = test::run_sdfkit("eval " + out + " " + gt + " --json --no-emd");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("metrics").at("iou").get<double>() > 75);
  // --iters 0: the carved mesh itself (the visual hull), no step taken.
  r = test::run_sdfkit("refine " + views + " -o " + (dir / "hull.obj").string() +
                       " --carve --carve-res 41 --iters 0 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json h = Json::parse(r.out);
  CHECK(h.at("steps") == 0);
  CHECK(h.at("faces") == h.at("carve").at("faces"));
  CHECK(h.at("carve").at("volume") == c.at("volume"));
  CHECK(h.at("carve").at("complete") == false);
  // --carve-complete: a small sphere inside the box leaves most of every silhouette unexplained; the hull points
  // that a majority of the views see on those pixels join it.
  r = test::run_sdfkit("refine " + views + " -o " + (dir / "completed.obj").string() +
                       " --sphere-radius 0.2 --carve --carve-complete --carve-res 41 --iters 0 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json k = Json::parse(r.out).at("carve");
  CHECK(k.at("complete") == true);
  CHECK(k.at("unexplained_pixels").get<long>() > 100);
  CHECK(k.at("carved_volume").get<double>() < 0.05);  // the sphere of radius 0.2: 0.034
  CHECK(k.at("volume").get<double>() > 0.5 * h.at("carve").at("volume").get<double>());
  CHECK(k.at("volume").get<double>() <= h.at("carve").at("volume").get<double>() * 1.001);
  // Without --carve the JSON says so; --carve-res or --carve-complete alone is an error.
  r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 2 --sphere-level 1 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("carve").is_null());
  r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 4 --exact-after 3 --exact-silhouette 2 --sphere-level 1 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("exact_after") == 3);
  CHECK(Json::parse(r.out).at("exact_silhouette") == 2);
  r = test::run_sdfkit("refine " + views + " -o " + out +
                       " --carve --carve-res 41 --iters 4 --exact-after 3 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("exact_after") == 3);  // given, so kept with --carve too
  // Shading: from the exact silhouette's first step, one albedo by default; --albedo needs --lit.
  CHECK(Json::parse(r.out).at("lit") == false);
  CHECK(Json::parse(r.out).at("lit_from").is_null());
  r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 4 --lit --sphere-level 1 --preview 1 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("lit") == true);
  CHECK(Json::parse(r.out).at("lit_from") == 3);
  CHECK(Json::parse(r.out).at("albedo") == "uniform");
  r = test::run_sdfkit("refine " + views + " -o " + out + " --iters 4 --lit --albedo vertex --exact-silhouette 0 --sphere-level 1 --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("lit_from") == 0);
  CHECK(Json::parse(r.out).at("albedo") == "vertex");
  r = test::run_sdfkit("refine " + views + " -o " + out + " --albedo vertex");
  CHECK(r.code != 0);
  CHECK(r.err.find("--lit") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --lit --w-rgb 0");
  CHECK(r.code != 0);
  CHECK(r.err.find("RGB") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --exact-silhouette 9");
  CHECK(r.code != 0);
  CHECK(r.err.find("--exact-silhouette") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --carve-res 33");
  CHECK(r.code != 0);
  CHECK(r.err.find("--carve") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --carve-complete");
  CHECK(r.code != 0);
  CHECK(r.err.find("--carve") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("sdfkit refine --init MESH: small components of the starting mesh are dropped first, unless asked not to") {
  const fs::path dir = box_view_set("refine_cli_init", 32);
  const std::string views = (dir / "views").string();
  // The box (12 faces) plus a far tetrahedron (4 faces, a third of the box's): dropped at 0.5, kept at 0.
  const std::string init = (dir / "init.obj").string();
  write_text_atomic(init, read_file((dir / "box.obj").string()) +
                              "v 0.8 0.8 0.8\nv 0.85 0.8 0.8\nv 0.8 0.85 0.8\nv 0.8 0.8 0.85\n"
                              "f 9 11 10\nf 9 10 12\nf 9 12 11\nf 10 11 12\n");
  const std::string out = (dir / "out.obj").string();
  test::CliRun r = test::run_sdfkit("refine " + views + " -o " + out + " --init " + init +
                                    " --iters 2 --init-keep-fraction 0.5 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("init_components_removed") == 1);
  CHECK(Json::parse(r.out).at("vertices") == 8);
  CHECK(r.err.find("1 small components dropped") != std::string::npos);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --init " + init + " --iters 2 --init-keep-fraction 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("init_components_removed") == 0);
  // From a mesh file the paper's loss is the default: the soft silhouette throughout, regularisers 1, unless asked.
  CHECK(Json::parse(r.out).at("exact_silhouette") == 0);
  CHECK(Json::parse(r.out).at("exact_after").is_null());
  CHECK(Json::parse(r.out).at("weights").at("edge") == 1.0);
  CHECK(Json::parse(r.out).at("weights").at("laplacian") == 1.0);
  CHECK(Json::parse(r.out).at("rgb_moves_vertices") == true);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --init " + init +
                       " --iters 4 --exact-silhouette 3 --w-edge 0.1 --no-rgb-moves-vertices --preview 0 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out).at("exact_silhouette") == 3);
  CHECK(Json::parse(r.out).at("exact_after") == 3);
  CHECK(Json::parse(r.out).at("weights").at("edge") == 0.1);
  CHECK(Json::parse(r.out).at("weights").at("laplacian") == 1.0);
  CHECK(Json::parse(r.out).at("rgb_moves_vertices") == false);
  CHECK(Json::parse(r.out).at("vertices") == 12);
  r = test::run_sdfkit("refine " + views + " -o " + out + " --init " + init + " --init-keep-fraction 2");
  CHECK(r.code != 0);
  CHECK(r.err.find("--init-keep-fraction") != std::string::npos);
  fs::remove_all(dir);
}
