#include "core/json.h"
#include "synth/benchmark.h"

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "synth/categories.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>
#include <unistd.h>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    path = fs::temp_directory_path() / ("sdfkit_synth_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

/// Every regular file under `root` (relative path -> bytes).
std::map<std::string, std::string> snapshot(const fs::path& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) out[fs::relative(e.path(), root).string()] = read_file(e.path().string());
  return out;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string l;
  while (std::getline(ss, l)) out.push_back(l);
  return out;
}

}  // namespace

TEST_CASE("splits are 80/10/10, disjoint, complete and seeded") {
  const Split s = split_indices(100, 7, 4);
  CHECK(s.train.size() == 80);
  CHECK(s.val.size() == 10);
  CHECK(s.test.size() == 10);
  std::set<int> all(s.train.begin(), s.train.end());
  all.insert(s.val.begin(), s.val.end());
  all.insert(s.test.begin(), s.test.end());
  CHECK(all.size() == 100);
  CHECK(*all.begin() == 0);
  CHECK(*all.rbegin() == 99);
  CHECK(std::is_sorted(s.val.begin(), s.val.end()));
  const Split again = split_indices(100, 7, 4);
  CHECK(again.test == s.test);
  CHECK(split_indices(100, 8, 4).test != s.test);  // seed matters
  CHECK(split_indices(100, 7, 5).test != s.test);  // so does the category
  const Split small = split_indices(3, 1, 0);
  CHECK(small.train.size() == 1);
  CHECK(small.val.size() == 1);
  CHECK(small.test.size() == 1);
  CHECK(split_indices(2, 1, 0).test.size() == 1);
  CHECK(split_indices(1, 1, 0).train.size() == 1);
}

TEST_CASE("split_base: a larger training set keeps the val and test shapes of the smaller benchmark") {
  SynthSettings small;
  small.per_category = 20;
  small.seed = 3;
  SynthSettings big = small;
  big.per_category = 60;
  big.split_base = 20;
  for (size_t c : {size_t(0), size_t(6)}) {
    const Split a = category_split(small, c), b = category_split(big, c);
    CHECK(b.test == a.test);
    CHECK(b.val == a.val);
    REQUIRE(b.train.size() == a.train.size() + 40);
    CHECK(std::equal(a.train.begin(), a.train.end(), b.train.begin()));
    for (int i = 0; i < 40; ++i) CHECK(b.train[a.train.size() + i] == 20 + i);
    // Without a base, the 60 shapes are split afresh: the test shapes are not those of the 20-shape benchmark.
    SynthSettings fresh = big;
    fresh.split_base = 0;
    CHECK(category_split(fresh, c).test.size() == 6);
  }
  big.split_base = 61;
  CHECK_THROWS_AS(plan_benchmark(big), sdfkit::InvalidInput);
}

TEST_CASE("plans: ids, per-shape seeds independent of the benchmark size") {
  SynthSettings s;
  s.per_category = 2;
  s.seed = 5;
  s.categories = {"03001627", "plane", "chair"};
  const auto plan = plan_benchmark(s);
  REQUIRE(plan.size() == 4);
  CHECK(plan[0].id == "plane_0000");
  CHECK(plan[2].id == "chair_0000");
  CHECK(plan[3].id == "chair_0001");
  s.per_category = 50;
  s.categories = {};
  const auto big = plan_benchmark(s);
  CHECK(big.size() == 13 * 50);
  CHECK(big[4 * 50 + 1].id == "chair_0001");
  CHECK(big[4 * 50 + 1].seed == plan[3].seed);
  s.categories = {"unicorn"};
  CHECK_THROWS_AS(plan_benchmark(s), sdfkit::InvalidInput);
  s.categories = {};
  s.per_category = 0;
  CHECK_THROWS_AS(plan_benchmark(s), sdfkit::InvalidInput);
}

