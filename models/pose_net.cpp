#include "models/pose_net.h"

#include "camera/rotation6d.h"
#include "core/json.h"
#include "models/net_input.h"
#include "nets/checkpoint.h"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {

Json PoseNetSettings::to_json() const {
  Json j = {{"width", width},
            {"image_size", image_size},
            {"feature", feature},
            {"distance_min", distance_min},
            {"distance_max", distance_max}};
  if (extra_convs > 0) j["extra_convs"] = extra_convs;     // absent in the 6-convolution encoder's models
  if (azimuth_bins > 0) j["azimuth_bins"] = azimuth_bins;  // absent in models without the head
  if (centre_head) j["centre_head"] = true;                 // same
  return j;
}

PoseNetSettings PoseNetSettings::from_json(const Json& j) {
  PoseNetSettings s;
  try {
    s.width = j.at("width").get<int>();
    s.image_size = j.at("image_size").get<int>();
    s.feature = j.at("feature").get<int>();
    s.distance_min = j.at("distance_min").get<double>();
    s.distance_max = j.at("distance_max").get<double>();
    s.extra_convs = j.value("extra_convs", 0);
    s.azimuth_bins = j.value("azimuth_bins", 0);
    s.centre_head = j.value("centre_head", false);
  } catch (const Json::exception& e) {
    throw IoError(std::string("pose network settings: malformed (") + e.what() + ")");
  }
  return s;
}

namespace {
constexpr double kSlope = 0.2;
constexpr double kPi = 3.14159265358979323846;

void conv_block(Sequential<float>& s, int in, int out, int k, int stride) {
  s.emplace<Conv2d<float>>(Conv2dSettings{in, out, k, stride, k / 2, true});
  s.add(leaky_relu<float>(kSlope));
}
}  // namespace

PoseNet::PoseNet(const PoseNetSettings& settings, bool with_grads) : s_(settings) {
  require(s_.width > 0 && s_.feature > 0 && s_.image_size >= 32, "pose net: width, feature > 0 and image >= 32");
  require(s_.distance_min > 0 && s_.distance_max > s_.distance_min, "pose net: need 0 < distance_min < distance_max");
  require(s_.azimuth_bins == 0 || (s_.azimuth_bins >= 4 && s_.azimuth_bins <= 360),
          "pose net: azimuth bins must be 0 (no head) or 4..360");
  require(s_.extra_convs >= 0 && s_.extra_convs <= 2, "pose net: extra convolutions must be 0, 1 or 2");
  const int w = s_.width;
  conv_block(trunk_, 3, w, 5, 2);
  conv_block(trunk_, w, 2 * w, 3, 2);
  for (int k = 0; k < s_.extra_convs; ++k) conv_block(trunk_, 2 * w, 2 * w, 3, 1);
  conv_block(trunk_, 2 * w, 4 * w, 3, 2);
  for (int k = 0; k < s_.extra_convs; ++k) conv_block(trunk_, 4 * w, 4 * w, 3, 1);
  conv_block(trunk_, 4 * w, 8 * w, 3, 2);
  conv_block(trunk_, 8 * w, 8 * w, 3, 1);
  conv_block(trunk_, 8 * w, 4 * w, 3, 2);
  trunk_.emplace<Flatten<float>>();
  const Shape conv_out = trunk_.output_shape({1, 3, s_.image_size, s_.image_size});
  trunk_.emplace<Linear<float>>(static_cast<int>(conv_out[1]), s_.feature);
  trunk_.add(leaky_relu<float>(kSlope));
  rot_head_.emplace<Linear<float>>(s_.feature, 128);
  rot_head_.add(leaky_relu<float>(kSlope));
  rot_head_.emplace<Linear<float>>(128, 6);
  dist_head_.emplace<Linear<float>>(s_.feature, 32);
  dist_head_.add(leaky_relu<float>(kSlope));
  dist_head_.emplace<Linear<float>>(32, 1);
  store_.add(trunk_);
  store_.add(rot_head_);
  store_.add(dist_head_);
  if (s_.azimuth_bins > 0) {
    az_head_.emplace<Linear<float>>(s_.feature, 128);
    az_head_.add(leaky_relu<float>(kSlope));
    az_head_.emplace<Linear<float>>(128, s_.azimuth_bins);
    store_.add(az_head_);
  }
  if (s_.centre_head) {  // last in the store: a model without it is a prefix (adopt_parameters)
    centre_head_.emplace<Linear<float>>(s_.feature, 32);
    centre_head_.add(leaky_relu<float>(kSlope));
    centre_head_.emplace<Linear<float>>(32, 2);
    store_.add(centre_head_);
  }
  store_.allocate(with_grads);
  trunk_.training(with_grads);
  rot_head_.training(with_grads);
  dist_head_.training(with_grads);
  az_head_.training(with_grads);
  centre_head_.training(with_grads);
}

