#include "metrics/normals.h"

#include "core/error.h"

#include <cmath>

namespace sdfkit {
namespace {

Points unit_rows(const Points& n, Eigen::Index expected, const std::string& what) {
  require(n.rows() == expected, what + ": " + std::to_string(n.rows()) + " normals for " + std::to_string(expected) +
                                    " points");
  require(n.allFinite(), what + ": non-finite normal");
  Points u = n;
  for (Eigen::Index i = 0; i < u.rows(); ++i) {
    const double len = u.row(i).norm();
    require(len > 0, what + ": zero-length normal at row " + std::to_string(i));
    u.row(i) /= len;
  }
  return u;
}

}  // namespace

NormalConsistency normal_consistency(const PairEvaluator& pair, const Points& pred_normals, const Points& gt_normals) {
  const Points np = unit_rows(pred_normals, pair.pred_size(), "prediction normals");
  const Points ng = unit_rows(gt_normals, pair.gt_size(), "ground-truth normals");
  NormalConsistency r;
  const auto& p2g = pair.pred_to_gt_index();
  for (Eigen::Index i = 0; i < np.rows(); ++i) r.accuracy += std::abs(np.row(i).dot(ng.row(p2g(i))));
  const auto& g2p = pair.gt_to_pred_index();
  for (Eigen::Index i = 0; i < ng.rows(); ++i) r.completeness += std::abs(ng.row(i).dot(np.row(g2p(i))));
  r.accuracy /= static_cast<double>(np.rows());
  r.completeness /= static_cast<double>(ng.rows());
  return r;
}

NormalConsistency normal_consistency(const Points& pred, const Points& pred_normals, const Points& gt,
                                     const Points& gt_normals) {
  return normal_consistency(PairEvaluator(pred, gt), pred_normals, gt_normals);
}

}  // namespace sdfkit