TEST_CASE("write_benchmark: files, lists, categories.json, coloured PLYs that read back") {
  TempDir dir("files");
  SynthSettings s;
  s.per_category = 3;
  s.seed = 11;
  s.categories = {"chair", "lamp"};
  const SynthSummary sum = write_benchmark(dir.path.string(), s);
  CHECK(sum.shapes == 6);
  CHECK(sum.faces > 0);
  const Json j = read_json((dir.path / "categories.json").string());
  REQUIRE(j["categories"].size() == 2);
  CHECK(j["categories"][0]["name"] == "chair");
  CHECK(j["categories"][0]["synset"] == "03001627");
  CHECK(j["categories"][0]["count"] == 3);
  CHECK(j["seed"] == 11);
  std::set<std::string> listed;
  for (const char* list : {"train.lst", "val.lst", "test.lst"}) {
    const auto ls = lines(read_file((dir.path / list).string()));
    CHECK(ls.size() == 2);  // one chair and one lamp each for 3 shapes per category
    for (const auto& l : ls) {
      CHECK(listed.insert(l).second);
      CHECK(fs::is_regular_file(dir.path / (l + ".ply")));
    }
  }
  CHECK(listed.size() == 6);
  // The binary PLY keeps the per-part colours and every face.
  const SynthShape shape = generate_shape(category_index("chair"), shape_seed(11, category_index("chair"), 1));
  MeshReport report;
  const Mesh m = read_mesh((dir.path / "chair" / "chair_0001.ply").string(), &report);
  CHECK(m.has_colors());
  CHECK(m.F.rows() == shape.mesh.F.rows());
  CHECK(report.degenerate_faces == 0);
  CHECK(report.duplicate_faces == 0);
  std::set<std::array<int, 3>> written, expected;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    written.insert({int(m.colors(v, 0) * 255 + 0.5f), int(m.colors(v, 1) * 255 + 0.5f), int(m.colors(v, 2) * 255 + 0.5f)});
  for (Eigen::Index v = 0; v < shape.mesh.V.rows(); ++v)
    expected.insert({int(shape.mesh.colors(v, 0) * 255 + 0.5f), int(shape.mesh.colors(v, 1) * 255 + 0.5f),
                     int(shape.mesh.colors(v, 2) * 255 + 0.5f)});
  CHECK(written == expected);
  CHECK((m.V.colwise().maxCoeff() - shape.mesh.V.colwise().maxCoeff()).cwiseAbs().maxCoeff() < 1e-6);
}

TEST_CASE("write_benchmark is byte-identical for a seed, whatever the thread count") {
  TempDir a("a"), b("b"), c("c");
  SynthSettings s;
  s.per_category = 2;
  s.seed = 3;
  s.jobs = 1;
  write_benchmark(a.path.string(), s);
  s.jobs = 2;
  write_benchmark(b.path.string(), s);
  const auto sa = snapshot(a.path), sb = snapshot(b.path);
  CHECK(sa.size() == 13 * 2 + 4);
  CHECK(sa == sb);
  s.seed = 4;
  write_benchmark(c.path.string(), s);
  const auto sc = snapshot(c.path);
  int same = 0;
  for (const auto& [k, v] : sa)
    if (k.size() > 4 && k.substr(k.size() - 4) == ".ply") same += sc.at(k) == v;
  CHECK(same == 0);  // a different seed changes every shape
}

TEST_CASE("rewriting a smaller benchmark removes the earlier run's extra shapes, foreign folders are refused") {
  TempDir dir("stale");
  SynthSettings s;
  s.per_category = 4;
  s.categories = {"phone"};
  write_benchmark(dir.path.string(), s);
  CHECK(fs::exists(dir.path / "phone" / "phone_0003.ply"));
  fs::create_directories(dir.path / "notes");
  write_text_atomic((dir.path / "phone" / "readme.txt").string(), "kept");
  s.per_category = 2;
  const SynthSummary sum = write_benchmark(dir.path.string(), s);
  CHECK(sum.removed_stale == 2);
  CHECK(!fs::exists(dir.path / "phone" / "phone_0003.ply"));
  CHECK(fs::exists(dir.path / "phone" / "phone_0001.ply"));
  CHECK(fs::exists(dir.path / "phone" / "readme.txt"));

  TempDir foreign("foreign");
  fs::create_directories(foreign.path);
  write_text_atomic((foreign.path / "thesis.tex").string(), "x");
  CHECK_THROWS_AS(write_benchmark(foreign.path.string(), s), sdfkit::InvalidInput);
  CHECK(fs::exists(foreign.path / "thesis.tex"));
}

TEST_CASE("sdfkit synth: exit codes and a usable folder") {
  TempDir dir("cli");
  const std::string exe = SDFKIT_EXE;
  const std::string ok = exe + " synth -o " + dir.path.string() + " -n 1 --categories chair,04379243 --seed 2 > /dev/null";
  REQUIRE(std::system(ok.c_str()) == 0);
  CHECK(fs::exists(dir.path / "table" / "table_0000.ply"));
  CHECK(fs::exists(dir.path / "chair" / "chair_0000.ply"));
  CHECK(fs::exists(dir.path / "train.lst"));
  const std::string bad = exe + " synth -o " + dir.path.string() + " --categories giraffe 2> /dev/null";
  const int rc = std::system(bad.c_str());
  CHECK(WEXITSTATUS(rc) == 1);
}
