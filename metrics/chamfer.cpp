#include "metrics/chamfer.h"

#include "core/error.h"
#include "metrics/sampling.h"

#include <tbb/parallel_invoke.h>

#include <cmath>

namespace sdfkit {

double f_from_pr(double precision, double recall) {
  return precision + recall > 0 ? 2 * precision * recall / (precision + recall) : 0.0;
}

PairEvaluator::PairEvaluator(const Points& pred, const Points& gt) {
  require_finite_points(pred, "prediction");
  require_finite_points(gt, "ground truth");
  std::unique_ptr<NearestGrid> pred_grid, gt_grid;
  tbb::parallel_invoke([&] { pred_grid = std::make_unique<NearestGrid>(pred, "prediction"); },
                       [&] { gt_grid = std::make_unique<NearestGrid>(gt, "ground truth"); });
  gt_grid->nearest(pred, p2g_index_, p2g_sq_);
  pred_grid->nearest(gt, g2p_index_, g2p_sq_);
}

ChamferResult PairEvaluator::chamfer() const {
  ChamferResult r;
  for (Eigen::Index i = 0; i < p2g_sq_.size(); ++i) {
    r.accuracy += std::sqrt(p2g_sq_(i));
    r.accuracy_sq += p2g_sq_(i);
  }
  for (Eigen::Index i = 0; i < g2p_sq_.size(); ++i) {
    r.completeness += std::sqrt(g2p_sq_(i));
    r.completeness_sq += g2p_sq_(i);
  }
  const auto np = static_cast<double>(p2g_sq_.size()), ng = static_cast<double>(g2p_sq_.size());
  r.accuracy /= np;
  r.accuracy_sq /= np;
  r.completeness /= ng;
  r.completeness_sq /= ng;
  return r;
}

FScore PairEvaluator::fscore(double threshold) const {
  require(threshold > 0 && std::isfinite(threshold), "F-score threshold must be positive and finite");
  // d < t  <=>  d^2 < t^2 for d, t >= 0; comparing squared distances avoids a square root per point, and the
  // square of the threshold is the only rounding (the same on every platform).
  const double t2 = threshold * threshold;
  long close_pred = 0, close_gt = 0;
  for (Eigen::Index i = 0; i < p2g_sq_.size(); ++i) close_pred += p2g_sq_(i) < t2;
  for (Eigen::Index i = 0; i < g2p_sq_.size(); ++i) close_gt += g2p_sq_(i) < t2;
  FScore f;
  f.threshold = threshold;
  f.precision = static_cast<double>(close_pred) / static_cast<double>(p2g_sq_.size());
  f.recall = static_cast<double>(close_gt) / static_cast<double>(g2p_sq_.size());
  f.fscore = f_from_pr(f.precision, f.recall);
  return f;
}

std::vector<FScore> PairEvaluator::fscores(const std::vector<double>& thresholds) const {
  std::vector<FScore> out;
  out.reserve(thresholds.size());
  for (double t : thresholds) out.push_back(fscore(t));
  return out;
}

ChamferResult chamfer(const Points& pred, const Points& gt) { return PairEvaluator(pred, gt).chamfer(); }

std::vector<FScore> fscores(const Points& pred, const Points& gt, const std::vector<double>& thresholds) {
  return PairEvaluator(pred, gt).fscores(thresholds);
}

}  // namespace sdfkit
