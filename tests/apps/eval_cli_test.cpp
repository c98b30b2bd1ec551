// CLI-level tests of `sdfkit eval`: runs the built executable on meshes and dataset folders written by the test,
// checks the scores against closed forms (two concentric spheres), the exit codes (0 / 1 / 2), and parses the
// --json, --csv and -o outputs back.
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

using Run = test::CliRun;

fs::path scratch() { return test::scratch_dir("eval_cli"); }

Run run(const std::string& args) { return test::run_sdfkit(args); }

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::string cur;
  std::istringstream in(s);
  while (std::getline(in, cur, sep)) parts.push_back(cur);
  if (!s.empty() && s.back() == sep) parts.emplace_back();
  return parts;
}

std::vector<std::string> lines(const std::string& s) {
  std::vector<std::string> out;
  for (auto& l : split(s, '\n'))
    if (!l.empty()) out.push_back(l);
  return out;
}

constexpr double kR1 = 0.5, kR2 = 0.55;  // prediction and ground-truth radii

// A fine UV sphere: its volume and surface are within 0.2% of the ideal sphere's.
void write_spheres(const fs::path& pred, const fs::path& gt) {
  write_mesh(pred.string(), make_sphere(Vec3::Zero(), kR1, 64, 128));
  write_mesh(gt.string(), make_sphere(Vec3::Zero(), kR2, 64, 128));
}

}  // namespace

