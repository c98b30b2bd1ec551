// The three scoring protocols of sdfkit (every convention in docs/eval.md):
//  disn : 2048 points drawn with replacement from each mesh's VERTICES; CD = (mean pred->gt squared NN distance
//         + mean gt->pred) x 1000; EMD = sum of matched Euclidean distances x 0.01 (exact by default, Fan et al.'s
//         approximate matcher with EmdMethod::kApprox); F-score, precision and recall (in %) at thresholds
//         {0.5, 1, 2, 5, 10, 20}% of 2.5 (1% = 0.025), strict <; IoU (in %) of solid voxelisations at DISN's
//         indexing (v + 1.1) / 2.4 * 110.
//  onet : 100k area-weighted surface samples; accuracy, completeness (mean distances), CD-L1 = their mean,
//         CD-L2 = mean of the two mean squared distances; IoU (fraction) from 100k uniform points in the padded
//         bounding box, inside = winding number > 0.5; normal consistency.
//  tmnet: 2048 area-weighted surface samples per mesh; CD = sum of the mean squared distances x 1000; EMD = mean
//         matched distance x 100 (exact).
// Random streams: prediction samples use Rng::derived(seed, 0), ground truth Rng::derived(seed, 1), IoU points
// Rng::derived(seed, 2): the same seed gives the same numbers on every machine and thread count.
// Point clouds (a Mesh with vertices and no faces) are scored from their points under every protocol: a cloud of
// exactly N points (the protocol's count, or --samples) is used as given, a larger one is subsampled to N without
// replacement, a smaller one keeps every point once and is padded to N with points drawn with replacement
// (metrics/sampling.h sample_cloud; EMD needs equal sizes). IoU and normal consistency need faces and are
// reported as unavailable (null).
#pragma once

#include "core/files.h"
#include "core/types.h"
#include "metrics/emd.h"

#include <optional>
#include <string>
#include <vector>

namespace sdfkit {

enum class Protocol { kDisn, kOnet, kTmnet };
Protocol parse_protocol(const std::string& name);  ///< InvalidInput on an unknown name
std::string to_string(Protocol p);

struct ProtocolSettings {
  Protocol protocol = Protocol::kDisn;
  uint64_t seed = 0;
  EmdMethod emd = EmdMethod::kExact;  ///< disn and tmnet
  long samples = 0;                  ///< points per shape; 0 = the protocol's own (2048, 100000, 2048)
  long iou_points = 100000;          ///< onet's uniform IoU points
  bool with_emd = true;              ///< skip EMD (reported null) when false
  bool with_iou = true;              ///< skip IoU (reported null) when false
};

/// One number of a protocol; `value` is empty when it cannot be computed for this input (then `note` says why).
struct Metric {
  std::string key;    ///< stable column name: cd, emd, f_1, p_1, r_1, iou, accuracy, ...
  std::string label;  ///< table row label with its unit/scale, e.g. "CD (x1000)"
  std::optional<double> value;
  std::string note;
};

struct EvalResult {
  Protocol protocol = Protocol::kDisn;
  uint64_t seed = 0;
  long samples = 0;
  std::string emd_method;
  /// How each side's points were obtained: "surface" (area-weighted samples), "vertices_with_replacement" (disn on
  /// a mesh), or for a point cloud "as_given", "subsampled", "padded" (metrics/sampling.h CloudSampling).
  std::string pred_sampling, gt_sampling;
  std::vector<Metric> metrics;  ///< in the protocol's fixed order (metric_keys)
  double seconds = 0;           ///< wall time of the evaluation

  [[nodiscard]] std::optional<double> get(const std::string& key) const;
  /// {"protocol", "seed", "samples", "emd_method", "seconds", "metrics": {key: value or null}, "notes": {...},
  ///  "sampling": {"prediction", "ground_truth"}}
  [[nodiscard]] Json to_json() const;
};

/// The keys a protocol reports, in order, with their labels.
std::vector<std::pair<std::string, std::string>> metric_keys(Protocol p);
/// DISN's F-score thresholds as fractions of 2.5 in percent: {0.5, 1, 2, 5, 10, 20}.
const std::vector<double>& disn_threshold_percents();

/// Scores `pred` against `gt`. Throws InvalidInput (naming "prediction" or "ground truth") on empty input or
/// non-finite coordinates.
EvalResult evaluate(const Mesh& pred, const Mesh& gt, const ProtocolSettings& settings = {});

}  // namespace sdfkit