void PoseNet::set_flip_check(double margin) {
  require(std::isfinite(margin) && margin >= 0, "pose net: the flip-check margin must be >= 0 (0 = off)");
  flip_check_ = margin;
}

void PoseNet::set_mirror_agree(double degrees) {
  require(std::isfinite(degrees) && degrees >= 0 && degrees <= 180,
          "pose net: the mirror TTA's agreement angle must be in [0, 180] degrees");
  mirror_agree_deg_ = degrees;
}

double PoseNet::train_step_flops(int batch) const {
  const Shape in{batch, 3, s_.image_size, s_.image_size};
  const Shape feat = trunk_.output_shape(in);
  double fwd = trunk_.forward_flops(in) + rot_head_.forward_flops(feat) + dist_head_.forward_flops(feat);
  if (s_.azimuth_bins > 0) fwd += az_head_.forward_flops(feat);
  if (s_.centre_head) fwd += centre_head_.forward_flops(feat);
  return 3.0 * fwd - trunk_[0].forward_flops(in);  // the image gradient of the first convolution is not computed
}

Json PoseNet::architecture() const {
  return {{"model", "pose_net"}, {"settings", s_.to_json()}, {"layers", store_.architecture()}};
}

void PoseNet::run(const MatrixXfR& images, bool training) {
  const int S = s_.image_size;
  require(images.cols() == 3 * S * S && images.rows() > 0,
          "pose net: expected B x " + std::to_string(3 * S * S) + " images, got " + std::to_string(images.rows()) +
              " x " + std::to_string(images.cols()));
  trunk_.training(training);
  rot_head_.training(training);
  dist_head_.training(training);
  az_head_.training(training);
  centre_head_.training(training);
  x_.resize({images.rows(), 3, S, S});
  // Centre the [0, 1] input.
  Eigen::Map<MatrixXfR>(x_.ptr(), images.rows(), images.cols()) = images.array() - 0.5f;
  trunk_.forward(x_, feat_);
  rot_head_.forward(feat_, rot_);
  dist_head_.forward(feat_, dist_);
  if (s_.azimuth_bins > 0) az_head_.forward(feat_, az_);
  if (s_.centre_head) centre_head_.forward(feat_, centre_);
}

std::pair<double, double> distance_logit_remap(double a, double b, double a2, double b2) {
  const double mid = 0.5 * (a + b);
  require(b > a && b2 > a2 && mid > a2 && mid < b2,
          "pose net: the middle of the distance range [" + std::to_string(a) + ", " + std::to_string(b) +
              "] is not inside [" + std::to_string(a2) + ", " + std::to_string(b2) + "]");
  const double s = (mid - a2) / (b2 - a2);  // sigmoid(beta)
  const double beta = std::log(s / (1 - s));
  const double alpha = 0.25 * (b - a) / ((b2 - a2) * s * (1 - s));
  return {alpha, beta};
}

