#include "camera/pose_metrics.h"

#include "core/error.h"

namespace sdfkit {

PoseErrors pose_errors(const Points& X, const Camera& predicted, const Camera& truth) {
  require(X.rows() > 0, "pose_errors: no points");
  require(X.allFinite(), "pose_errors: non-finite point coordinates");
  validate_camera(predicted, "pose_errors: predicted camera");
  validate_camera(truth, "pose_errors: true camera");
  // Serial sums in point order: the result does not depend on threading.
  PoseErrors e;
  double sum3 = 0, sum2 = 0;
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const Vec3 x = X.row(i).transpose();
    const Vec3 cp = to_camera(predicted, x), ct = to_camera(truth, x);
    sum3 += (cp - ct).norm();
    if (cp.z() > 0 && ct.z() > 0) {
      const Vec3 hp = predicted.K * cp, ht = truth.K * ct;
      sum2 += (hp.head<2>() / hp.z() - ht.head<2>() / ht.z()).norm();
      ++e.points_2d;
    }
  }
  e.d3d = sum3 / static_cast<double>(X.rows());
  e.d2d = e.points_2d > 0 ? sum2 / static_cast<double>(e.points_2d) : 0.0;
  return e;
}

double pose_d3d(const Points& X, const Camera& predicted, const Camera& truth) {
  return pose_errors(X, predicted, truth).d3d;
}

double pose_d2d(const Points& X, const Camera& predicted, const Camera& truth) {
  return pose_errors(X, predicted, truth).d2d;
}

}  // namespace sdfkit
