// `sdfkit synth -o DIR`: write the procedural ShapeNet-like benchmark (13 categories of DISN's Table 1).
#include "apps/command.h"
#include "core/error.h"
#include "core/json.h"
#include "synth/benchmark.h"
#include "synth/categories.h"
#include "synth/sheet.h"

#include <chrono>
#include <iostream>
#include <sstream>

namespace sdfkit::app {
namespace {

std::vector<std::string> split_commas(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const auto& item : items) {
    std::stringstream ss(item);
    std::string part;
    while (std::getline(ss, part, ','))
      if (!part.empty()) out.push_back(part);
  }
  return out;
}

std::function<int()> setup_synth(CLI::App& app) {
  struct Opts {
    std::string out;
    int per_category = -1;
    uint64_t seed = 0;
    std::vector<std::string> categories;
    std::string preset = "ci";
    int jobs = 0;
    int split_base = 0;
    bool json = false;
    std::string sheet;
    int sheet_k = 6;
    int sheet_cell = 160;
  };
  auto o = std::make_shared<Opts>();
  std::string names;
  for (const auto& c : categories()) names += (names.empty() ? "" : ",") + c.name;
  app.add_option("-o,--out", o->out, "output folder: DIR/<category>/<shape-id>.ply, categories.json, train/val/test.lst")
      ->required();
  app.add_option("--preset", o->preset, "ci = 3 shapes per category, full = 100 per category")
      ->check(CLI::IsMember({"ci", "full"}))
      ->capture_default_str();
  app.add_option("-n,--per-category", o->per_category, "shapes per category (overrides --preset)")
      ->check(in_range(1, 100000));
  app.add_option("--split-base", o->split_base,
                 "draw val and test from the first N shapes of each category, as in a benchmark of N per category; "
                 "the shapes after them all go to train (0 = all shapes): a larger training set with the same test "
                 "shapes")
      ->check(non_negative());
  app.add_option("--seed", o->seed, "seed of every random choice (same seed -> byte-identical files)")
      ->capture_default_str();
  app.add_option("--categories", o->categories,
                 "comma-separated names or ShapeNet synset ids (default: all 13: " + names + ")");
  app.add_option("-j,--jobs", o->jobs, "worker threads, 0 = all cores (output does not depend on it)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_flag("--json", o->json, "print a JSON summary on stdout");
  app.add_option("--sheet", o->sheet, "also render a contact sheet PNG: one view of the first K shapes per category");
  app.add_option("--sheet-per-category", o->sheet_k, "K, shapes per category on the contact sheet")
      ->check(in_range(1, 100))
      ->capture_default_str();
  app.add_option("--sheet-cell", o->sheet_cell, "contact sheet cell size in pixels")
      ->check(in_range(16, 2048))
      ->capture_default_str();
  return [o] {
    SynthSettings s;
    s.per_category = o->per_category > 0 ? o->per_category : (o->preset == "full" ? 100 : 3);
    s.seed = o->seed;
    s.categories = split_commas(o->categories);
    s.jobs = o->jobs;
    s.split_base = o->split_base;
    const auto plan = plan_benchmark(s);  // validates categories before any work
    ProgressBar bar("synth", static_cast<long>(plan.size()));
    const auto t0 = std::chrono::steady_clock::now();
    const SynthSummary sum = write_benchmark(o->out, s, [&](double f) {
      bar.update(static_cast<long>(f * static_cast<double>(plan.size()) + 0.5));
      return true;
    });
    bar.finish();
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!o->sheet.empty()) {
      SheetSettings sheet;
      sheet.per_category = o->sheet_k;
      sheet.cell = o->sheet_cell;
      write_contact_sheet(o->sheet, s, sheet);
    }
    if (o->json) {
      std::cout << Json{{"out", o->out},         {"shapes", sum.shapes},       {"faces", sum.faces},
                        {"max_faces", sum.max_faces}, {"seconds", secs},        {"seed", s.seed},
                        {"per_category", s.per_category}, {"removed_stale", sum.removed_stale},
                        {"sheet", o->sheet}}
                       .dump(2)
                << '\n';
    } else {
      std::cout << "synth: wrote " << sum.shapes << " shapes (" << sum.faces << " triangles, largest " << sum.max_faces
                << ") to " << o->out << " in " << secs << " s";
      if (sum.removed_stale > 0) std::cout << "; removed " << sum.removed_stale << " shapes of an earlier run";
      std::cout << '\n';
      if (!o->sheet.empty()) std::cout << "synth: contact sheet " << o->sheet << '\n';
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("synth", "write the procedural 13-category benchmark (meshes, splits, categories.json)",
                        setup_synth);

}  // namespace
}  // namespace sdfkit::app