void PoseNet::adopt_parameters(const PoseNet& from) {
  PoseNetSettings same = from.s_;
  same.distance_min = s_.distance_min;
  same.distance_max = s_.distance_max;
  same.centre_head = s_.centre_head;
  require(same.to_json() == s_.to_json() && (s_.centre_head || !from.s_.centre_head),
          "pose net: cannot adopt the parameters of another architecture (" + from.s_.to_json().dump() + " vs " +
              s_.to_json().dump() + ")");
  const auto [alpha, beta] = distance_logit_remap(from.s_.distance_min, from.s_.distance_max, s_.distance_min,
                                                  s_.distance_max);
  // `from`'s parameters are a prefix of this store (the centre head comes last).
  std::copy(from.store_.values.begin(), from.store_.values.end(), store_.values.begin());
  if (s_.centre_head && !from.s_.centre_head) {
    const Layer<float>& out = centre_head_[centre_head_.size() - 1];
    float* c = store_.values.data() + (out.params() - store_.values.data());
    std::fill(c, c + out.n_params(), 0.0f);
  }
  // The distance head's last layer (32 -> 1: 32 weights, then the bias) becomes alpha x + beta.
  const Layer<float>& last = dist_head_[dist_head_.size() - 1];
  float* w = store_.values.data() + (last.params() - store_.values.data());
  for (size_t i = 0; i + 1 < last.n_params(); ++i) w[i] = static_cast<float>(alpha * w[i]);
  w[last.n_params() - 1] = static_cast<float>(alpha * w[last.n_params() - 1] + beta);
}

Camera PoseNet::camera_from_outputs(const Eigen::Matrix<float, 6, 1>& b, float z, const float* centre) const {
  Camera cam;
  cam.K = disn_intrinsics(s_.image_size, s_.image_size);
  cam.width = cam.height = s_.image_size;
  if (centre) {
    cam.K(0, 2) += cam.K(0, 0) * static_cast<double>(centre[0]);
    cam.K(1, 2) += cam.K(1, 1) * static_cast<double>(centre[1]);
  }
  const Vec6T<double> bd = b.cast<double>();
  cam.R = rot6d_to_matrix(bd);
  const double sig = 1.0 / (1.0 + std::exp(-static_cast<double>(z)));
  cam.t = Vec3(0, 0, s_.distance_min + sig * (s_.distance_max - s_.distance_min));
  return cam;
}

void PoseNet::set_zoom_tta(const std::vector<double>& zooms) {
  for (double k : zooms)
    require(std::isfinite(k) && k >= 0.5 && k <= 2 && k != 1,
            "pose net: a zoom TTA magnification must be in [0.5, 2] and not 1");
  zoom_tta_ = zooms;
}

