// Camera-pose errors as in DISN's Table 3: d3D, the mean distance between a shape's points transformed by the
// predicted and by the true camera (object frame units), and d2D, the mean reprojection error in pixels.
#pragma once

#include "camera/camera.h"
#include "core/types.h"

#include <utility>
#include <vector>

namespace sdfkit {

struct PoseErrors {
  double d3d = 0;        ///< mean_i |(R_p x_i + t_p) - (R_t x_i + t_t)|
  double d2d = 0;        ///< mean_i |pi_p(x_i) - pi_t(x_i)| over points in front of both cameras (pixels)
  long points_2d = 0;    ///< points used for d2D (z_cam > 0 in both cameras)
};

/// Both errors over the #P x 3 object-frame points X (e.g. the shape's 2048 sample points). Each camera
/// projects with its own K. Throws InvalidInput for no points or non-finite coordinates; d2D is 0 with
/// points_2d = 0 when no point is in front of both cameras.
PoseErrors pose_errors(const Points& X, const Camera& predicted, const Camera& truth);

/// The errors modulo the shape's own symmetries: each of d3D and d2D is the smallest over the true camera and the
/// true camera composed with each symmetry g (R_t g, t_t), which sees a shape with gX = X exactly as the true
/// camera does, so that an image cannot tell them apart. `symmetries` are object-frame rotations (e.g. from
/// sdf/symmetry.h); empty gives pose_errors. points_2d is that of the d2D minimum.
PoseErrors pose_errors_modulo(const Points& X, const Camera& predicted, const Camera& truth,
                              const std::vector<Mat3>& symmetries);

/// The two numbers alone.
double pose_d3d(const Points& X, const Camera& predicted, const Camera& truth);
double pose_d2d(const Points& X, const Camera& predicted, const Camera& truth);

/// The rotation error in degrees: {the geodesic angle between R_est and R_true, the turn phi about the object's
/// vertical axis (+y) nearest to it}, with R_est ~ R_true R_y(phi) and phi in [-180, 180]; a whole-view flip reads
/// about +-180. Both rotations world (object frame) -> camera.
std::pair<double, double> rotation_error_degrees(const Mat3& R_est, const Mat3& R_true);

}  // namespace sdfkit
