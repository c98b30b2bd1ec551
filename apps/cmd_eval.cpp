// `sdfkit eval PRED GT`: score a prediction against its ground truth with one of the protocols of
// metrics/protocols.h, for a pair of files or for two dataset folders (docs/eval.md).
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/io/points.h"
#include "core/mesh_io.h"
#include "metrics/protocols.h"
#include "metrics/report.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

namespace sdfkit::app {
namespace {

namespace fs = std::filesystem;

/// Mesh (obj ply off stl) or point cloud (xyz, npy N x 3+: first three columns). A point cloud has no faces.
Mesh read_shape(const std::string& path) {
  if (!fs::exists(path)) throw IoError(path + ": no such file");
  if (!has_point_cloud_extension(path)) return read_mesh(path);
  Mesh m;
  m.V = read_point_cloud(path);
  return m;
}

const char* const kPredictionExtensions[] = {".obj", ".ply", ".off", ".stl", ".xyz", ".npy"};

std::string find_prediction(const fs::path& dir, const std::string& shape) {
  for (const char* ext : kPredictionExtensions) {
    const fs::path p = dir / (shape + ext);
    if (fs::exists(p)) return p.string();
  }
  return "";
}

struct Opts {
  std::string pred, gt, protocol = "disn", emd = "exact", out, split;
  bool emd_given = false, split_given = false, jobs_given = false;
  uint64_t seed = 0;
  bool json = false, csv = false, no_emd = false, no_iou = false;
  int jobs = 0;
  long samples = 0;
};

/// A flag that does not apply under the chosen protocol or mode is an error, not silently ignored.
void check_flags_apply(const Opts& o, bool folders) {
  const Protocol p = parse_protocol(o.protocol);
  if (p == Protocol::kOnet && (o.emd_given || o.no_emd))
    throw InvalidInput(std::string(o.emd_given ? "--emd" : "--no-emd") +
                       " does not apply to --protocol onet, which reports no EMD");
  if (p == Protocol::kTmnet && o.no_iou)
    throw InvalidInput("--no-iou does not apply to --protocol tmnet, which reports no IoU");
  if (!folders && o.split_given) throw InvalidInput("--split applies to folders, not to a pair of files");
  if (!folders && o.jobs_given) throw InvalidInput("--jobs applies to folders, not to a pair of files");
}

ProtocolSettings settings_of(const Opts& o) {
  ProtocolSettings s;
  s.protocol = parse_protocol(o.protocol);
  s.emd = parse_emd_method(o.emd);
  s.seed = o.seed;
  s.samples = o.samples;
  s.with_emd = !o.no_emd;
  s.with_iou = !o.no_iou;
  return s;
}

void emit(const Opts& o, const std::string& text) {
  if (o.out.empty())
    std::cout << text;
  else
    write_text_atomic(o.out, text);
}

int run_pair(const Opts& o) {
  const ProtocolSettings s = settings_of(o);
  const Mesh pred = read_shape(o.pred);
  const Mesh gt = read_shape(o.gt);
  const EvalResult r = evaluate(pred, gt, s);
  if (o.json) {
    Json j = r.to_json();
    j["pred"] = o.pred;
    j["gt"] = o.gt;
    emit(o, j.dump(2) + "\n");
  } else if (o.csv) {
    std::string header = "pred,gt,protocol", row = o.pred + "," + o.gt + "," + to_string(r.protocol);
    for (const auto& m : r.metrics) {
      header += "," + m.key;
      row += ",";
      if (m.value) {
        std::ostringstream v;
        v.precision(9);
        v << *m.value;
        row += v.str();
      }
    }
    emit(o, header + ",seconds\n" + row + "," + std::to_string(r.seconds) + "\n");
  } else {
    std::ostringstream t;
    t << "protocol " << to_string(r.protocol) << ", seed " << r.seed << ", " << r.samples << " points per shape"
      << (r.emd_method.empty() ? "" : ", EMD " + r.emd_method) << '\n'
      << "  points: prediction " << r.pred_sampling << ", ground truth " << r.gt_sampling << '\n';
    for (const auto& m : r.metrics) {
      t << "  " << m.label << ": ";
      if (m.value) {
        t.precision(6);
        t << *m.value;
      } else {
        t << "n/a (" << m.note << ")";
      }
      t << '\n';
    }
    t << "  (" << r.seconds << " s)\n";
    emit(o, t.str());
  }
  return kOk;
}

int run_folders(const Opts& o) {
  const ProtocolSettings s = settings_of(o);
  std::vector<ShapeRecord> records;
  const fs::path gt_root(o.gt), pred_root(o.pred);
  // --split: only the listed <category>/<shape> entries (a name -> GT/NAME.lst, or a list file).
  std::set<std::string> wanted;
  if (!o.split.empty()) {
    const fs::path list = fs::exists(o.split) ? fs::path(o.split) : gt_root / (o.split + ".lst");
    std::ifstream in(list);
    if (!in) throw InvalidInput("--split " + o.split + ": neither a list file nor " + list.string());
    for (std::string line; std::getline(in, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty() && line[0] != '#') wanted.insert(line);
    }
    if (wanted.empty()) throw InvalidInput(list.string() + ": the split lists no shapes");
  }
  std::set<std::string> seen;
  std::vector<fs::path> categories;
  for (const auto& e : fs::directory_iterator(gt_root))
    if (e.is_directory()) categories.push_back(e.path());
  std::sort(categories.begin(), categories.end());
  for (const auto& cat : categories) {
    std::vector<fs::path> shapes;
    for (const auto& e : fs::directory_iterator(cat))
      if (e.is_directory() && fs::exists(e.path() / "gt.obj")) shapes.push_back(e.path());
    std::sort(shapes.begin(), shapes.end());
    for (const auto& sh : shapes) {
      const std::string id = cat.filename().string() + "/" + sh.filename().string();
      if (!wanted.empty() && !wanted.count(id)) continue;
      seen.insert(id);
      ShapeRecord r;
      r.category = cat.filename().string();
      r.shape = sh.filename().string();
      r.gt_path = (sh / "gt.obj").string();
      r.pred_path = find_prediction(pred_root / r.category, r.shape);
      r.status = r.pred_path.empty() ? "missing" : "pending";
      if (r.pred_path.empty()) r.reason = "no prediction " + (pred_root / r.category / r.shape).string() + ".{obj,ply,...}";
      records.push_back(std::move(r));
    }
  }
  for (const std::string& id : wanted)  // listed but without a ground truth: reported, not skipped
    if (!seen.count(id)) {
      ShapeRecord r;
      const size_t slash = id.find('/');
      r.category = slash == std::string::npos ? "default" : id.substr(0, slash);
      r.shape = slash == std::string::npos ? id : id.substr(slash + 1);
      r.status = "failed";
      r.reason = "listed in --split " + o.split + " but " + (gt_root / id / "gt.obj").string() + " does not exist";
      records.push_back(std::move(r));
    }
  if (records.empty()) throw InvalidInput(o.gt + ": no ground-truth shapes (<gt>/<category>/<shape>/gt.obj) found");
  // Predictions without a ground truth are reported, not scored. Only files find_prediction could pick count:
  // recon's <name>.preview.png beside each mesh is not a prediction.
  const auto is_prediction = [](const fs::path& f) {
    for (const char* ext : kPredictionExtensions)
      if (f.extension() == ext) return true;
    return false;
  };
  long extra = 0;
  if (fs::is_directory(pred_root))
    for (const auto& cat : fs::directory_iterator(pred_root))
      if (cat.is_directory())
        for (const auto& f : fs::directory_iterator(cat.path()))
          if (f.is_regular_file() && is_prediction(f.path()) &&
              !fs::exists(gt_root / cat.path().filename() / f.path().stem() / "gt.obj"))
            ++extra;

  ProgressBar bar("eval", static_cast<long>(records.size()));
  tbb::task_arena arena(o.jobs > 0 ? o.jobs : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(size_t(0), records.size(), [&](size_t i) {
      ShapeRecord& r = records[i];
      if (r.status == "pending") {
        try {
          r.result = evaluate(read_shape(r.pred_path), read_shape(r.gt_path), s);
          r.status = "ok";
        } catch (const std::exception& e) {
          r.status = "failed";
          r.reason = e.what();
        }
      }
      bar.tick();
    });
  });
  bar.finish();
  const Summary summary = summarize(records, s.protocol);
  const std::string table = markdown_table(summary);
  Json js = summary_json(summary, records);
  js["extra_predictions"] = extra;
  js["seed"] = s.seed;
  js["emd_method"] = s.protocol == Protocol::kOnet ? Json(nullptr) : Json(to_string(s.emd));
  if (!o.out.empty()) {
    write_text_atomic((fs::path(o.out) / "per_shape.csv").string(), per_shape_csv(records, s.protocol));
    write_text_atomic((fs::path(o.out) / "table.md").string(), table);
    write_json((fs::path(o.out) / "summary.json").string(), js);
  }
  if (o.json)
    std::cout << js.dump(2) << '\n';
  else if (o.csv)
    std::cout << per_shape_csv(records, s.protocol);
  else
    std::cout << table;
  for (const auto& r : records)
    if (r.status != "ok") std::cerr << "sdfkit: " << r.status << ": " << r.category << "/" << r.shape << ": " << r.reason << '\n';
  if (extra > 0) std::cerr << "sdfkit: " << extra << " prediction file(s) have no ground truth and were not scored\n";
  return summary.mean.ok == summary.mean.total ? int(kOk) : int(kPartialFailure);
}

std::function<int()> setup_eval(CLI::App& app) {
  auto o = std::make_shared<Opts>();
  app.add_option("pred", o->pred,
                 "prediction: a mesh (.obj .ply .off .stl) or point cloud (.xyz, .npy N x 3+), or a folder "
                 "<pred>/<category>/<shape>.{obj,ply,...}")
      ->required();
  app.add_option("gt", o->gt,
                 "ground truth: a mesh or point cloud, or a prepared dataset folder <gt>/<category>/<shape>/gt.obj")
      ->required();
  app.add_option("--protocol", o->protocol,
                 "disn: 2048 vertex samples, CD x1000, EMD sum x0.01, F-score, voxel IoU; onet: 100k surface samples, "
                 "accuracy/completeness/CD-L1/CD-L2, point IoU, normal consistency; tmnet: 2048 surface samples, "
                 "CD x1000, EMD mean x100")
      ->check(CLI::IsMember({"disn", "onet", "tmnet"}));
  app.add_option("--seed", o->seed, "seed of every random draw (same seed, same numbers)");
  CLI::Option* emd_opt = app.add_option("--emd", o->emd, "exact (certified optimal matching, default) or approx (DISN's approximate matcher)")
      ->check(CLI::IsMember({"exact", "approx"}));
  app.add_option("--samples", o->samples, "points per shape instead of the protocol's own count")
      ->check(positive());
  app.add_flag("--no-emd", o->no_emd, "skip EMD (reported as null)");
  app.add_flag("--no-iou", o->no_iou, "skip IoU (reported as null)");
  auto* json = app.add_flag("--json", o->json, "JSON output (pair: the result; folders: the summary)");
  app.add_flag("--csv", o->csv, "CSV output (pair: one row; folders: one row per shape)")->excludes(json);
  CLI::Option* split_opt = app.add_option("--split", o->split,
                 "folders: score only the <category>/<shape> entries of this split (a name looked up as GT/NAME.lst, "
                 "or a list file); other shapes are not counted as missing");
  CLI::Option* jobs_opt = app.add_option("--jobs", o->jobs, "shapes scored in parallel in folder mode (default: all cores)")
      ->check(non_negative());
  app.add_option("-o,--out", o->out,
                 "pair: write the output to this file instead of stdout; folders: write per_shape.csv, table.md and "
                 "summary.json into this folder");
  return [o, emd_opt, split_opt, jobs_opt] {
    o->emd_given = emd_opt->count() > 0;
    o->split_given = split_opt->count() > 0;
    o->jobs_given = jobs_opt->count() > 0;
    const bool pd = fs::is_directory(o->pred), gd = fs::is_directory(o->gt);
    if (pd != gd && gd && !fs::exists(o->pred)) {  // every prediction missing
      check_flags_apply(*o, true);
      return run_folders(*o);
    }
    if (pd != gd)
      throw InvalidInput("PRED and GT must both be files or both be folders (got " + o->pred + " and " + o->gt + ")");
    check_flags_apply(*o, gd);
    return gd ? run_folders(*o) : run_pair(*o);
  };
}

SDFKIT_REGISTER_COMMAND("eval", "score predictions against ground truth (CD, EMD, F-score, IoU, NC)", setup_eval);

}  // namespace
}  // namespace sdfkit::app