PosePrediction PoseNet::predict(const MatrixXfR& images) {
  const Eigen::Index B = images.rows();
  const int S = s_.image_size;
  // The network reads every image at each zoom level (level 0: as given, then zoom_tta_), each followed by its
  // mirror with the mirror TTA: level z's rows start at z * per * B.
  const size_t Z = 1 + zoom_tta_.size();
  const Eigen::Index per = mirror_tta_ ? 2 : 1;
  std::vector<double> mag(Z * static_cast<size_t>(B), 1.0);  // magnification applied to (level, image)
  MatrixXfR all(static_cast<Eigen::Index>(Z) * per * B, images.cols());
  for (size_t z = 0; z < Z; ++z) {
    const Eigen::Index r0 = static_cast<Eigen::Index>(z) * per * B;
    if (z == 0) {
      all.middleRows(r0, B) = images;
    } else {
      require(images.cols() == 3L * S * S, "pose net: the zoom TTA reads 3-channel images");
      for (Eigen::Index b = 0; b < B; ++b) {
        const Eigen::VectorXf row = images.row(b).transpose();
        // Never magnify an object out of the frame (the training zoom's rule).
        const double k = std::min(zoom_tta_[z - 1], std::max(1.0, max_zoom_inside(row, S)));
        mag[z * static_cast<size_t>(B) + static_cast<size_t>(b)] = k;
        all.row(r0 + b) = (k == 1 ? row : zoom_image(row, S, k)).transpose();
      }
    }
    if (mirror_tta_) all.middleRows(r0 + B, B) = flip_images(all.middleRows(r0, B), S);
  }
  run(all, false);
  const int K = s_.azimuth_bins;
  // Camera and azimuth probabilities of row r of the last run, read for an image magnified by k: the distance
  // is k times the one read (the training zoom moves the camera, ZoomAugmentSettings::kDistance) and the
  // principal point's offset from the image centre 1 / k times.
  const auto reading = [&](Eigen::Index r, double k, std::vector<float>& prob) {
    Eigen::Matrix<float, 6, 1> v;
    for (int i = 0; i < 6; ++i) v[i] = rot_[r * 6 + i];
    prob.clear();
    if (K > 0) {
      std::vector<double> pd(static_cast<size_t>(K));
      softmax_cross_entropy(az_.ptr() + r * K, nullptr, K, nullptr, pd.data());
      prob.assign(pd.begin(), pd.end());
    }
    Camera cam = camera_from_outputs(v, dist_[r], s_.centre_head ? centre_.ptr() + r * 2 : nullptr);
    if (k != 1) {
      cam.t *= k;
      const double c = 0.5 * S;
      cam.K(0, 2) = unmagnified_coordinate(cam.K(0, 2), c, k);
      cam.K(1, 2) = unmagnified_coordinate(cam.K(1, 2), c, k);
    }
    return std::make_pair(v, cam);
  };
  // One zoom level's estimate of image b: its reading, combined with the mirror's under the mirror TTA.
  const auto level = [&](size_t z, Eigen::Index b, std::vector<float>& prob, Eigen::Matrix<float, 6, 1>* r6,
                         double* mirror_angle) {
    const Eigen::Index r0 = static_cast<Eigen::Index>(z) * per * B;
    const double k = mag[z * static_cast<size_t>(B) + static_cast<size_t>(b)];
    auto [v, cam] = reading(r0 + b, k, prob);
    if (r6) *r6 = v;
    if (!mirror_tta_) return cam;
    std::vector<float> mprob;
    const Camera other = mirror_camera(reading(r0 + B + b, k, mprob).second);
    mprob = mirror_azimuth_prob(mprob);
    for (size_t i = 0; i < prob.size(); ++i) prob[i] = 0.5f * (prob[i] + mprob[i]);
    const double angle = rotation_angle_deg(cam.R, other.R);
    if (mirror_angle) *mirror_angle = angle;
    // Without the azimuth head nothing tells the readings apart: they are always averaged, except when exactly
    // opposite (their sum is singular, no mean exists; a half turn apart is 2 cos(angle / 2) from singular).
    if (angle <= mirror_agree_deg_ || (K == 0 && angle < 179.9)) {
      cam.R = nearest_rotation(cam.R + other.R);
      cam.t = 0.5 * (cam.t + other.t);
      cam.K = 0.5 * (cam.K + other.K);
    } else if (K > 0 && azimuth_window_mass(prob, camera_azimuth(other)) >
                            azimuth_window_mass(prob, camera_azimuth(cam))) {
      cam = other;
    }
    return cam;
  };
  PosePrediction p;
  for (Eigen::Index b = 0; b < B; ++b) {
    std::vector<float> prob;
    Eigen::Matrix<float, 6, 1> r6;
    double angle = 0;
    Camera cam = level(0, b, prob, &r6, &angle);
    p.rot6d.push_back(r6);
    if (mirror_tta_) p.mirror_angle.push_back(angle);
    if (Z > 1) {
      // The other levels: their probabilities all enter the mean, their cameras when within the agreement angle
      // of level 0's (a level that reads another view does not drag the estimate half-way to it).
      Mat3 sum_r = cam.R;
      Vec3 sum_t = cam.t;
      Mat3 sum_k = cam.K;
      int n = 1;
      std::vector<double> sum_p(prob.begin(), prob.end());
      for (size_t z = 1; z < Z; ++z) {
        std::vector<float> zp;
        const Camera c = level(z, b, zp, nullptr, nullptr);
        for (size_t i = 0; i < zp.size(); ++i) sum_p[i] += zp[i];
        if (rotation_angle_deg(cam.R, c.R) <= mirror_agree_deg_) {
          sum_r += c.R;
          sum_t += c.t;
          sum_k += c.K;
          ++n;
        }
      }
      cam.R = nearest_rotation(sum_r);
      cam.t = sum_t / static_cast<double>(n);
      cam.K = sum_k / static_cast<double>(n);
      for (size_t i = 0; i < prob.size(); ++i) prob[i] = static_cast<float>(sum_p[i] / static_cast<double>(Z));
    }
    p.regressed.push_back(cam);
    double shift = 0;
    if (K > 0) {
      p.azimuth_prob.push_back(prob);
      shift = azimuth_flip_shift(prob, camera_azimuth(cam), flip_check_);
    }
    p.azimuth_shift.push_back(shift);
    p.cameras.push_back(shift == 0 ? cam : turn_about_vertical(cam, shift));
  }
  return p;
}

