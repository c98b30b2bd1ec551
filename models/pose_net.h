// The camera pose estimator (DISN's camera network, made small because no ImageNet weights exist here):
//
//   image 3 x 137 x 137 (network_image(): RGB in [0,1], white background; centred by -0.5 inside)
//   -> conv 5x5/2 (w) -> conv 3x3/2 (2w) -> conv 3x3/2 (4w) -> conv 3x3/2 (8w) -> conv 3x3/1 (8w)
//   -> conv 3x3/2 (4w) -> flatten (4w x 5 x 5) -> FC 256           (LeakyReLU 0.2 after every layer)
//   with extra_convs = n > 0, n more conv 3x3/1 after the second and after the third convolution (at 35 and 18 px,
//   2w and 4w channels): a deeper encoder at about 1.7 times the compute for n = 1 (width 32)
//   -> rotation head FC 256 -> 128 -> 6, Gram-Schmidt (camera/rotation6d.h) -> R (world -> camera)
//   -> distance head FC 256 -> 32 -> 1, d = d_min + sigmoid(z) (d_max - d_min)
//   -> optional azimuth head FC 256 -> 128 -> K logits (azimuth_bins = K > 0): a coarse classifier of the camera
//      centre's azimuth about the object's +y axis, bins centred at k * 360 / K
//   -> optional centre head FC 256 -> 32 -> 2 (centre_head): where the object-frame origin appears, o = (p - c) / f
//      for its image position p, the image centre c and DISN's focal length f
//
// The camera looks at the object-frame origin, so t = (0, 0, d) and K is DISN's (f = 149.84375, c = 68.5); with the
// centre head the principal point is c + f o instead: the camera of an image cropped around an off-centre object,
// as recon's reframing of photos makes them (a render shows the origin at the centre, o = 0).
// Distance range: DISN uses sigmoid * 0.4 + 0.6 times 1.75, i.e. [1.05, 1.75] ShapeNet units; our view sets
// (camera/views.h) put the camera at 2.45..3.0 unit-sphere radii, so the default range is [2.3, 3.15].
//
// Loss (DISN's L_cam): mean over items and over the shape's sample points p_i of
//   |(R_pred p_i + t_pred) - (R_true p_i + t_true)|^2.
// Two additions, both optional and both measured in docs/results/pose.md:
//  * modulo symmetries: when an item comes with the rotations g that map its shape onto itself, its L_cam is the
//    smallest over the true camera and its twins (R_true g, t_true), which an image cannot tell apart (the
//    gradient is that of the minimum);
//  * azimuth head: cross-entropy of the K logits against a soft one-hot of the true azimuth (split linearly
//    between the two nearest bin centres; averaged over the twins), weighted by azimuth_weight. At inference it
//    checks the regressed rotation for flips (azimuth_flip_shift): when the classifier puts clearly more mass at the
//    regressed azimuth turned by a whole number of bins, the camera is turned about +y by that amount. The 6D head
//    keeps the fine pose; the classifier only picks the mode.
// With the centre head, its loss d_t^2 |o - o_t|^2 (the origin's sideways displacement at the true distance d_t,
// in L_cam's units) is added with weight centre_weight.
#pragma once

#include "camera/camera.h"
#include "core/json.h"
#include "nets/layers.h"
#include "nets/optim.h"

#include <string>

#include <memory>
#include <vector>

namespace sdfkit {

struct PoseNetSettings {
  int width = 16;        ///< channels of the first conv (later convs: 2w, 4w, 8w)
  int extra_convs = 0;   ///< conv 3x3/1 layers added after the 2nd and after the 3rd convolution each (0..2)
  int image_size = 137;  ///< input side (the dataset's network_image size)
  int feature = 256;     ///< shared feature size
  double distance_min = 2.3;
  double distance_max = 3.15;
  int azimuth_bins = 0;  ///< K of the azimuth classifier head (0 = no head, as the models before it)
  bool centre_head = false;  ///< regress the principal point (where the origin appears; false = the image centre)

