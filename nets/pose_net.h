// The camera pose estimator (DISN's camera network, made small because no ImageNet weights exist here):
//
//   image 3 x 137 x 137 (network_image(): RGB in [0,1], white background; centred by -0.5 inside)
//   -> conv 5x5/2 (w) -> conv 3x3/2 (2w) -> conv 3x3/2 (4w) -> conv 3x3/2 (8w) -> conv 3x3/1 (8w)
//   -> conv 3x3/2 (4w) -> flatten (4w x 5 x 5) -> FC 256           (LeakyReLU 0.2 after every layer)
//   -> rotation head FC 256 -> 128 -> 6, Gram-Schmidt (camera/rotation6d.h) -> R (world -> camera)
//   -> distance head FC 256 -> 32 -> 1, d = d_min + sigmoid(z) (d_max - d_min)
//
// The camera looks at the object-frame origin, so t = (0, 0, d) and K is DISN's (f = 149.84375, c = 68.5).
// Distance range: DISN uses sigmoid * 0.4 + 0.6 times 1.75, i.e. [1.05, 1.75] ShapeNet units; our view sets
// (camera/views.h) put the camera at 2.45..3.0 unit-sphere radii, so the default range is [2.3, 3.15].
//
// Loss (DISN's L_cam): mean over items and over the shape's sample points p_i of
//   |(R_pred p_i + t_pred) - (R_true p_i + t_true)|^2.
#pragma once

#include "camera/camera.h"
#include "nets/layers.h"

#include <memory>
#include <vector>

namespace sdfkit {

struct PoseNetSettings {
  int width = 16;        ///< channels of the first conv (later convs: 2w, 4w, 8w)
  int image_size = 137;  ///< input side (the dataset's network_image size)
  int feature = 256;     ///< shared feature size
  double distance_min = 2.3;
  double distance_max = 3.15;

  [[nodiscard]] Json to_json() const;
  static PoseNetSettings from_json(const Json& j);
};

/// Predicted cameras of a batch.
struct PosePrediction {
  std::vector<Camera> cameras;
  std::vector<Eigen::Matrix<float, 6, 1>> rot6d;  ///< raw 6D outputs
};

class PoseNet {
 public:
  /// with_grads = false builds the inference-only model (no gradient buffers).
  explicit PoseNet(const PoseNetSettings& settings = {}, bool with_grads = true);
  PoseNet(const PoseNet&) = delete;
  PoseNet& operator=(const PoseNet&) = delete;

  [[nodiscard]] const PoseNetSettings& settings() const { return s_; }
  /// Settings + layer list, stored in checkpoints and compared on load.
  [[nodiscard]] Json architecture() const;
  [[nodiscard]] size_t n_params() const { return store_.size(); }
  ParamStore<float>& params() { return store_; }
  void init(uint64_t seed) { store_.init(seed); }

  /// images: B x (3 * S * S) channels-first rows (SdfBatch::images / Dataset::input), S = image_size.
  [[nodiscard]] PosePrediction predict(const MatrixXfR& images);

  /// One training forward + backward: returns the batch's L_cam and ADDS the gradients of weight x L_cam to the
  /// parameter gradients (call params().zero_grad() first). points[b] are item b's object-frame points. Data-
  /// parallel training runs one item per replica with weight 1 / batch (nets/pose_train.cpp).
  double forward_backward(const MatrixXfR& images, const std::vector<PointsF>& points,
                          const std::vector<Camera>& truth, double weight = 1.0);
  /// Make this network a replica of `master` (same settings): it reads master's parameter values and owns its
  /// activations and gradient buffer (ParamStore::share_values).
  void share_parameters(PoseNet& master) { store_.share_values(master.store_); }
  /// L_cam without gradients (validation).
  double loss(const MatrixXfR& images, const std::vector<PointsF>& points, const std::vector<Camera>& truth);

  /// Floating-point operations of one training step on `batch` images (Layer::forward_flops; backward = 2x
  /// forward less the image gradient, which is not computed).
  [[nodiscard]] double train_step_flops(int batch) const;

  /// Camera from the raw head outputs (6D rotation, distance logit).
  [[nodiscard]] Camera camera_from_outputs(const Eigen::Matrix<float, 6, 1>& b, float z) const;

 private:
  void run(const MatrixXfR& images, bool training);
  PoseNetSettings s_;
  Sequential<float> trunk_, rot_head_, dist_head_;
  ParamStore<float> store_;
  Tensor x_, feat_, rot_, dist_;
};

/// L_cam of one item and its gradient wrt (R_pred, d_pred); exposed for tests.
/// Returns mean_i |(R p_i + (0,0,d)) - (R_t p_i + t_t)|^2.
double pose_point_loss(const Eigen::Matrix3d& R, double d, const PointsF& points, const Camera& truth,
                       Eigen::Matrix3d* dR, double* dd);

}  // namespace sdfkit