Mat3 nearest_rotation(const Mat3& M) {
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 sv = svd.singularValues();
  require(std::isfinite(sv[0]) && sv[2] > 1e-9 * std::max(sv[0], 1e-300),
          "nearest rotation: the matrix is singular (no mean of these rotations)");
  Mat3 D = Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

double rotation_angle_deg(const Mat3& A, const Mat3& B) {
  const double c = std::clamp(0.5 * ((A.transpose() * B).trace() - 1.0), -1.0, 1.0);
  return std::acos(c) * 180.0 / kPi;
}

MatrixXfR flip_images(const MatrixXfR& images, int size) {
  require(size > 0 && images.cols() % (static_cast<Eigen::Index>(size) * size) == 0,
          "flip images: rows are not C x " + std::to_string(size) + " x " + std::to_string(size));
  MatrixXfR out(images.rows(), images.cols());
  const Eigen::Index lines = images.cols() / size;
  for (Eigen::Index b = 0; b < images.rows(); ++b)
    for (Eigen::Index l = 0; l < lines; ++l)
      out.row(b).segment(l * size, size) = images.row(b).segment(l * size, size).reverse();
  return out;
}

std::vector<float> mirror_azimuth_prob(const std::vector<float>& prob) {
  const size_t K = prob.size();
  std::vector<float> out(K);
  for (size_t k = 0; k < K; ++k) out[k] = prob[(K - k) % K];
  return out;
}

double pose_point_loss(const Eigen::Matrix3d& R, double d, const PointsF& points, const Camera& truth,
                       Eigen::Matrix3d* dR, double* dd) {
  require(points.rows() > 0, "pose loss: no points");
  const Vec3 t(0, 0, d);
  const Eigen::Matrix3d DR = R - truth.R;
  const Vec3 Dt = t - truth.t;
  double s = 0;
  Eigen::Matrix3d gR = Eigen::Matrix3d::Zero();
  Vec3 gt = Vec3::Zero();
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Vec3 p = points.row(i).transpose().cast<double>();
    const Vec3 e = DR * p + Dt;
    s += e.squaredNorm();
    gR += e * p.transpose();
    gt += e;
  }
  const double inv = 1.0 / static_cast<double>(points.rows());
  if (dR) *dR = 2.0 * inv * gR;
  if (dd) *dd = 2.0 * inv * gt.z();
  return s * inv;
}