  [[nodiscard]] Json to_json() const;
  static PoseNetSettings from_json(const Json& j);
};

/// Predicted cameras of a batch.
struct PosePrediction {
  std::vector<Camera> cameras;      ///< the estimate: the regressed camera after the flip check
  std::vector<Camera> regressed;    ///< the 6D + distance heads' camera, before the flip check
  std::vector<double> azimuth_shift;  ///< degrees the flip check turned each camera about +y (0 = kept)
  std::vector<Eigen::Matrix<float, 6, 1>> rot6d;  ///< raw 6D outputs
  std::vector<std::vector<float>> azimuth_prob;   ///< softmax of the azimuth head (empty without the head)
  /// With mirror TTA: degrees between the rotations read from the image and from its mirror (empty without it).
  std::vector<double> mirror_angle;
};

/// Per-item options of a training forward/backward.
struct PoseLossOptions {
  /// symmetries[b]: object-frame rotations mapping item b's shape onto itself (empty or absent = none).
  const std::vector<std::vector<Mat3>>* symmetries = nullptr;
  double azimuth_weight = 0;  ///< weight of the azimuth cross-entropy (needs the head; 0 = head untrained)
  double centre_weight = 1;   ///< weight of the centre head's loss (ignored without the head)
};

/// Default margin of the flip check (PoseNet::set_flip_check): with the mirror TTA's averaged probabilities, 1 (turn
/// whenever another azimuth has more mass) scores best on the validation split (d2D 6.44 px against 6.63 at 1.5).
inline constexpr double kDefaultFlipCheck = 1.0;
/// Mirror TTA: the two readings are averaged when their rotations are at most this many degrees apart.
inline constexpr double kMirrorAgreeDeg = 30.0;

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
  /// Margin of the flip check applied by predict() when the model has an azimuth head (azimuth_flip_shift);
  /// 0 turns it off. Throws InvalidInput for a negative or non-finite margin.
  void set_flip_check(double margin);
  [[nodiscard]] double flip_check() const { return flip_check_; }
  /// Mirror test-time augmentation in predict(): the network also reads each image flipped left to right, which
  /// shows the object mirrored across its x = 0 plane through mirror_camera() of the true camera (the same object
  /// when it is symmetric about that plane, as ShapeNet's and the benchmark's shapes are). The second reading,
  /// mirrored back, is a second estimate of the camera: when the two rotations are within kMirrorAgreeDeg they are
  /// averaged (the rotation nearest to their sum, the mean of the translations and principal points), otherwise the
  /// reading whose azimuth the classifier supports more is kept (the image's own on ties). Without the azimuth head
  /// they are always averaged (but when exactly opposite: the image's own).
  /// The azimuth probabilities are the mean of the image's and the mirrored ones (bin k <-> bin -k), and the flip
  /// check runs on them. Costs a second forward pass.
  void set_mirror_tta(bool on) { mirror_tta_ = on; }
  [[nodiscard]] bool mirror_tta() const { return mirror_tta_; }
  /// The mirror TTA's agreement angle (default kMirrorAgreeDeg): readings at most this many degrees apart are
  /// averaged. InvalidInput outside [0, 180].
  void set_mirror_agree(double degrees);
  [[nodiscard]] double mirror_agree() const { return mirror_agree_deg_; }
  /// Zoom test-time augmentation in predict(): the network also reads each image magnified by each k of `zooms`
  /// about its centre (zoom_image, train/dataset.h; a k > 1 is lowered so that the object stays in the frame, as
  /// the training zoom does), each with its mirror under the mirror TTA. A reading of an image magnified by k is
  /// read back at distance k d and principal-point offset / k (the pose training's zoom moves the camera,
  /// ZoomAugmentSettings::kDistance). The readings whose rotation is within the agreement angle (mirror_agree) of
  /// the unzoomed one are averaged with it (rotation nearest to the sum, mean translation and intrinsics); the
  /// azimuth probabilities of every level are averaged before the flip check. Empty (default) = off. Costs one
  /// more forward pass (two with the mirror TTA) per magnification. InvalidInput for a k outside [0.5, 2] or 1.
  void set_zoom_tta(const std::vector<double>& zooms);
  [[nodiscard]] const std::vector<double>& zoom_tta() const { return zoom_tta_; }

