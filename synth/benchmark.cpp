#include "synth/benchmark.h"

#include "core/error.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "core/random.h"
#include "synth/categories.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <regex>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit {

uint64_t shape_seed(uint64_t seed, size_t category, int index) {
  return Rng::derived(seed, (static_cast<uint64_t>(category + 1) << 32) | static_cast<uint32_t>(index)).next();
}

std::string shape_id(size_t category, int index) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "_%04d", index);
  return categories().at(category).name + buf;
}

std::vector<PlannedShape> plan_benchmark(const SynthSettings& s) {
  require(s.per_category >= 1 && s.per_category <= 100000,
          "synth: --per-category must be between 1 and 100000 (got " + std::to_string(s.per_category) + ")");
  require(s.jobs >= 0, "synth: --jobs must be >= 0");
  require(s.split_base >= 0 && s.split_base <= s.per_category,
          "synth: --split-base must be between 0 and --per-category (got " + std::to_string(s.split_base) + ")");
  std::vector<size_t> cats;
  if (s.categories.empty()) {
    for (size_t c = 0; c < categories().size(); ++c) cats.push_back(c);
  } else {
    std::set<size_t> chosen;
    for (const auto& name : s.categories) chosen.insert(category_index(name));
    cats.assign(chosen.begin(), chosen.end());
  }
  std::vector<PlannedShape> out;
  for (const size_t c : cats)
    for (int i = 0; i < s.per_category; ++i) out.push_back({c, i, shape_id(c, i), shape_seed(s.seed, c, i)});
  return out;
}

Split split_indices(int n, uint64_t seed, size_t category) {
  require(n >= 0, "split_indices: n must be >= 0");
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  Rng rng = Rng::derived(seed ^ 0x5eed5b1175ULL, category);
  for (int i = n - 1; i > 0; --i) std::swap(order[i], order[rng.below(static_cast<uint64_t>(i + 1))]);
  int n_val = static_cast<int>(std::lround(0.1 * n)), n_test = n_val;
  if (n >= 3) {
    n_val = std::max(n_val, 1);
    n_test = std::max(n_test, 1);
  } else if (n == 2) {
    n_val = 0;
    n_test = 1;
  } else {
    n_val = n_test = 0;
  }
  Split s;
  s.test.assign(order.begin(), order.begin() + n_test);
  s.val.assign(order.begin() + n_test, order.begin() + n_test + n_val);
  s.train.assign(order.begin() + n_test + n_val, order.end());
  std::sort(s.train.begin(), s.train.end());
  std::sort(s.val.begin(), s.val.end());
  std::sort(s.test.begin(), s.test.end());
  return s;
}

Split category_split(const SynthSettings& settings, size_t category) {
  const int base = settings.split_base > 0 ? settings.split_base : settings.per_category;
  Split s = split_indices(base, settings.seed, category);
  for (int i = base; i < settings.per_category; ++i) s.train.push_back(i);
  return s;
}

namespace {

/// Refuse foreign non-empty folders; in an earlier synth output, list shape files not in `keep`.
std::vector<fs::path> stale_files(const fs::path& dir, const std::set<std::string>& keep) {
  std::vector<fs::path> stale;
  if (!fs::exists(dir)) return stale;
  if (!fs::is_directory(dir)) throw InvalidInput(dir.string() + ": exists and is not a folder");
  if (fs::is_empty(dir)) return stale;
  if (!fs::exists(dir / "categories.json"))
    throw InvalidInput(dir.string() +
                       ": folder is not empty and holds no categories.json (not a synth output); choose another -o");
  static const std::regex kShapeName(R"([a-z]+_[0-9]{4,}\.ply)");
  for (const auto& c : categories()) {
    const fs::path sub = dir / c.name;
    if (!fs::is_directory(sub)) continue;
    for (const auto& e : fs::directory_iterator(sub)) {
      const std::string name = e.path().filename().string();
      if (!e.is_regular_file() || !std::regex_match(name, kShapeName)) continue;
      if (!keep.count(c.name + "/" + name)) stale.push_back(e.path());
    }
  }
  std::sort(stale.begin(), stale.end());
  return stale;
}

}  // namespace

SynthSummary write_benchmark(const std::string& dir, const SynthSettings& settings, const ProgressFn& progress) {
  const std::vector<PlannedShape> plan = plan_benchmark(settings);
  const fs::path root(dir);
  std::set<std::string> keep;
  for (const auto& e : plan) keep.insert(categories()[e.category].name + "/" + e.id + ".ply");
  const std::vector<fs::path> stale = stale_files(root, keep);

  std::vector<long> faces(plan.size(), 0);
  FirstFailure errors;  // a failing shape's error: the first one in plan order, whatever the scheduling
  std::atomic<long> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;
  const int threads = settings.jobs > 0 ? settings.jobs : tbb::this_task_arena::max_concurrency();
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(size_t(0), plan.size(), [&](size_t i) {
      if (cancelled.load()) return;
      errors.run(i, [&] {
        const PlannedShape& e = plan[i];
        const SynthShape shape = generate_shape(e.category, e.seed);
        write_mesh((root / categories()[e.category].name / (e.id + ".ply")).string(), shape.mesh);
        faces[i] = static_cast<long>(shape.mesh.F.rows());
      });
      const long d = ++done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (!progress(static_cast<double>(d) / static_cast<double>(plan.size()))) cancelled = true;
      }
    });
  });
  errors.rethrow();
  if (cancelled) throw Error("synth: cancelled");

  // Lists and categories.json (written after the meshes: a folder with categories.json is complete).
  std::vector<size_t> cats;
  for (const auto& e : plan)
    if (cats.empty() || cats.back() != e.category) cats.push_back(e.category);
  std::ostringstream train, val, test;
  Json jc = Json::array();
  for (const size_t c : cats) {
    const Split s = category_split(settings, c);
    const std::string& name = categories()[c].name;
    for (const int i : s.train) train << name << '/' << shape_id(c, i) << '\n';
    for (const int i : s.val) val << name << '/' << shape_id(c, i) << '\n';
    for (const int i : s.test) test << name << '/' << shape_id(c, i) << '\n';
    jc.push_back({{"synset", categories()[c].synset},
                  {"name", name},
                  {"count", settings.per_category},
                  {"train", s.train.size()},
                  {"val", s.val.size()},
                  {"test", s.test.size()}});
  }
  write_text_atomic((root / "train.lst").string(), train.str());
  write_text_atomic((root / "val.lst").string(), val.str());
  write_text_atomic((root / "test.lst").string(), test.str());
  for (const auto& p : stale) fs::remove(p);
  write_json((root / "categories.json").string(),
             {{"generator", "sdfkit synth"},
              {"format", 1},
              {"seed", settings.seed},
              {"per_category", settings.per_category},
              {"split_base", settings.split_base > 0 ? settings.split_base : settings.per_category},
              {"up", "+y"},
              {"front", "+z"},
              {"mesh_format", "binary PLY, polygon soup of closed parts, per-vertex colours"},
              {"categories", jc}});

  SynthSummary sum;
  sum.shapes = static_cast<long>(plan.size());
  for (const long f : faces) {
    sum.faces += f;
    sum.max_faces = std::max(sum.max_faces, f);
  }
  sum.removed_stale = static_cast<long>(stale.size());
  return sum;
}

}  // namespace sdfkit
