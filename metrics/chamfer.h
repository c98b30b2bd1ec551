// Chamfer distances (squared and L1 variants), F-score at distance thresholds, and the evaluator that serves them
// (and normal consistency, metrics/normals.h) from one pair of nearest-neighbour grids built once.
//
// Conventions (docs/eval.md): "pred -> gt" distances are from each predicted point to its nearest ground-truth
// point (accuracy / precision side), "gt -> pred" the reverse (completeness / recall side). Distances are
// Euclidean; "squared" variants average squared distances. Means are plain sequential sums over points in input
// order, so results are bit-identical for any thread count.
#pragma once

#include "core/types.h"
#include "metrics/grid_nn.h"

#include <memory>
#include <vector>

namespace sdfkit {

struct ChamferResult {
  double accuracy = 0;         ///< mean pred -> gt distance
  double completeness = 0;     ///< mean gt -> pred distance
  double accuracy_sq = 0;      ///< mean pred -> gt squared distance
  double completeness_sq = 0;  ///< mean gt -> pred squared distance

  /// Sum of the two mean squared distances (DISN, TMNet; multiplied by 1000 in their tables).
  [[nodiscard]] double cd_squared() const { return accuracy_sq + completeness_sq; }
  /// Mean of accuracy and completeness (Occupancy Networks' Chamfer-L1).
  [[nodiscard]] double cd_l1() const { return 0.5 * (accuracy + completeness); }
  /// Mean of the two mean squared distances (Occupancy Networks' Chamfer-L2).
  [[nodiscard]] double cd_l2() const { return 0.5 * (accuracy_sq + completeness_sq); }
};

/// Precision = share of predicted points closer than `threshold` to the ground truth (strict <), recall = share
/// of ground-truth points closer than `threshold` to the prediction, F = 2PR / (P + R) (0 when P + R = 0).
struct FScore {
  double threshold = 0;
  double precision = 0;
  double recall = 0;
  double fscore = 0;
};
/// F from precision and recall (0 when both are 0).
double f_from_pr(double precision, double recall);

/// Buckets each set once (metrics/grid_nn.h) and finds exact nearest neighbours in both directions once; every
/// metric of the pair is then read from those. Throws InvalidInput if a set is empty or holds a non-finite coordinate.
class PairEvaluator {
 public:
  PairEvaluator(const Points& pred, const Points& gt);

  [[nodiscard]] Eigen::Index pred_size() const { return p2g_sq_.size(); }
  [[nodiscard]] Eigen::Index gt_size() const { return g2p_sq_.size(); }
  /// For every predicted point, its nearest ground-truth point and the squared distance to it.
  [[nodiscard]] const Eigen::VectorXi& pred_to_gt_index() const { return p2g_index_; }
  [[nodiscard]] const Eigen::VectorXd& pred_to_gt_sq() const { return p2g_sq_; }
  /// For every ground-truth point, its nearest predicted point and the squared distance to it.
  [[nodiscard]] const Eigen::VectorXi& gt_to_pred_index() const { return g2p_index_; }
  [[nodiscard]] const Eigen::VectorXd& gt_to_pred_sq() const { return g2p_sq_; }

  [[nodiscard]] ChamferResult chamfer() const;
  [[nodiscard]] FScore fscore(double threshold) const;
  [[nodiscard]] std::vector<FScore> fscores(const std::vector<double>& thresholds) const;

 private:
  Eigen::VectorXi p2g_index_, g2p_index_;
  Eigen::VectorXd p2g_sq_, g2p_sq_;
};

/// One-off versions (build the trees, answer, discard).
ChamferResult chamfer(const Points& pred, const Points& gt);
std::vector<FScore> fscores(const Points& pred, const Points& gt, const std::vector<double>& thresholds);

}  // namespace sdfkit
