#include "nets/pose_net.h"

#include "camera/rotation6d.h"
#include "nets/optim.h"
#include "nets/checkpoint.h"
#include "nets/pose_train.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <unistd.h>

using namespace sdfkit;

namespace {

PointsF random_points(int n, uint64_t seed) {
  Rng rng(seed);
  PointsF p(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = static_cast<float>(rng.uniform(-0.8, 0.8));
  return p;
}

}  // namespace

TEST_CASE("L_cam: zero at the truth, closed-form gradient matches finite differences") {
  const Camera truth = look_at(40, 27, 2.7);
  const PointsF pts = random_points(50, 1);
  CHECK(pose_point_loss(truth.R, truth.t.z(), pts, truth, nullptr, nullptr) == doctest::Approx(0.0).epsilon(1e-20));
  // A pure distance error e shifts every point by e along z: L = e^2.
  CHECK(pose_point_loss(truth.R, truth.t.z() + 0.1, pts, truth, nullptr, nullptr) == doctest::Approx(0.01));
  const Camera other = look_at(95, 20, 2.5);
  Eigen::Matrix3d dR;
  double dd = 0;
  pose_point_loss(other.R, 2.5, pts, truth, &dR, &dd);
  const double h = 1e-6;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Eigen::Matrix3d Rp = other.R, Rm = other.R;
      Rp(r, c) += h;
      Rm(r, c) -= h;
      const double num = (pose_point_loss(Rp, 2.5, pts, truth, nullptr, nullptr) -
                          pose_point_loss(Rm, 2.5, pts, truth, nullptr, nullptr)) / (2 * h);
      CHECK(dR(r, c) == doctest::Approx(num).epsilon(1e-6));
    }
  const double num_d = (pose_point_loss(other.R, 2.5 + h, pts, truth, nullptr, nullptr) -
                        pose_point_loss(other.R, 2.5 - h, pts, truth, nullptr, nullptr)) / (2 * h);
  CHECK(dd == doctest::Approx(num_d).epsilon(1e-6));
  // Chained through the 6D representation (what the network's rotation head receives).
  Vec6T<double> b;
  b << 0.3, -1.1, 0.4, 0.9, 0.2, -0.5;
  auto loss6 = [&](const Vec6T<double>& v) {
    return pose_point_loss(rot6d_to_matrix(v), 2.5, pts, truth, nullptr, nullptr);
  };
  pose_point_loss(rot6d_to_matrix(b), 2.5, pts, truth, &dR, nullptr);
  const Vec6T<double> g = rot6d_backward(b, dR);
  for (int k = 0; k < 6; ++k) {
    Vec6T<double> bp = b, bm = b;
    bp[k] += h;
    bm[k] -= h;
    CHECK(g[k] == doctest::Approx((loss6(bp) - loss6(bm)) / (2 * h)).epsilon(1e-5));
  }
}

TEST_CASE("pose net: predictions are valid look-at cameras within the distance range") {
  PoseNetSettings s;
  s.width = 2;
  s.image_size = 40;
  s.feature = 16;
  PoseNet net(s, false);
  net.init(3);
  MatrixXfR img = MatrixXfR::Random(3, 3 * 40 * 40).array() * 0.5f + 0.5f;
  const PosePrediction p = net.predict(img);
  REQUIRE(p.cameras.size() == 3);
  for (const auto& c : p.cameras) {
    CHECK((c.R * c.R.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-9);
    CHECK(c.R.determinant() == doctest::Approx(1.0));
    CHECK(c.t.x() == 0.0);
    CHECK(c.t.y() == 0.0);
    CHECK(c.t.z() >= s.distance_min);
    CHECK(c.t.z() <= s.distance_max);
    CHECK(c.K(0, 0) == doctest::Approx(35.0 / 32.0 * 40));
  }
  std::vector<PointsF> pts(3, random_points(10, 1));
  CHECK_THROWS_AS(net.forward_backward(img, pts, p.cameras), InvalidInput);  // inference-only model
  MatrixXfR bad(2, 10);
  CHECK_THROWS_AS(net.predict(bad), InvalidInput);
}

TEST_CASE("pose net: training on a tiny batch lowers L_cam, model file round trip") {
  PoseNetSettings s;
  s.width = 4;
  s.image_size = 40;
  s.feature = 32;
  PoseNet net(s, true);
  net.init(5);
  Rng rng(9);
  MatrixXfR img(4, 3 * 40 * 40);
  for (Eigen::Index i = 0; i < img.size(); ++i) img.data()[i] = static_cast<float>(rng.uniform());
  std::vector<Camera> truth = {look_at(10, 25, 2.5), look_at(100, 30, 2.9), look_at(200, 26, 2.6),
                               look_at(300, 28, 2.8)};
  std::vector<PointsF> pts;
  for (int b = 0; b < 4; ++b) pts.push_back(random_points(64, 20 + b));
  OptimizerSettings os;
  os.beta1 = 0.9;
  Optimizer opt(os, net.n_params());
  const double first = net.loss(img, pts, truth);
  double last = first;
  for (int k = 0; k < 150; ++k) {
    net.params().zero_grad();
    last = net.forward_backward(img, pts, truth);
    opt.step(net.params().values.data(), net.params().grads.data(), 2e-3);
  }
  last = net.loss(img, pts, truth);
  INFO("first ", first, " last ", last);
  CHECK(last < 0.1 * first);

  const auto dir = test::scratch_dir("pose_net");
  const std::string path = (dir / "pose.ckpt").string();
  save_pose_model(path, net, {{"note", "test"}});
  Json training;
  auto loaded = load_pose_model(path, &training);
  CHECK(training.at("note") == "test");
  CHECK(loaded->params().grads.empty());
  const auto a = net.predict(img), b = loaded->predict(img);
  for (int i = 0; i < 4; ++i) {
    CHECK(a.cameras[i].R == b.cameras[i].R);
    CHECK(a.cameras[i].t == b.cameras[i].t);
  }
  // Not a pose model -> clear error naming the file.
  Checkpoint other;
  other.header["kind"] = "sdf_model";
  save_checkpoint((dir / "other.ckpt").string(), other);
  CHECK_THROWS_AS(load_pose_model((dir / "other.ckpt").string()), IoError);
  std::filesystem::remove_all(dir);
}
