#include "nets/pose_net.h"

#include "camera/rotation6d.h"

#include <cmath>

namespace sdfkit {

Json PoseNetSettings::to_json() const {
  return {{"width", width},
          {"image_size", image_size},
          {"feature", feature},
          {"distance_min", distance_min},
          {"distance_max", distance_max}};
}

PoseNetSettings PoseNetSettings::from_json(const Json& j) {
  PoseNetSettings s;
  try {
    s.width = j.at("width").get<int>();
    s.image_size = j.at("image_size").get<int>();
    s.feature = j.at("feature").get<int>();
    s.distance_min = j.at("distance_min").get<double>();
    s.distance_max = j.at("distance_max").get<double>();
  } catch (const Json::exception& e) {
    throw IoError(std::string("pose network settings: malformed (") + e.what() + ")");
  }
  return s;
}

namespace {
constexpr double kSlope = 0.2;

void conv_block(Sequential<float>& s, int in, int out, int k, int stride) {
  s.emplace<Conv2d<float>>(Conv2dSettings{in, out, k, stride, k / 2, true});
  s.add(leaky_relu<float>(kSlope));
}
}  // namespace

PoseNet::PoseNet(const PoseNetSettings& settings, bool with_grads) : s_(settings) {
  require(s_.width > 0 && s_.feature > 0 && s_.image_size >= 32, "pose net: width, feature > 0 and image >= 32");
  require(s_.distance_min > 0 && s_.distance_max > s_.distance_min, "pose net: need 0 < distance_min < distance_max");
  const int w = s_.width;
  conv_block(trunk_, 3, w, 5, 2);
  conv_block(trunk_, w, 2 * w, 3, 2);
  conv_block(trunk_, 2 * w, 4 * w, 3, 2);
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
  store_.allocate(with_grads);
  trunk_.training(with_grads);
  rot_head_.training(with_grads);
  dist_head_.training(with_grads);
}

double PoseNet::train_step_flops(int batch) const {
  const Shape in{batch, 3, s_.image_size, s_.image_size};
  const Shape feat = trunk_.output_shape(in);
  const double fwd = trunk_.forward_flops(in) + rot_head_.forward_flops(feat) + dist_head_.forward_flops(feat);
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
  x_.resize({images.rows(), 3, S, S});
  // Centre the [0, 1] input.
  Eigen::Map<MatrixXfR>(x_.ptr(), images.rows(), images.cols()) = images.array() - 0.5f;
  trunk_.forward(x_, feat_);
  rot_head_.forward(feat_, rot_);
  dist_head_.forward(feat_, dist_);
}

Camera PoseNet::camera_from_outputs(const Eigen::Matrix<float, 6, 1>& b, float z) const {
  Camera cam;
  cam.K = disn_intrinsics(s_.image_size, s_.image_size);
  cam.width = cam.height = s_.image_size;
  const Vec6T<double> bd = b.cast<double>();
  cam.R = rot6d_to_matrix(bd);
  const double sig = 1.0 / (1.0 + std::exp(-static_cast<double>(z)));
  cam.t = Vec3(0, 0, s_.distance_min + sig * (s_.distance_max - s_.distance_min));
  return cam;
}

PosePrediction PoseNet::predict(const MatrixXfR& images) {
  run(images, false);
  PosePrediction p;
  for (Eigen::Index b = 0; b < images.rows(); ++b) {
    Eigen::Matrix<float, 6, 1> r;
    for (int k = 0; k < 6; ++k) r[k] = rot_[b * 6 + k];
    p.rot6d.push_back(r);
    p.cameras.push_back(camera_from_outputs(r, dist_[b]));
  }
  return p;
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

double PoseNet::forward_backward(const MatrixXfR& images, const std::vector<PointsF>& points,
                                 const std::vector<Camera>& truth, double weight) {
  require(store_.has_grads(), "pose net: forward_backward needs a model built with gradients");
  const Eigen::Index B = images.rows();
  require(static_cast<Eigen::Index>(points.size()) == B && static_cast<Eigen::Index>(truth.size()) == B,
          "pose net: one point set and one camera per image");
  run(images, true);
  Tensor drot(rot_.shape), ddist(dist_.shape);
  double total = 0;
  const double range = s_.distance_max - s_.distance_min;
  for (Eigen::Index b = 0; b < B; ++b) {
    Vec6T<double> r;
    for (int k = 0; k < 6; ++k) r[k] = rot_[b * 6 + k];
    const Rot6dForward<double> f = rot6d_forward(r);
    const double sig = 1.0 / (1.0 + std::exp(-static_cast<double>(dist_[b])));
    Eigen::Matrix3d dR;
    double dd = 0;
    total += pose_point_loss(f.R, s_.distance_min + sig * range, points[b], truth[b], &dR, &dd);
    const Vec6T<double> db = rot6d_backward(f, dR) * (weight / static_cast<double>(B));
    for (int k = 0; k < 6; ++k) drot[b * 6 + k] = static_cast<float>(db[k]);
    ddist[b] = static_cast<float>(dd * range * sig * (1.0 - sig) * (weight / static_cast<double>(B)));
  }
  Tensor dfeat_r, dfeat_d;
  rot_head_.backward(feat_, rot_, drot, &dfeat_r);
  dist_head_.backward(feat_, dist_, ddist, &dfeat_d);
  for (int64_t i = 0; i < dfeat_r.size(); ++i) dfeat_r[i] += dfeat_d[i];
  trunk_.backward(x_, feat_, dfeat_r, nullptr);
  return total / static_cast<double>(B);
}

double PoseNet::loss(const MatrixXfR& images, const std::vector<PointsF>& points, const std::vector<Camera>& truth) {
  const PosePrediction p = predict(images);
  double total = 0;
  for (size_t b = 0; b < p.cameras.size(); ++b)
    total += pose_point_loss(p.cameras[b].R, p.cameras[b].t.z(), points.at(b), truth.at(b), nullptr, nullptr);
  return total / static_cast<double>(p.cameras.size());
}

}  // namespace sdfkit
