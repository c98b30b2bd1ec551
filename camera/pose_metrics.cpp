#include "camera/pose_metrics.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>

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

PoseErrors pose_errors_modulo(const Points& X, const Camera& predicted, const Camera& truth,
                              const std::vector<Mat3>& symmetries) {
  PoseErrors best = pose_errors(X, predicted, truth);
  for (const Mat3& g : symmetries) {
    require(g.allFinite() && (g.transpose() * g - Mat3::Identity()).norm() < 1e-6 && g.determinant() > 0,
            "pose_errors_modulo: a symmetry must be a rotation");
    Camera twin = truth;
    twin.R = truth.R * g;
    const PoseErrors e = pose_errors(X, predicted, twin);
    best.d3d = std::min(best.d3d, e.d3d);
    if (e.d2d < best.d2d) {
      best.d2d = e.d2d;
      best.points_2d = e.points_2d;
    }
  }
  return best;
}

double pose_d3d(const Points& X, const Camera& predicted, const Camera& truth) {
  return pose_errors(X, predicted, truth).d3d;
}

double pose_d2d(const Points& X, const Camera& predicted, const Camera& truth) {
  return pose_errors(X, predicted, truth).d2d;
}

std::pair<double, double> rotation_error_degrees(const Mat3& R_est, const Mat3& R_true) {
  const Mat3 M = R_true.transpose() * R_est;  // R_est = R_true M
  const double c = std::clamp((M.trace() - 1.0) / 2.0, -1.0, 1.0);
  const double deg = 180.0 / 3.14159265358979323846;
  // The R_y(phi) = [[cos, 0, sin], [0, 1, 0], [-sin, 0, cos]] nearest to M in the Frobenius norm.
  return {std::acos(c) * deg, std::atan2(M(0, 2) - M(2, 0), M(0, 0) + M(2, 2)) * deg};
}

}  // namespace sdfkit
