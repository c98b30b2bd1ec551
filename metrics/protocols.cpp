#include "metrics/protocols.h"

#include "core/error.h"
#include "core/json.h"
#include "core/random.h"
#include "metrics/chamfer.h"
#include "metrics/iou.h"
#include "metrics/normals.h"
#include "metrics/sampling.h"

#include <chrono>
#include <map>
#include <cmath>
#include <sstream>

namespace sdfkit {
namespace {

std::string percent_key(const char* prefix, double pct) {
  std::ostringstream s;
  s << prefix << pct;  // 0.5 -> "f_0.5", 1 -> "f_1"
  return s.str();
}

bool is_point_cloud(const Mesh& m) { return m.F.rows() == 0; }

void check_input(const Mesh& m, const std::string& what) {
  require(m.V.rows() > 0, what + ": empty (no vertices or points)");
  require(m.V.allFinite(), what + ": non-finite (NaN or infinite) coordinate");
  if (!is_point_cloud(m))
    require(m.F.minCoeff() >= 0 && m.F.maxCoeff() < m.V.rows(), what + ": face index out of range");
}

struct Samples {
  Points points, normals;  // normals empty for vertex samples and point clouds
  std::string how;         // EvalResult::pred_sampling / gt_sampling
};

Samples draw(const Mesh& m, Protocol p, long n, uint64_t seed, const std::string& what) {
  Samples s;
  if (is_point_cloud(m)) {
    CloudSampling how = CloudSampling::kAsGiven;
    s.points = sample_cloud(m.V, n, seed, &how, what);
    s.how = to_string(how);
  } else if (p == Protocol::kDisn) {
    s.points = sample_with_replacement(m.V, n, seed, what);
    s.how = "vertices_with_replacement";
  } else {
    s.how = "surface";
    SurfaceSamples ss = sample_surface(m, n, seed, what);
    s.points = std::move(ss.points);
    s.normals = std::move(ss.normals);
  }
  return s;
}

}  // namespace

Protocol parse_protocol(const std::string& name) {
  if (name == "disn") return Protocol::kDisn;
  if (name == "onet") return Protocol::kOnet;
  if (name == "tmnet") return Protocol::kTmnet;
  throw InvalidInput("unknown protocol '" + name + "' (expected disn, onet or tmnet)");
}

std::string to_string(Protocol p) {
  switch (p) {
    case Protocol::kDisn: return "disn";
    case Protocol::kOnet: return "onet";
    case Protocol::kTmnet: return "tmnet";
  }
  return "?";
}

const std::vector<double>& disn_threshold_percents() {
  static const std::vector<double> kPercents = {0.5, 1, 2, 5, 10, 20};
  return kPercents;
}

std::vector<std::pair<std::string, std::string>> metric_keys(Protocol p) {
  std::vector<std::pair<std::string, std::string>> k;
  switch (p) {
    case Protocol::kDisn:
      k.emplace_back("cd", "CD (x1000)");
      k.emplace_back("emd", "EMD (x0.01)");
      k.emplace_back("iou", "IoU (%)");
      for (double t : disn_threshold_percents()) {
        std::ostringstream pct;
        pct << t;
        k.emplace_back(percent_key("f_", t), "F-score@" + pct.str() + "% (%)");
      }
      for (double t : disn_threshold_percents()) {
        std::ostringstream pct;
        pct << t;
        k.emplace_back(percent_key("p_", t), "Precision@" + pct.str() + "% (%)");
        k.emplace_back(percent_key("r_", t), "Recall@" + pct.str() + "% (%)");
      }
      break;
    case Protocol::kOnet:
      k = {{"accuracy", "Accuracy"}, {"completeness", "Completeness"}, {"cd_l1", "CD-L1"},
           {"cd_l2", "CD-L2"},       {"iou", "IoU"},                   {"normal_consistency", "Normal consistency"}};
      break;
    case Protocol::kTmnet: k = {{"cd", "CD (x1000)"}, {"emd", "EMD (x100)"}}; break;
  }
  return k;
}

std::optional<double> EvalResult::get(const std::string& key) const {
  for (const auto& m : metrics)
    if (m.key == key) return m.value;
  return std::nullopt;
}

Json EvalResult::to_json() const {
  Json values = Json::object(), notes = Json::object();
  for (const auto& m : metrics) {
    values[m.key] = m.value ? Json(*m.value) : Json(nullptr);
    if (!m.note.empty()) notes[m.key] = m.note;
  }
  Json j = {{"protocol", to_string(protocol)}, {"seed", seed}, {"samples", samples}, {"seconds", seconds},
            {"metrics", values}, {"sampling", {{"prediction", pred_sampling}, {"ground_truth", gt_sampling}}}};
  j["emd_method"] = emd_method.empty() ? Json(nullptr) : Json(emd_method);
  if (!notes.empty()) j["notes"] = notes;
  return j;
}

EvalResult evaluate(const Mesh& pred, const Mesh& gt, const ProtocolSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  check_input(pred, "prediction");
  check_input(gt, "ground truth");
  const Protocol p = settings.protocol;
  const long n = settings.samples > 0 ? settings.samples : (p == Protocol::kOnet ? 100000 : 2048);
  EvalResult r;
  r.protocol = p;
  r.seed = settings.seed;
  r.samples = n;
  r.emd_method = p == Protocol::kOnet ? "" : to_string(settings.emd);
  std::map<std::string, Metric> found;
  auto set = [&](const std::string& key, std::optional<double> v, std::string note = "") {
    found[key] = Metric{key, "", v, std::move(note)};
  };

  const Samples sp = draw(pred, p, n, Rng::derived(settings.seed, 0).next(), "prediction");
  const Samples sg = draw(gt, p, n, Rng::derived(settings.seed, 1).next(), "ground truth");
  r.pred_sampling = sp.how;
  r.gt_sampling = sg.how;
  const PairEvaluator pair(sp.points, sg.points);
  const ChamferResult cd = pair.chamfer();
  const bool meshes = !is_point_cloud(pred) && !is_point_cloud(gt);

  if (p == Protocol::kDisn || p == Protocol::kTmnet) {
    set("cd", cd.cd_squared() * 1000.0);
    if (settings.with_emd) {
      EmdSettings es;
      es.method = settings.emd;
      const EmdResult e = emd(sp.points, sg.points, es);
      set("emd", p == Protocol::kDisn ? e.total * 0.01 : e.mean() * 100.0);
    } else {
      set("emd", std::nullopt, "EMD disabled");
    }
  }
  if (p == Protocol::kDisn) {
    for (double t : disn_threshold_percents()) {
      const FScore f = pair.fscore(t / 100.0 * 2.5);
      set(percent_key("f_", t), 100.0 * f.fscore);
      set(percent_key("p_", t), 100.0 * f.precision);
      set(percent_key("r_", t), 100.0 * f.recall);
    }
    if (!settings.with_iou)
      set("iou", std::nullopt, "IoU disabled");
    else if (!meshes)
      set("iou", std::nullopt, "IoU needs two meshes (a point cloud has no inside)");
    else
      set("iou", 100.0 * voxel_iou(pred, gt));
  }
  if (p == Protocol::kOnet) {
    set("accuracy", cd.accuracy);
    set("completeness", cd.completeness);
    set("cd_l1", cd.cd_l1());
    set("cd_l2", cd.cd_l2());
    if (!settings.with_iou) {
      set("iou", std::nullopt, "IoU disabled");
    } else if (!meshes) {
      set("iou", std::nullopt, "IoU needs two meshes (a point cloud has no inside)");
    } else {
      PointIouSettings is;
      is.points = settings.iou_points;
      set("iou", point_iou(pred, gt, Rng::derived(settings.seed, 2).next(), is).iou);
    }
    if (sp.normals.rows() > 0 && sg.normals.rows() > 0)
      set("normal_consistency", normal_consistency(pair, sp.normals, sg.normals).value());
    else
      set("normal_consistency", std::nullopt, "normal consistency needs two meshes");
  }
  for (const auto& [key, label] : metric_keys(p)) {
    Metric m = found.at(key);
    m.label = label;
    r.metrics.push_back(std::move(m));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace sdfkit