double pose_point_loss_modulo(const Eigen::Matrix3d& R, double d, const PointsF& points, const Camera& truth,
                              const std::vector<Mat3>& symmetries, Eigen::Matrix3d* dR, double* dd, int* twin) {
  double best = pose_point_loss(R, d, points, truth, dR, dd);
  int arg = 0;
  for (size_t k = 0; k < symmetries.size(); ++k) {
    Camera t = truth;
    t.R = truth.R * symmetries[k];
    Eigen::Matrix3d gR;
    double gd = 0;
    const double l = pose_point_loss(R, d, points, t, dR ? &gR : nullptr, dd ? &gd : nullptr);
    if (l < best) {
      best = l;
      arg = static_cast<int>(k) + 1;
      if (dR) *dR = gR;
      if (dd) *dd = gd;
    }
  }
  if (twin) *twin = arg;
  return best;
}

Eigen::Vector2d camera_centre_offset(const Camera& cam) {
  return {(cam.K(0, 2) - 0.5 * cam.width) / cam.K(0, 0), (cam.K(1, 2) - 0.5 * cam.height) / cam.K(1, 1)};
}

double pose_centre_loss(const Eigen::Vector2d& o, const Camera& truth, Eigen::Vector2d* grad) {
  const double d2 = truth.t.squaredNorm();
  const Eigen::Vector2d e = o - camera_centre_offset(truth);
  if (grad) *grad = 2.0 * d2 * e;
  return d2 * e.squaredNorm();
}

double camera_azimuth(const Camera& cam) { return look_at_params(cam).azimuth_deg; }

void add_azimuth_target(double azimuth_deg, int bins, double weight, float* target) {
  require(bins > 0 && std::isfinite(azimuth_deg), "azimuth target: need bins > 0 and a finite azimuth");
  const double u = azimuth_deg / (360.0 / bins);
  const double lo = std::floor(u), f = u - lo;
  const int j = static_cast<int>(((static_cast<long>(lo) % bins) + bins) % bins);
  target[j] += static_cast<float>(weight * (1.0 - f));
  target[(j + 1) % bins] += static_cast<float>(weight * f);
}

double softmax_cross_entropy(const float* logits, const float* target, int bins, double* dz, double* prob) {
  double m = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < bins; ++k) m = std::max(m, static_cast<double>(logits[k]));
  double sum = 0;
  for (int k = 0; k < bins; ++k) sum += std::exp(static_cast<double>(logits[k]) - m);
  const double log_sum = m + std::log(sum);
  double ce = 0;
  for (int k = 0; k < bins; ++k) {
    const double logp = static_cast<double>(logits[k]) - log_sum;
    const double p = std::exp(logp);
    const double y = target ? static_cast<double>(target[k]) : 0.0;
    if (y != 0) ce -= y * logp;
    if (prob) prob[k] = p;
    if (dz) dz[k] = p - y;
  }
  return ce;
}

namespace {
/// |a - b| on the circle, degrees in [0, 180].
double angle_between(double a, double b) {
  const double d = std::fmod(std::fabs(a - b), 360.0);
  return d > 180.0 ? 360.0 - d : d;
}
}  // namespace

double azimuth_window_mass(const std::vector<float>& prob, double azimuth_deg) {
  const int K = static_cast<int>(prob.size());
  require(K > 0, "azimuth window: no bins");
  const double w = 360.0 / K;
  double m = 0;
  for (int k = 0; k < K; ++k) m += prob[static_cast<size_t>(k)] * std::max(0.0, 1.0 - angle_between(azimuth_deg, k * w) / (2 * w));
  return m;
}

