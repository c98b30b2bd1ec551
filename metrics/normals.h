// Normal consistency (Occupancy Networks' definition): for each predicted sample, |n_pred . n_gt| with the normal
// of its nearest ground-truth sample, and the same from the ground-truth side; the result is the mean of the two
// means. Absolute value: orientation (inward/outward winding) does not count, only the direction of the surface.
// 1 = every normal parallel to its neighbour's, 0 = perpendicular.
#pragma once

#include "core/types.h"
#include "metrics/chamfer.h"

namespace sdfkit {

struct NormalConsistency {
  double accuracy = 0;      ///< mean |n_pred . n_nearest_gt| over predicted samples
  double completeness = 0;  ///< mean |n_gt . n_nearest_pred| over ground-truth samples
  [[nodiscard]] double value() const { return 0.5 * (accuracy + completeness); }
};

/// Uses the evaluator's nearest neighbours. `pred_normals` / `gt_normals` have one row per point of the
/// evaluator's sets; they are normalised here (zero rows are refused). InvalidInput on a size mismatch.
NormalConsistency normal_consistency(const PairEvaluator& pair, const Points& pred_normals, const Points& gt_normals);

/// One-off version.
NormalConsistency normal_consistency(const Points& pred, const Points& pred_normals, const Points& gt,
                                     const Points& gt_normals);

}  // namespace sdfkit