  /// One training forward + backward: returns the batch's L_cam and ADDS the gradients of weight x L_cam to the
  /// parameter gradients (call params().zero_grad() first). points[b] are item b's object-frame points. Data-
  /// parallel training runs one item per replica with weight 1 / batch (train/pose_train.cpp).
  /// With options: L_cam modulo each item's symmetries and the weighted azimuth cross-entropy (its mean over the
  /// items goes to *azimuth_ce when given), and with the centre head its weighted loss (the unweighted mean to
  /// *centre_loss when given). The return value is L_cam alone.
  double forward_backward(const MatrixXfR& images, const std::vector<PointsF>& points,
                          const std::vector<Camera>& truth, double weight = 1.0, const PoseLossOptions& options = {},
                          double* azimuth_ce = nullptr, double* centre_loss = nullptr);
  /// Make this network a replica of `master` (same settings): it reads master's parameter values and owns its
  /// activations and gradient buffer (ParamStore::share_values).
  void share_parameters(PoseNet& master) { store_.share_values(master.store_); }
  /// L_cam without gradients (validation).
  double loss(const MatrixXfR& images, const std::vector<PointsF>& points, const std::vector<Camera>& truth);

  /// Floating-point operations of one training step on `batch` images (Layer::forward_flops; backward = 2x
  /// forward less the image gradient, which is not computed).
  [[nodiscard]] double train_step_flops(int batch) const;

  /// Take the parameters of a network with the same settings except the distance range and the centre head
  /// (`from`), re-expressing its distance head in this network's range: the head's logit z becomes alpha z + beta
  /// (distance_logit_remap), so that the predicted distance and its slope at the middle of `from`'s range are
  /// unchanged. When this network has a centre head and `from` has none, the head's last layer starts at zero (the
  /// image centre, `from`'s answer) and its first layer keeps this network's initialisation. Throws InvalidInput
  /// when the settings differ otherwise, `from` has a centre head this one lacks, or the middle of `from`'s range is
  /// outside this one.
  void adopt_parameters(const PoseNet& from);

  /// Camera from the raw head outputs (6D rotation, distance logit, centre o or null for the image centre).
  [[nodiscard]] Camera camera_from_outputs(const Eigen::Matrix<float, 6, 1>& b, float z,
                                           const float* centre = nullptr) const;

 private:
  void run(const MatrixXfR& images, bool training);
  PoseNetSettings s_;
  Sequential<float> trunk_, rot_head_, dist_head_, az_head_, centre_head_;
  ParamStore<float> store_;
  Tensor x_, feat_, rot_, dist_, az_, centre_;
  double flip_check_ = kDefaultFlipCheck;
  bool mirror_tta_ = false;
  double mirror_agree_deg_ = kMirrorAgreeDeg;
  std::vector<double> zoom_tta_;
};

/// L_cam of one item and its gradient wrt (R_pred, d_pred); exposed for tests.
/// Returns mean_i |(R p_i + (0,0,d)) - (R_t p_i + t_t)|^2.
double pose_point_loss(const Eigen::Matrix3d& R, double d, const PointsF& points, const Camera& truth,
                       Eigen::Matrix3d* dR, double* dd);

/// L_cam modulo symmetries: the smallest pose_point_loss over the true camera and its twins (R_t g, t_t), g in
/// `symmetries` (first minimum on ties; the gradient is that twin's). *twin receives the index of the minimum
/// (0 = the true camera, k = symmetries[k - 1]).
double pose_point_loss_modulo(const Eigen::Matrix3d& R, double d, const PointsF& points, const Camera& truth,
                              const std::vector<Mat3>& symmetries, Eigen::Matrix3d* dR, double* dd,
                              int* twin = nullptr);