TEST_CASE("eval of a sphere against a larger sphere, onet: CD and IoU against closed forms") {
  const fs::path dir = scratch() / "pair";
  fs::create_directories(dir);
  const fs::path pred = dir / "pred.obj", gt = dir / "gt.ply";
  write_spheres(pred, gt);

  // onet (30k points instead of 100k, to keep the test short): every pred -> gt and gt -> pred distance is at
  // least r2 - r1 and, at a sample spacing of ~0.01, at most a few percent above it on average; point IoU =
  // (r1/r2)^3 (winding numbers; sampling noise ~0.5% at 30k points).
  Run r = run("eval " + pred.string() + " " + gt.string() + " --protocol onet --seed 3 --samples 30000 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json onet = Json::parse(r.out);
  CHECK(onet["protocol"] == "onet");
  CHECK(onet["seed"] == 3);
  const double gap = kR2 - kR1;
  const Json& m = onet["metrics"];
  CHECK(m["accuracy"].get<double>() >= gap * (1 - 1e-3));
  CHECK(m["accuracy"].get<double>() == doctest::Approx(gap).epsilon(0.02));
  CHECK(m["completeness"].get<double>() == doctest::Approx(gap).epsilon(0.02));
  CHECK(m["cd_l1"].get<double>() == doctest::Approx(gap).epsilon(0.02));
  CHECK(m["cd_l2"].get<double>() == doctest::Approx(gap * gap).epsilon(0.04));
  CHECK(m["iou"].get<double>() == doctest::Approx(std::pow(kR1 / kR2, 3)).epsilon(0.015));
  CHECK(m["normal_consistency"].get<double>() > 0.99);
}

TEST_CASE("eval of a sphere against a larger sphere, disn and tmnet: IoU and EMD bounds, JSON, CSV and -o agree") {
  const fs::path dir = scratch() / "pair";
  fs::create_directories(dir);
  const fs::path pred = dir / "pred.obj", gt = dir / "gt.ply";
  write_spheres(pred, gt);
  const double gap = kR2 - kR1;
  Run r;

  // disn: voxel IoU (in %) of the two solids; surface cells count as solid, which adds about half a cell
  // (2.4/110/2) to each radius. EMD (sum x 0.01) is at least 2048 x (r2 - r1) x 0.01, since every matched pair
  // is at least r2 - r1 apart. CD (x1000) is at least 2 x (r2 - r1)^2 x 1000 for the same reason.
  r = run("eval " + pred.string() + " " + gt.string() + " --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json disn = Json::parse(r.out);
  CHECK(disn["protocol"] == "disn");
  CHECK(disn["emd_method"] == "exact");
  const Json& d = disn["metrics"];
  const double half_cell = 2.4 / 110 / 2;
  CHECK(d["iou"].get<double>() ==
        doctest::Approx(100 * std::pow((kR1 + half_cell) / (kR2 + half_cell), 3)).epsilon(0.02));
  CHECK(d["emd"].get<double>() >= 2048 * gap * 0.01 * (1 - 1e-9));
  CHECK(d["emd"].get<double>() < 2048 * 2 * gap * 0.01);
  CHECK(d["cd"].get<double>() >= 2 * gap * gap * 1000 * (1 - 1e-9));
  // F-score: nothing is closer than r2 - r1 = 0.05 = 2% of 2.5, everything closer than 20% (0.5)
  CHECK(d["f_1"].get<double>() == 0.0);
  CHECK(d["f_20"].get<double>() == 100.0);

  // --csv: one header and one row, the same numbers as --json for the same seed
  r = run("eval " + pred.string() + " " + gt.string() + " --csv");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const auto rows = lines(r.out);
  REQUIRE(rows.size() == 2);
  const auto header = split(rows[0], ','), values = split(rows[1], ',');
  REQUIRE(header.size() == values.size());
  CHECK(header[0] == "pred");
  CHECK(header[2] == "protocol");
  CHECK(values[2] == "disn");
  std::map<std::string, std::string> csv;
  for (size_t i = 0; i < header.size(); ++i) csv[header[i]] = values[i];
  for (const char* key : {"cd", "emd", "iou", "f_1", "f_5", "p_5", "r_5"})
    CHECK(std::stod(csv.at(key)) == doctest::Approx(d[key].get<double>()).epsilon(1e-8));

  // -o FILE: the same JSON, written atomically
  const fs::path out = dir / "result.json";
  r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --json -o " + out.string());
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(r.out.empty());
  const Json tm = read_json(out.string());
  CHECK(tm["protocol"] == "tmnet");
  CHECK(tm["metrics"]["emd"].get<double>() >= gap * 100 * (1 - 1e-9));  // mean matched distance x 100
}

TEST_CASE("eval of two dataset folders: a missing prediction is reported (exit 2), the others are scored") {
  const fs::path root = scratch() / "folders";
  fs::remove_all(root);
  const fs::path gt = root / "gt", pred = root / "pred";
  // gt: chair/a, chair/b, table/c; predictions for chair/a and table/c only
  for (const char* s : {"chair/a", "chair/b", "table/c"}) fs::create_directories(gt / s);
  fs::create_directories(pred / "chair");
  fs::create_directories(pred / "table");
  write_mesh((gt / "chair/a/gt.obj").string(), make_sphere(Vec3::Zero(), kR2, 24, 48));
  write_mesh((gt / "chair/b/gt.obj").string(), make_sphere(Vec3::Zero(), kR2, 24, 48));
  write_mesh((gt / "table/c/gt.obj").string(), make_torus(Vec3::Zero(), 0.6, 0.25, 48, 24));
  write_mesh((pred / "chair/a.obj").string(), make_sphere(Vec3::Zero(), kR1, 24, 48));
  write_mesh((pred / "table/c.ply").string(), make_torus(Vec3::Zero(), 0.6, 0.25, 40, 20));

  const fs::path out = root / "report";
  Run r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --json --jobs 2 -o " + out.string());
  CHECK(r.code == 2);
  CHECK(r.err.find("missing") != std::string::npos);
  CHECK(r.err.find("chair/b") != std::string::npos);
  const Json s = Json::parse(r.out);
  CHECK(s["protocol"] == "tmnet");
  CHECK(s["categories"]["chair"]["total"] == 2);
  CHECK(s["categories"]["chair"]["ok"] == 1);
  CHECK(s["categories"]["chair"]["missing"] == 1);
  CHECK(s["categories"]["table"]["ok"] == 1);
  CHECK(s["mean"]["missing"] == 1);
  REQUIRE(s["problems"].size() == 1);
  CHECK(s["problems"][0]["shape"] == "b");
  CHECK(s["problems"][0]["status"] == "missing");
  // the scored chair is the sphere pair: CD x1000 >= 2 (r2 - r1)^2 x 1000
  CHECK(s["categories"]["chair"]["metrics"]["cd"].get<double>() >= 2 * 0.05 * 0.05 * 1000 * (1 - 1e-9));
  // the table is a torus against a re-tessellation of the same torus: closer than the spheres (its CD is
  // the sampling spacing of 2048 points, the spheres add their 0.05 gap)
  CHECK(s["categories"]["table"]["metrics"]["cd"].get<double>() <
        s["categories"]["chair"]["metrics"]["cd"].get<double>() / 2);

  // -o DIR: per-shape CSV with every shape and its status, the Markdown table, the JSON summary
  const auto rows = lines(read_file((out / "per_shape.csv").string()));
  REQUIRE(rows.size() == 4);
  CHECK(rows[0].rfind("category,shape,status", 0) == 0);
  std::map<std::string, std::string> status;
  for (size_t i = 1; i < rows.size(); ++i) {
    const auto f = split(rows[i], ',');
    status[f[0] + "/" + f[1]] = f[2];
  }
  CHECK(status["chair/a"] == "ok");
  CHECK(status["chair/b"] == "missing");
  CHECK(status["table/c"] == "ok");
  CHECK(read_file((out / "table.md").string()).find("chair") != std::string::npos);
  CHECK(read_json((out / "summary.json").string())["mean"]["ok"] == 2);

  // --csv prints the per-shape rows; with every prediction present the exit code is 0
  write_mesh((pred / "chair/b.obj").string(), make_sphere(Vec3::Zero(), kR1, 24, 48));
  r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --csv");
  CHECK_MESSAGE(r.code == 0, r.err);
  CHECK(lines(r.out).size() == 4);
  CHECK(r.out.find("missing") == std::string::npos);
}

TEST_CASE("eval refuses bad input with one line naming the file (exit 1)") {
  const fs::path dir = scratch() / "bad";
  fs::create_directories(dir);
  const fs::path good = dir / "good.obj", bad = dir / "broken.obj", nan = dir / "nan.xyz";
  write_mesh(good.string(), make_sphere(Vec3::Zero(), kR1, 16, 32));
  write_text_atomic(bad.string(), "v 0 0 0\nv 1 0 0\nf 1 2 7\n");  // face index out of range
  write_text_atomic(nan.string(), "0 0 0\n1 nan 0\n0 1 0\n");

  Run r = run("eval " + bad.string() + " " + good.string());
  CHECK(r.code == 1);
  CHECK(r.err.find("broken.obj") != std::string::npos);
  CHECK(lines(r.err).size() == 1);

  r = run("eval " + nan.string() + " " + good.string());
  CHECK(r.code == 1);
  CHECK(r.err.find("nan.xyz") != std::string::npos);

  r = run("eval " + (dir / "absent.obj").string() + " " + good.string());
  CHECK(r.code == 1);
  CHECK(r.err.find("absent.obj") != std::string::npos);

  r = run("eval " + good.string() + " " + good.string() + " --protocol nope");
  CHECK(r.code == 1);

  // Flags that do not apply are errors, not silently ignored.
  const std::vector<std::pair<std::string, std::string>> na = {
      {" --protocol onet --emd approx", "--emd does not apply to --protocol onet"},
      {" --protocol onet --no-emd", "--no-emd does not apply"},
      {" --protocol tmnet --no-iou", "--no-iou does not apply to --protocol tmnet"},
      {" --split test", "--split applies to folders"},
      {" --jobs 2", "--jobs applies to folders"},
  };
  for (const auto& item : na) {
    const auto& flags = item.first;
    const auto& message = item.second;
    CAPTURE(flags);
    r = run("eval " + good.string() + " " + good.string() + flags);
    CHECK(r.code == 1);
    CHECK(r.err.find(message) != std::string::npos);
  }
}

TEST_CASE("eval of folders with --split: only the listed shapes are scored, a listed shape without GT is reported") {
  const fs::path root = scratch() / "split";
  fs::remove_all(root);
  const fs::path gt = root / "gt", pred = root / "pred";
  for (const char* s : {"chair/a", "chair/b", "table/c"}) fs::create_directories(gt / s);
  fs::create_directories(pred / "chair");
  for (const char* s : {"chair/a", "chair/b", "table/c"})
    write_mesh((gt / s / "gt.obj").string(), make_sphere(Vec3::Zero(), kR2, 16, 32));
  write_mesh((pred / "chair/a.obj").string(), make_sphere(Vec3::Zero(), kR1, 16, 32));
  {
    std::ofstream((gt / "test.lst").string()) << "chair/a\n";
    std::ofstream((root / "bad.lst").string()) << "chair/a\ntable/zzz\n";
  }
  // Only chair/a is in the split: nothing is missing, exit 0.
  Run r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --json --split test");
  CHECK_MESSAGE(r.code == 0, r.err);
  Json s = Json::parse(r.out);
  CHECK(s["mean"]["total"] == 1);
  CHECK(s["mean"]["ok"] == 1);
  CHECK(s["mean"]["missing"] == 0);
  // A list file naming a shape without ground truth: reported as failed (exit 2), with the path in the reason.
  r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --json --split " + (root / "bad.lst").string());
  CHECK(r.code == 2);
  s = Json::parse(r.out);
  CHECK(s["mean"]["total"] == 2);
  CHECK(s["mean"]["ok"] == 1);
  CHECK(r.err.find("zzz") != std::string::npos);
  // An unknown split name is a user error.
  r = run("eval " + pred.string() + " " + gt.string() + " --split nosuch");
  CHECK(r.code == 1);
  CHECK(r.err.find("nosuch") != std::string::npos);
}

TEST_CASE("eval of two 2048-point clouds under tmnet scores the points as given, and says so") {
  // Closed form as in tests/metrics/protocols_test.cpp: 2048 points 1 apart and their copies 0.1 away: CD x1000 =
  // 20 exactly, EMD mean x100 = 10. Drawn with replacement, the same clouds would score CD about 1100.
  const fs::path dir = scratch() / "clouds";
  fs::create_directories(dir);
  std::string a, b, big;
  for (int i = 0; i < 2048; ++i) {
    a += std::to_string(i) + " 0 0\n";
    b += std::to_string(i) + " 0.1 0\n";
  }
  for (int i = 0; i < 3000; ++i) big += std::to_string(i) + " 0 0.5\n";
  write_text_atomic((dir / "a.xyz").string(), a);
  write_text_atomic((dir / "b.xyz").string(), b);
  write_text_atomic((dir / "big.xyz").string(), big);
  Run r = run("eval " + (dir / "a.xyz").string() + " " + (dir / "b.xyz").string() + " --protocol tmnet --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  Json j = Json::parse(r.out);
  CHECK(j["metrics"]["cd"].get<double>() == doctest::Approx(20.0).epsilon(1e-9));
  CHECK(j["metrics"]["emd"].get<double>() == doctest::Approx(10.0).epsilon(1e-9));
  CHECK(j["sampling"]["prediction"] == "as_given");
  CHECK(j["sampling"]["ground_truth"] == "as_given");
  // A larger cloud is subsampled without replacement; the text output names the choice too.
  r = run("eval " + (dir / "big.xyz").string() + " " + (dir / "b.xyz").string() + " --protocol tmnet --no-emd");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(r.out.find("points: prediction subsampled, ground truth as_given") != std::string::npos);
}

TEST_CASE("eval of folders: only prediction files count as extra predictions, not recon's preview images") {
  const fs::path root = scratch() / "extra";
  fs::remove_all(root);
  const fs::path gt = root / "gt", pred = root / "pred";
  write_mesh((gt / "chair" / "a" / "gt.obj").string(), make_sphere(Vec3::Zero(), kR2, 24, 48));
  write_mesh((pred / "chair" / "a.obj").string(), make_sphere(Vec3::Zero(), kR1, 24, 48));
  write_text_atomic((pred / "chair" / "a.preview.png").string(), "not a mesh");  // as sdfkit recon writes
  write_mesh((pred / "chair" / "z.obj").string(), make_sphere(Vec3::Zero(), kR1, 24, 48));  // no ground truth
  const Run r = run("eval " + pred.string() + " " + gt.string() + " --protocol tmnet --no-emd --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(Json::parse(r.out)["extra_predictions"] == 1);
  CHECK(r.err.find("1 prediction file(s) have no ground truth") != std::string::npos);
}