double azimuth_flip_shift(const std::vector<float>& prob, double azimuth_deg, double margin) {
  if (margin <= 0 || prob.empty()) return 0;
  const int K = static_cast<int>(prob.size());
  const double w = 360.0 / K;
  const double here = azimuth_window_mass(prob, azimuth_deg);
  double best = here;
  int arg = 0;
  for (int j = 1; j < K; ++j) {
    const double m = azimuth_window_mass(prob, azimuth_deg + j * w);
    if (m > best) {
      best = m;
      arg = j;
    }
  }
  if (arg == 0 || !(best > margin * here)) return 0;
  const double shift = arg * w;
  return shift > 180.0 ? shift - 360.0 : shift;
}

double PoseNet::forward_backward(const MatrixXfR& images, const std::vector<PointsF>& points,
                                 const std::vector<Camera>& truth, double weight, const PoseLossOptions& options,
                                 double* azimuth_ce, double* centre_loss) {
  require(store_.has_grads(), "pose net: forward_backward needs a model built with gradients");
  const Eigen::Index B = images.rows();
  require(static_cast<Eigen::Index>(points.size()) == B && static_cast<Eigen::Index>(truth.size()) == B,
          "pose net: one point set and one camera per image");
  require(!options.symmetries || static_cast<Eigen::Index>(options.symmetries->size()) == B,
          "pose net: one symmetry list per image");
  require(options.azimuth_weight >= 0 && std::isfinite(options.azimuth_weight),
          "pose net: the azimuth weight must be >= 0");
  require(options.azimuth_weight == 0 || s_.azimuth_bins > 0, "pose net: an azimuth weight needs the azimuth head");
  require(options.centre_weight >= 0 && std::isfinite(options.centre_weight),
          "pose net: the centre weight must be >= 0");
  run(images, true);
  Tensor drot(rot_.shape), ddist(dist_.shape);
  double total = 0, ce_total = 0;
  const double range = s_.distance_max - s_.distance_min;
  const double scale = weight / static_cast<double>(B);
  static const std::vector<Mat3> kNone;
  const int K = s_.azimuth_bins;
  Tensor daz;
  if (K > 0) daz.assign(az_.shape, 0.0f);  // an untrained head (weight 0) gets no gradient
  Tensor dcentre;
  double centre_total = 0;
  if (s_.centre_head) dcentre.assign(centre_.shape, 0.0f);
  for (Eigen::Index b = 0; b < B; ++b) {
    const std::vector<Mat3>& g = options.symmetries ? (*options.symmetries)[static_cast<size_t>(b)] : kNone;
    Vec6T<double> r;
    for (int k = 0; k < 6; ++k) r[k] = rot_[b * 6 + k];
    const Rot6dForward<double> f = rot6d_forward(r);
    const double sig = 1.0 / (1.0 + std::exp(-static_cast<double>(dist_[b])));
    Eigen::Matrix3d dR;
    double dd = 0;
    total += pose_point_loss_modulo(f.R, s_.distance_min + sig * range, points[b], truth[b], g, &dR, &dd);
    const Vec6T<double> db = rot6d_backward(f, dR) * scale;
    for (int k = 0; k < 6; ++k) drot[b * 6 + k] = static_cast<float>(db[k]);
    ddist[b] = static_cast<float>(dd * range * sig * (1.0 - sig) * scale);
    if (K > 0 && options.azimuth_weight > 0) {
      // The target: the true azimuth and those of the twins, equally.
      std::vector<float> y(static_cast<size_t>(K), 0.0f);
      const double share = 1.0 / static_cast<double>(g.size() + 1);
      add_azimuth_target(camera_azimuth(truth[b]), K, share, y.data());
      for (const Mat3& m : g) {
        Camera t = truth[b];
        t.R = truth[b].R * m;
        add_azimuth_target(camera_azimuth(t), K, share, y.data());
      }
      std::vector<double> dz(static_cast<size_t>(K));
      ce_total += softmax_cross_entropy(az_.ptr() + b * K, y.data(), K, dz.data(), nullptr);
      for (int k = 0; k < K; ++k) daz[b * K + k] = static_cast<float>(dz[static_cast<size_t>(k)] * options.azimuth_weight * scale);
    }
    if (s_.centre_head) {
      Eigen::Vector2d g;
      const Eigen::Vector2d o(static_cast<double>(centre_[b * 2]), static_cast<double>(centre_[b * 2 + 1]));
      centre_total += pose_centre_loss(o, truth[b], &g);
      dcentre[b * 2] = static_cast<float>(g[0] * options.centre_weight * scale);
      dcentre[b * 2 + 1] = static_cast<float>(g[1] * options.centre_weight * scale);
    }
  }
  Tensor dfeat_r, dfeat_d;
  rot_head_.backward(feat_, rot_, drot, &dfeat_r);
  dist_head_.backward(feat_, dist_, ddist, &dfeat_d);
  for (int64_t i = 0; i < dfeat_r.size(); ++i) dfeat_r[i] += dfeat_d[i];
  if (K > 0 && options.azimuth_weight > 0) {
    Tensor dfeat_a;
    az_head_.backward(feat_, az_, daz, &dfeat_a);
    for (int64_t i = 0; i < dfeat_r.size(); ++i) dfeat_r[i] += dfeat_a[i];
  }
  if (s_.centre_head) {
    Tensor dfeat_c;
    centre_head_.backward(feat_, centre_, dcentre, &dfeat_c);
    for (int64_t i = 0; i < dfeat_r.size(); ++i) dfeat_r[i] += dfeat_c[i];
  }
  trunk_.backward(x_, feat_, dfeat_r, nullptr);
  if (azimuth_ce) *azimuth_ce = ce_total / static_cast<double>(B);
  if (centre_loss) *centre_loss = centre_total / static_cast<double>(B);
  return total / static_cast<double>(B);
}