/// Where a camera shows the object-frame origin relative to its image centre, in focal lengths: o = (c' - c) / f
/// for principal point c', image centre c = (width / 2, height / 2) and focal lengths (f_x, f_y). 0 for a render.
Eigen::Vector2d camera_centre_offset(const Camera& cam);

/// The centre head's loss of one item, d_t^2 |o - o_t|^2 with o_t = camera_centre_offset(truth) and d_t the true
/// camera's distance |t|; its gradient wrt o in *grad when given.
double pose_centre_loss(const Eigen::Vector2d& o, const Camera& truth, Eigen::Vector2d* grad);

/// (alpha, beta) such that d(z) = a + (b - a) sigmoid(z) and d'(alpha z + beta) = a2 + (b2 - a2) sigmoid(alpha z +
/// beta) agree in value and first derivative at z = 0 (d = (a + b) / 2). Throws InvalidInput when (a + b) / 2 is
/// not strictly inside (a2, b2).
std::pair<double, double> distance_logit_remap(double a, double b, double a2, double b2);

/// The rotation nearest to M in the Frobenius norm (U V^T of M's SVD, det +1): the chordal mean of rotations whose
/// sum is M. Throws InvalidInput when M is singular (e.g. two opposite rotations), where no mean is defined.
Mat3 nearest_rotation(const Mat3& M);
/// Angle in degrees of the rotation taking A to B (geodesic distance on SO(3)).
double rotation_angle_deg(const Mat3& A, const Mat3& B);
/// Images (B x 3 S S channels-first rows) flipped left to right.
MatrixXfR flip_images(const MatrixXfR& images, int size);
/// Azimuth probabilities of the mirrored view: bin k gets bin (K - k) mod K (the azimuth a becomes -a).
std::vector<float> mirror_azimuth_prob(const std::vector<float>& prob);
/// Azimuth of a camera centre (degrees in [0, 360), camera.h's convention: 0 at +z, 90 at +x).
double camera_azimuth(const Camera& cam);

/// Adds `weight` x the soft one-hot of `azimuth_deg` over K bins centred at k * 360 / K (split linearly between
/// the two nearest centres) to target[0..K).
void add_azimuth_target(double azimuth_deg, int bins, double weight, float* target);

/// Cross-entropy -sum_k y_k log softmax(z)_k of K logits against a target distribution y (sum 1), computed stably;
/// dz (may be null) receives softmax(z) - y, and prob (may be null) softmax(z).
double softmax_cross_entropy(const float* logits, const float* target, int bins, double* dz, double* prob);

/// The classifier's probability mass near an azimuth: sum_k p_k max(0, 1 - |angle(azimuth, c_k)| / (2 w)), with
/// c_k = k w, w = 360 / K: the mass of the bins within two bin widths, tapered linearly.
double azimuth_window_mass(const std::vector<float>& prob, double azimuth_deg);

/// The flip check: among the azimuths a + j w (j = 0..K-1, keeping the regressed azimuth a's position inside its
/// bin), the one of largest window mass; its shift j w (in (-180, 180], degrees) is returned when that mass
/// exceeds `margin` x the mass at a, else 0. margin 0 = off (always 0).
double azimuth_flip_shift(const std::vector<float>& prob, double azimuth_deg, double margin);

/// Model file = checkpoint with "kind": "pose_model", the architecture and the parameters (+ training state).
void save_pose_model(const std::string& path, PoseNet& net, const Json& training = Json::object(),
                     const Optimizer* optimizer = nullptr);
/// Inference-only network from a model file (IoError naming the file when missing/corrupt/not a pose model).
std::unique_ptr<PoseNet> load_pose_model(const std::string& path, Json* training = nullptr);

}  // namespace sdfkit