double PoseNet::loss(const MatrixXfR& images, const std::vector<PointsF>& points, const std::vector<Camera>& truth) {
  const PosePrediction p = predict(images);
  double total = 0;
  for (size_t b = 0; b < p.cameras.size(); ++b)
    total += pose_point_loss(p.cameras[b].R, p.cameras[b].t.z(), points.at(b), truth.at(b), nullptr, nullptr);
  return total / static_cast<double>(p.cameras.size());
}

// ------------------------------------------------------------------------------------------------ model files
namespace {
constexpr const char* kPoseKind = "pose_model";
}  // namespace

void save_pose_model(const std::string& path, PoseNet& net, const Json& training, const Optimizer* optimizer) {
  Checkpoint ck;
  ck.header["kind"] = kPoseKind;
  ck.header["architecture"] = net.architecture();
  ck.header["training"] = training;
  ck.set_block("params", std::vector<float>(net.params().values.begin(), net.params().values.end()));
  if (optimizer) ck.put_optimizer(*optimizer);
  save_checkpoint(path, ck);
}

std::unique_ptr<PoseNet> load_pose_model(const std::string& path, Json* training) {
  const Checkpoint ck = load_checkpoint(path);
  if (ck.header.value("kind", std::string()) != kPoseKind)
    throw IoError(path + ": not a pose model (kind '" + ck.header.value("kind", std::string()) + "')");
  PoseNetSettings s;
  try {
    s = PoseNetSettings::from_json(ck.header.at("architecture").at("settings"));
  } catch (const Json::exception&) {
    throw IoError(path + ": pose model without network settings");
  }
  std::unique_ptr<PoseNet> net;
  try {
    net = std::make_unique<PoseNet>(s, false);
  } catch (const InvalidInput& e) {
    throw IoError(path + ": pose model with impossible settings (" + e.what() + ")");
  }
  require_header_match(ck, "architecture", net->architecture(), path);
  const auto& p = ck.block("params", static_cast<long>(net->n_params()));
  std::copy(p.begin(), p.end(), net->params().values.begin());
  if (training) *training = ck.header.value("training", Json::object());
  return net;
}

}  // namespace sdfkit
