#include "core/json.h"
#include "models/pose_net.h"

#include "camera/rotation6d.h"
#include "nets/checkpoint.h"
#include "nets/gradcheck.h"
#include "nets/optim.h"
#include "scratch.h"
#include "train/dataset.h"
#include "train/pose_train.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <unistd.h>

using namespace sdfkit;

namespace {

/// A tiny network (40 px images) with a K-bin azimuth head.
PoseNetSettings tiny_with_head(int bins) {
  PoseNetSettings s;
  s.width = 2;
  s.image_size = 40;
  s.feature = 12;
  s.azimuth_bins = bins;
  return s;
}

PointsF random_points(int n, uint64_t seed) {
  Rng rng(seed);
  PointsF p(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = static_cast<float>(rng.uniform(-0.8, 0.8));
  return p;
}

/// `rows` random 40 px images (values uniform in [0, 1) from `rng`).
MatrixXfR random_images(int rows, Rng& rng) {
  MatrixXfR img(rows, 3 * 40 * 40);
  for (Eigen::Index i = 0; i < img.size(); ++i) img.data()[i] = static_cast<float>(rng.uniform());
  return img;
}

/// Nudges every parameter off its initialisation by up to 0.05 (draws from `rng`), for gradient checks.
void perturb(PoseNet& net, Rng& rng) {
  for (auto& v : net.params().values) v += static_cast<float>(0.05 * rng.uniform(-1, 1));
}

/// Relative error between `grads` (the analytic gradient `value` leaves) and central differences of `value` in
/// float at the parameters `idx`.
double gradient_error(PoseNet& net, const std::function<double()>& value, const std::vector<float>& grads,
                      const std::vector<size_t>& idx) {
  const std::vector<double> numeric = test::numeric_gradient<float>(value, net.params().values.data(), idx, 2e-3);
  std::vector<double> analytic;
  for (size_t i : idx) analytic.push_back(grads[i]);
  return test::relative_error(analytic, numeric);
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
  CHECK_THROWS_AS((void)net.predict(bad), InvalidInput);
}

TEST_CASE("pose net: training on a tiny batch lowers L_cam, model file round trip") {
  PoseNetSettings s;
  s.width = 4;
  s.image_size = 40;
  s.feature = 32;
  PoseNet net(s, true);
  net.init(5);
  Rng rng(9);
  const MatrixXfR img = random_images(4, rng);
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

TEST_CASE("pose net with extra convolutions: deeper trunk, gradients by finite differences, model file round trip") {
  PoseNetSettings s = tiny_with_head(8);
  const size_t plain_params = PoseNet(s, false).n_params();
  s.extra_convs = 1;
  PoseNet net(s, true);
  // One conv 3x3/1 at 2w and one at 4w channels (w = 2): (9 * 4 * 4 + 4) + (9 * 8 * 8 + 8) parameters more.
  CHECK(net.n_params() == plain_params + (9 * 4 * 4 + 4) + (9 * 8 * 8 + 8));
  CHECK(net.architecture().at("settings").at("extra_convs") == 1);
  CHECK(PoseNetSettings::from_json(s.to_json()).extra_convs == 1);
  CHECK(PoseNetSettings::from_json(tiny_with_head(8).to_json()).extra_convs == 0);  // older models: absent
  net.init(21);
  Rng rng(22);
  perturb(net, rng);
  const MatrixXfR img = random_images(2, rng);
  const std::vector<Camera> truth = {look_at(60, 26, 2.5), look_at(200, 29, 2.8)};
  const std::vector<PointsF> pts = {random_points(32, 3), random_points(32, 4)};
  PoseLossOptions lo;
  lo.azimuth_weight = 0.3;
  auto value = [&] {
    double ce = 0;
    net.params().zero_grad();
    const double l = net.forward_backward(img, pts, truth, 1.0, lo, &ce);
    return l + lo.azimuth_weight * ce;
  };
  value();
  const std::vector<float> grads(net.params().grads.begin(), net.params().grads.end());
  // The first 2000 parameters hold the first three convolutions and the extra one at 2w (75 * 2 + 2 + 9 * 2 * 4 + 4
  // + 148 + ...): sample those densely, then the rest.
  std::vector<size_t> idx = test::some_indices(2000, 30, 6);
  for (size_t i : test::some_indices(net.n_params(), 30, 7)) idx.push_back(i);
  CHECK(gradient_error(net, value, grads, idx) < 2e-2);

  const auto dir = test::scratch_dir("pose_net_deep");
  const std::string path = (dir / "pose.ckpt").string();
  save_pose_model(path, net, {});
  auto loaded = load_pose_model(path, nullptr);
  CHECK(loaded->settings().extra_convs == 1);
  const auto a = net.predict(img), b = loaded->predict(img);
  for (int i = 0; i < 2; ++i) CHECK(a.cameras[i].R == b.cameras[i].R);
  s.extra_convs = 3;
  CHECK_THROWS_AS(PoseNet(s, false), InvalidInput);
  std::filesystem::remove_all(dir);
}

TEST_CASE("L_cam modulo symmetries: zero at a twin of the truth, the twin's gradient, first minimum on ties") {
  const Camera truth = look_at(40, 27, 2.7);
  const PointsF pts = random_points(40, 3);
  const Mat3 half = Eigen::AngleAxisd(3.14159265358979323846, Vec3::UnitY()).toRotationMatrix();
  const Mat3 quarter = Eigen::AngleAxisd(3.14159265358979323846 / 2, Vec3::UnitY()).toRotationMatrix();
  // The twin (R_t g, t_t) is the true camera turned to azimuth 40 + 180.
  Camera twin = truth;
  twin.R = truth.R * half;
  CHECK((twin.R - look_at(220, 27, 2.7).R).norm() < 1e-12);
  int which = -1;
  CHECK(pose_point_loss_modulo(twin.R, 2.7, pts, truth, {quarter, half}, nullptr, nullptr, &which) < 1e-20);
  CHECK(which == 2);
  CHECK(pose_point_loss_modulo(twin.R, 2.7, pts, truth, {}, nullptr, nullptr, &which) > 1.0);
  CHECK(which == 0);
  // Away from the truth, the value and gradient are those of the nearest twin.
  const Camera other = look_at(200, 22, 2.5);
  Eigen::Matrix3d dR, dR_twin;
  double dd = 0, dd_twin = 0;
  const double l = pose_point_loss_modulo(other.R, 2.5, pts, truth, {half}, &dR, &dd, &which);
  CHECK(which == 1);
  CHECK(l == pose_point_loss(other.R, 2.5, pts, twin, &dR_twin, &dd_twin));
  CHECK(dR == dR_twin);
  CHECK(dd == dd_twin);
  // The identity as a "symmetry" ties with the truth: the truth (index 0) wins.
  pose_point_loss_modulo(other.R, 2.5, pts, truth, {Mat3::Identity()}, nullptr, nullptr, &which);
  CHECK(which == 0);
}

TEST_CASE("azimuth head helpers: targets, cross-entropy, window mass and the flip check") {
  // Targets: split between the two nearest centres, wrapping at 360.
  std::vector<float> y(36, 0.0f);
  add_azimuth_target(355.0, 36, 1.0, y.data());
  CHECK(y[35] == doctest::Approx(0.5));
  CHECK(y[0] == doctest::Approx(0.5));
  std::fill(y.begin(), y.end(), 0.0f);
  add_azimuth_target(120.0, 36, 0.25, y.data());
  CHECK(y[12] == doctest::Approx(0.25));
  double sum = 0;
  for (float v : y) sum += v;
  CHECK(sum == doctest::Approx(0.25));
  add_azimuth_target(-10.0, 36, 1.0, y.data());  // = 350
  CHECK(y[35] == doctest::Approx(1.0));

  // Cross-entropy: log K for equal logits and a one-hot target; gradient against finite differences.
  std::vector<float> z(8, 0.3f), t(8, 0.0f);
  t[3] = 1.0f;
  std::vector<double> dz(8), p(8);
  CHECK(softmax_cross_entropy(z.data(), t.data(), 8, dz.data(), p.data()) == doctest::Approx(std::log(8.0)));
  CHECK(p[0] == doctest::Approx(0.125));
  Rng rng(4);
  for (auto& v : z) v = static_cast<float>(rng.uniform(-3, 3));
  t = {0.1f, 0.0f, 0.4f, 0.5f, 0.0f, 0.0f, 0.0f, 0.0f};
  softmax_cross_entropy(z.data(), t.data(), 8, dz.data(), nullptr);
  for (int k = 0; k < 8; ++k) {
    // Central difference in double through a double copy of the logits.
    auto ce = [&](double h) {
      double m = -1e300, s = 0;
      std::vector<double> zz(z.begin(), z.end());
      zz[static_cast<size_t>(k)] += h;
      for (double v : zz) m = std::max(m, v);
      for (double v : zz) s += std::exp(v - m);
      double c = 0;
      for (int j = 0; j < 8; ++j) c -= t[static_cast<size_t>(j)] * (zz[static_cast<size_t>(j)] - m - std::log(s));
      return c;
    };
    CHECK(dz[static_cast<size_t>(k)] == doctest::Approx((ce(1e-6) - ce(-1e-6)) / 2e-6).epsilon(1e-6));
  }
  // Extreme logits stay finite.
  std::vector<float> big = {1e30f, -1e30f, 0.0f, 0.0f};
  std::vector<float> tb = {0.0f, 1.0f, 0.0f, 0.0f};
  CHECK(std::isfinite(softmax_cross_entropy(big.data(), tb.data(), 4, nullptr, nullptr)));

  // Window mass: all mass in bin 18 (180 degrees) of 36: full at 180, half at 190, none past 200.
  std::vector<float> prob(36, 0.0f);
  prob[18] = 1.0f;
  CHECK(azimuth_window_mass(prob, 180) == doctest::Approx(1.0));
  CHECK(azimuth_window_mass(prob, 190) == doctest::Approx(0.5));
  CHECK(azimuth_window_mass(prob, 201) == 0.0);
  // Flip check: a regressed azimuth of 3 degrees against a classifier sure of 180: turned by 180 (to 183).
  CHECK(azimuth_flip_shift(prob, 3.0, 1.5) == doctest::Approx(180.0));
  CHECK(azimuth_flip_shift(prob, 3.0, 0.0) == 0.0);  // off
  // The regressed azimuth already where the classifier is: kept.
  CHECK(azimuth_flip_shift(prob, 178.0, 1.5) == 0.0);
  // Two modes: 0.55 at 90 degrees, 0.45 at the regressed 270 (ratio 1.22): the margin decides.
  std::fill(prob.begin(), prob.end(), 0.0f);
  prob[9] = 0.55f;
  prob[27] = 0.45f;
  CHECK(azimuth_flip_shift(prob, 270.0, 1.25) == 0.0);
  CHECK(azimuth_flip_shift(prob, 270.0, 1.2) == doctest::Approx(180.0));
  // Shifts are reported in (-180, 180]: a mode 30 degrees below.
  std::fill(prob.begin(), prob.end(), 0.0f);
  prob[3] = 1.0f;
  CHECK(azimuth_flip_shift(prob, 60.0, 1.5) == doctest::Approx(-30.0));
}

TEST_CASE("pose net with an azimuth head: gradients of L_cam (modulo symmetries) + weighted cross-entropy") {
  const PoseNetSettings s = tiny_with_head(8);
  PoseNet net(s, true);
  net.init(11);
  Rng rng(12);
  perturb(net, rng);
  const MatrixXfR img = random_images(2, rng);
  const std::vector<Camera> truth = {look_at(30, 25, 2.6), look_at(250, 28, 2.9)};
  const std::vector<PointsF> pts = {random_points(32, 1), random_points(32, 2)};
  const Mat3 half = Eigen::AngleAxisd(3.14159265358979323846, Vec3::UnitY()).toRotationMatrix();
  const std::vector<std::vector<Mat3>> sym = {{}, {half}};
  PoseLossOptions lo;
  lo.symmetries = &sym;
  lo.azimuth_weight = 0.7;
  // L_cam + w CE; leaves the gradient of the evaluation in the parameter gradients.
  auto value = [&] {
    double ce = 0;
    net.params().zero_grad();
    const double l = net.forward_backward(img, pts, truth, 1.0, lo, &ce);
    return l + lo.azimuth_weight * ce;
  };
  value();
  const std::vector<float> grads(net.params().grads.begin(), net.params().grads.end());
  // The azimuth head's output bias: d/db_k = w / B sum_b (softmax_bk - y_bk), in closed form.
  const PosePrediction p = net.predict(img);
  REQUIRE(p.azimuth_prob.size() == 2);
  const size_t bias0 = net.n_params() - 8;
  for (int k = 0; k < 8; ++k) {
    double expect = 0;
    for (int b = 0; b < 2; ++b) {
      std::vector<float> y(8, 0.0f);
      const double share = b == 0 ? 1.0 : 0.5;
      add_azimuth_target(look_at_params(truth[b]).azimuth_deg, 8, share, y.data());
      if (b == 1) add_azimuth_target(look_at_params(truth[b]).azimuth_deg + 180, 8, share, y.data());
      expect += p.azimuth_prob[b][k] - y[k];
    }
    CHECK(grads[bias0 + k] == doctest::Approx(0.7 / 2 * expect).epsilon(1e-4));
  }
  // Every other parameter: central differences in float (loose tolerance), over the trunk and the three heads.
  std::vector<size_t> idx = test::some_indices(net.n_params(), 40, 5);
  for (size_t k = 0; k < 20; ++k) idx.push_back(net.n_params() - 1 - 37 * k);  // the heads
  CHECK(gradient_error(net, value, grads, idx) < 2e-2);
  // Weight 0 leaves the head without gradient, and a head-less model refuses a weight.
  lo.azimuth_weight = 0;
  net.params().zero_grad();
  net.forward_backward(img, pts, truth, 1.0, lo, nullptr);
  for (size_t k = 0; k < 8; ++k) CHECK(net.params().grads[bias0 + k] == 0.0f);
  PoseNetSettings plain = s;
  plain.azimuth_bins = 0;  // headless
  PoseNet headless(plain, true);
  lo.azimuth_weight = 0.5;
  CHECK_THROWS_AS(headless.forward_backward(img, pts, truth, 1.0, lo, nullptr), InvalidInput);
}

TEST_CASE("pose net with an azimuth head: the flip check turns the camera, the model file keeps the head") {
  PoseNetSettings s = tiny_with_head(12);
  PoseNet net(s, true);
  net.init(2);
  // Force the classifier to one bin through its output bias: every image then says "azimuth 90".
  const size_t bias0 = net.n_params() - 12;
  for (size_t k = 0; k < 12; ++k) net.params().values[bias0 + k] = k == 3 ? 40.0f : -40.0f;
  MatrixXfR img = MatrixXfR::Random(3, 3 * 40 * 40).array() * 0.5f + 0.5f;
  net.set_flip_check(0);
  const PosePrediction off = net.predict(img);
  net.set_flip_check(1.5);
  const PosePrediction on = net.predict(img);
  for (int b = 0; b < 3; ++b) {
    CHECK(off.azimuth_shift[b] == 0.0);
    CHECK((off.cameras[b].R - off.regressed[b].R).norm() == 0.0);
    const double a = look_at_params(off.cameras[b]).azimuth_deg, turned = look_at_params(on.cameras[b]).azimuth_deg;
    // Turned by a whole number of 30-degree bins: to within 15 degrees of 90, or kept when already within 40
    // (the margin 1.5 keeps a camera whose window mass is at least 2/3 of the best).
    CHECK(std::fabs(turned - 90) <= (on.azimuth_shift[b] != 0 ? 15.0 : 40.0) + 1e-9);
    CHECK(std::fmod(std::fabs(turned - a) + 1e-9, 30.0) < 1e-6);
    CHECK(on.cameras[b].t == off.cameras[b].t);
  }
  CHECK_THROWS_AS(net.set_flip_check(-1), InvalidInput);
  // Model file: the head and its bins come back; a model without the head has no azimuth_bins key.
  const auto dir = test::scratch_dir("pose_net_head");
  const std::string path = (dir / "pose.ckpt").string();
  save_pose_model(path, net);
  auto loaded = load_pose_model(path);
  CHECK(loaded->settings().azimuth_bins == 12);
  CHECK(loaded->n_params() == net.n_params());
  CHECK(net.architecture().at("settings").contains("azimuth_bins"));
  // A model file whose settings no network can have is an IoError naming the file.
  Checkpoint forged = load_checkpoint(path);
  forged.header["architecture"]["settings"]["azimuth_bins"] = 2;
  const std::string bad = (dir / "bad.ckpt").string();
  save_checkpoint(bad, forged);
  try {
    load_pose_model(bad);
    FAIL("a model with 2 azimuth bins loaded");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find(bad) != std::string::npos);
  }
  s.azimuth_bins = 0;
  CHECK_FALSE(PoseNet(s, false).architecture().at("settings").contains("azimuth_bins"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("distance head remap: same distance and slope at the old range's middle, adopted by a wider network") {
  const double a = 2.3, b = 3.15, a2 = 1.4, b2 = 4.4;
  const std::pair<double, double> remap = distance_logit_remap(a, b, a2, b2);
  const double alpha = remap.first, beta = remap.second;
  const auto sig = [](double z) { return 1.0 / (1.0 + std::exp(-z)); };
  const auto d_old = [&](double z) { return a + (b - a) * sig(z); };
  const auto d_new = [&](double z) { return a2 + (b2 - a2) * sig(alpha * z + beta); };
  CHECK(d_new(0) == doctest::Approx(d_old(0)).epsilon(1e-12));
  const double h = 1e-5;
  CHECK((d_new(h) - d_new(-h)) / (2 * h) == doctest::Approx((d_old(h) - d_old(-h)) / (2 * h)).epsilon(1e-7));
  CHECK_THROWS_AS(distance_logit_remap(a, b, 3.0, 4.0), InvalidInput);  // middle 2.725 outside

  PoseNetSettings s;
  s.width = 2;
  s.image_size = 40;
  s.feature = 16;
  s.azimuth_bins = 8;
  PoseNet from(s, false);
  from.init(4);
  PoseNetSettings wide = s;
  wide.distance_min = a2;
  wide.distance_max = b2;
  PoseNet to(wide, false);
  to.adopt_parameters(from);
  MatrixXfR img = MatrixXfR::Random(4, 3 * 40 * 40).array() * 0.5f + 0.5f;
  const PosePrediction p = from.predict(img), q = to.predict(img);
  for (size_t i = 0; i < 4; ++i) {
    CHECK((p.regressed[i].R - q.regressed[i].R).norm() < 1e-12);  // the rotation head is copied as it is
    CHECK(p.azimuth_prob[i] == q.azimuth_prob[i]);
    // Second-order agreement near the middle: a freshly initialised head's logits are small.
    CHECK(q.regressed[i].t.z() == doctest::Approx(p.regressed[i].t.z()).epsilon(0.01));
  }
  PoseNetSettings other = wide;
  other.feature = 8;
  PoseNet mismatched(other, false);
  CHECK_THROWS_AS(mismatched.adopt_parameters(from), InvalidInput);
}

TEST_CASE("pose net with a centre head: closed-form loss, gradients by finite differences, the principal point") {
  // The loss: d_t^2 |o - o_t|^2 with o_t the true principal point's offset in focal lengths.
  Camera truth = look_at(40, 20, 2.5);
  const double f = truth.K(0, 0), c = 0.5 * truth.width;
  truth.K(0, 2) = c + 0.1 * f;
  truth.K(1, 2) = c - 0.05 * f;
  CHECK(camera_centre_offset(truth).x() == doctest::Approx(0.1).epsilon(1e-12));
  CHECK(camera_centre_offset(truth).y() == doctest::Approx(-0.05).epsilon(1e-12));
  CHECK(camera_centre_offset(look_at(10, 30, 2.7)).norm() < 1e-12);  // a render shows the origin at the centre
  Eigen::Vector2d g;
  CHECK(pose_centre_loss(Eigen::Vector2d(0.3, -0.2), truth, &g) ==
        doctest::Approx(6.25 * (0.2 * 0.2 + 0.15 * 0.15)).epsilon(1e-12));
  CHECK(g.x() == doctest::Approx(2 * 6.25 * 0.2).epsilon(1e-12));
  CHECK(g.y() == doctest::Approx(2 * 6.25 * -0.15).epsilon(1e-12));
  CHECK(pose_centre_loss(Eigen::Vector2d(0.1, -0.05), truth, nullptr) == doctest::Approx(0).scale(1));

  PoseNetSettings s = tiny_with_head(8);
  s.centre_head = true;
  PoseNet net(s, true);
  net.init(21);
  Rng rng(22);
  perturb(net, rng);
  const MatrixXfR img = random_images(2, rng);
  Camera t0 = look_at(30, 25, 2.6, 40, 40), t1 = look_at(250, 28, 2.9, 40, 40);
  t0.K(0, 2) += 3.0;
  t1.K(1, 2) -= 4.0;
  const std::vector<Camera> cams = {t0, t1};
  const std::vector<PointsF> pts = {random_points(32, 3), random_points(32, 4)};
  PoseLossOptions lo;
  lo.azimuth_weight = 0.3;
  lo.centre_weight = 2.0;
  auto value = [&] {
    double ce = 0, centre = 0;
    net.params().zero_grad();
    const double l = net.forward_backward(img, pts, cams, 1.0, lo, &ce, &centre);
    return l + lo.azimuth_weight * ce + lo.centre_weight * centre;
  };
  value();
  const std::vector<float> grads(net.params().grads.begin(), net.params().grads.end());
  // The centre head's output bias (the last two parameters): d/db = w / B sum_b 2 d_b^2 (o_b - o_tb), closed form.
  const PosePrediction p = net.predict(img);
  for (int a = 0; a < 2; ++a) {
    double expect = 0;
    for (int b = 0; b < 2; ++b) {
      const Eigen::Vector2d o = camera_centre_offset(p.regressed[b]);
      Eigen::Vector2d gb;
      pose_centre_loss(o, cams[b], &gb);
      expect += gb[a];
    }
    CHECK(grads[net.n_params() - 2 + a] == doctest::Approx(2.0 / 2 * expect).epsilon(1e-3));
  }
  std::vector<size_t> idx = test::some_indices(net.n_params(), 40, 7);
  for (size_t k = 0; k < 24; ++k) idx.push_back(net.n_params() - 1 - 5 * k);  // the centre head
  CHECK(gradient_error(net, value, grads, idx) < 2e-2);
  // The predicted camera's principal point is c + f o for the head's output: with its last layer's weights at 0,
  // o is the bias.
  const size_t n = net.n_params();
  for (size_t i = n - 2 - 64; i < n - 2; ++i) net.params().values[i] = 0.0f;
  net.params().values[n - 2] = 0.125f;
  net.params().values[n - 1] = -0.0625f;
  const PosePrediction q = net.predict(img);
  for (const Camera& cam : q.regressed) {
    CHECK(cam.K(0, 2) == doctest::Approx(20.0 + 0.125 * cam.K(0, 0)).epsilon(1e-12));
    CHECK(cam.K(1, 2) == doctest::Approx(20.0 - 0.0625 * cam.K(1, 1)).epsilon(1e-12));
  }
  CHECK(s.to_json().at("centre_head") == true);
  CHECK(PoseNetSettings::from_json(s.to_json()).centre_head);
  CHECK(!tiny_with_head(8).to_json().contains("centre_head"));
  lo.centre_weight = -1;
  CHECK_THROWS_AS(net.forward_backward(img, pts, cams, 1.0, lo), InvalidInput);
}

TEST_CASE("a centre head adopted from a model without one starts at the image centre, same cameras otherwise") {
  PoseNetSettings s = tiny_with_head(8);
  PoseNet from(s, false);
  from.init(5);
  PoseNetSettings with = s;
  with.centre_head = true;
  with.distance_min = 1.4;
  with.distance_max = 4.4;
  PoseNet to(with, false);
  to.init(6);
  to.adopt_parameters(from);
  MatrixXfR img = MatrixXfR::Random(3, 3 * 40 * 40).array() * 0.5f + 0.5f;
  const PosePrediction p = from.predict(img), q = to.predict(img);
  for (size_t i = 0; i < 3; ++i) {
    CHECK((p.regressed[i].R - q.regressed[i].R).norm() < 1e-12);
    CHECK((p.regressed[i].K - q.regressed[i].K).norm() == 0.0);  // the centre: o = 0 exactly
    CHECK(q.regressed[i].t.z() == doctest::Approx(p.regressed[i].t.z()).epsilon(0.01));
    CHECK(p.azimuth_prob[i] == q.azimuth_prob[i]);
  }
  // The head's first layer keeps its own initialisation (not zero), so that it can learn.
  double first = 0;
  for (size_t i = from.n_params(); i < to.n_params() - 66; ++i) first += std::abs(to.params().values[i]);
  CHECK(first > 0);
  // The other way round is refused: a model with a centre head cannot be adopted by one without.
  PoseNet back(s, false);
  CHECK_THROWS_AS(back.adopt_parameters(to), InvalidInput);
}

TEST_CASE("rotation helpers of the pose mirror TTA: nearest rotation, angle, flipped images, mirrored bins") {
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, -0.5).normalized()).toRotationMatrix();
  const Vec3 axis = Vec3(-0.3, 1, 0.4).normalized();
  const Mat3 plus = R * Eigen::AngleAxisd(0.3, axis).toRotationMatrix();
  const Mat3 minus = R * Eigen::AngleAxisd(-0.3, axis).toRotationMatrix();
  // The chordal mean of two rotations is their geodesic midpoint; a positive multiple of R is R.
  CHECK((nearest_rotation(plus + minus) - R).norm() < 1e-12);
  CHECK((nearest_rotation(2.5 * R) - R).norm() < 1e-12);
  CHECK(std::fabs(rotation_angle_deg(plus, minus) - 0.6 * 180 / 3.14159265358979323846) < 1e-9);
  CHECK(rotation_angle_deg(R, R) < 1e-6);
  // A reflection's nearest rotation has determinant +1.
  const Mat3 reflected = R * Vec3(1, 1, -1).asDiagonal();
  CHECK(std::fabs(nearest_rotation(reflected).determinant() - 1) < 1e-12);
  CHECK_THROWS_AS(nearest_rotation(Mat3::Zero()), InvalidInput);
  // Flipped images: pixel (c, y, x) comes from (c, y, S - 1 - x); flipping twice gives the image back.
  const int S = 5;
  const MatrixXfR img = MatrixXfR::Random(2, 3 * S * S);
  const MatrixXfR f = flip_images(img, S);
  for (int b = 0; b < 2; ++b)
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < S; ++y)
        for (int x = 0; x < S; ++x) CHECK(f(b, (c * S + y) * S + x) == img(b, (c * S + y) * S + S - 1 - x));
  CHECK((flip_images(f, S) - img).norm() == 0);
  CHECK_THROWS_AS(flip_images(img, 4), InvalidInput);
  // Mirrored bins: the mass at azimuth a becomes the mass at -a.
  std::vector<float> prob(12);
  for (size_t k = 0; k < prob.size(); ++k) prob[k] = static_cast<float>(k + 1) / 78.f;
  const std::vector<float> m = mirror_azimuth_prob(prob);
  for (double a : {0.0, 17.0, 95.0, 200.0, 333.0})
    CHECK(azimuth_window_mass(m, 360.0 - a) == doctest::Approx(azimuth_window_mass(prob, a)).epsilon(1e-6));
}

TEST_CASE("pose net mirror TTA: equivariant to flipping the input, the midpoint of readings that agree") {
  for (const int bins : {0, 12}) {
    CAPTURE(bins);
    PoseNet net(tiny_with_head(bins), false);
    net.init(5);
    const MatrixXfR img = MatrixXfR::Random(6, 3 * 40 * 40).array() * 0.5f + 0.5f;
    const PosePrediction plain = net.predict(img);
    net.set_mirror_tta(true);
    const PosePrediction tta = net.predict(img);
    const PosePrediction flipped = net.predict(flip_images(img, 40));
    REQUIRE(tta.mirror_angle.size() == 6);
    CHECK(plain.mirror_angle.empty());
    for (int b = 0; b < 6; ++b) {
      CAPTURE(b);
      // The flipped image's estimate is the mirror of the image's: the TTA is exact in the task's symmetry.
      const Camera expect = mirror_camera(tta.cameras[b]);
      CHECK((flipped.cameras[b].R - expect.R).norm() < 1e-5);
      CHECK((flipped.cameras[b].t - expect.t).norm() < 1e-5);
      CHECK((flipped.cameras[b].K - expect.K).norm() < 1e-4);
      CHECK(flipped.mirror_angle[b] == doctest::Approx(tta.mirror_angle[b]).epsilon(1e-4));
      // Readings that agree are averaged: the result lies halfway between the image's reading and the other.
      if (tta.mirror_angle[b] <= kMirrorAgreeDeg || bins == 0)
        CHECK(rotation_angle_deg(tta.regressed[b].R, plain.regressed[b].R) ==
              doctest::Approx(tta.mirror_angle[b] / 2).epsilon(1e-3));
    }
  }
}

TEST_CASE("pose net mirror TTA agreement angle: 180 averages every pair, 0 keeps one reading, bad angles refused") {
  PoseNet net(tiny_with_head(12), false);
  net.init(5);
  const MatrixXfR img = MatrixXfR::Random(6, 3 * 40 * 40).array() * 0.5f + 0.5f;
  net.set_flip_check(0);
  const PosePrediction plain = net.predict(img);
  net.set_mirror_tta(true);
  CHECK(net.mirror_agree() == kMirrorAgreeDeg);
  net.set_mirror_agree(180);
  const PosePrediction all = net.predict(img);
  net.set_mirror_agree(0);
  const PosePrediction none = net.predict(img);
  for (int b = 0; b < 6; ++b) {
    CAPTURE(b);
    REQUIRE(all.mirror_angle[b] > 1e-3);  // the two readings of a random image differ
    REQUIRE(all.mirror_angle[b] < 179.0);
    // 180: always the midpoint; 0: one of the two readings, unchanged.
    CHECK(rotation_angle_deg(all.regressed[b].R, plain.regressed[b].R) ==
          doctest::Approx(all.mirror_angle[b] / 2).epsilon(1e-3));
    const double to_plain = rotation_angle_deg(none.regressed[b].R, plain.regressed[b].R);
    CHECK((to_plain < 1e-3 || std::abs(to_plain - none.mirror_angle[b]) < 1e-3));
  }
  for (const double bad : {-1.0, 180.5, std::nan("")}) CHECK_THROWS_AS(net.set_mirror_agree(bad), InvalidInput);
}

TEST_CASE("pose net zoom TTA: the readings of the magnified images, read back and averaged with the image's") {
  for (const bool centre : {false, true}) {
    CAPTURE(centre);
    PoseNetSettings s = tiny_with_head(12);
    s.centre_head = centre;
    PoseNet net(s, false);
    net.init(7);
    // Images 0-2: an object of 10 x 10 px on white (room to magnify); 3-5: noise over the whole frame (none).
    MatrixXfR img = MatrixXfR::Ones(6, 3 * 40 * 40);
    // Seeded noise (not Eigen's Random, whose std::rand state depends on the tests run before).
    Rng rng(centre ? 31 : 30);
    MatrixXfR noise(6, 3 * 40 * 40);
    for (Eigen::Index i = 0; i < noise.size(); ++i) noise.data()[i] = static_cast<float>(rng.uniform());
    for (int b = 0; b < 6; ++b)
      for (int c = 0; c < 3; ++c)
        for (int y = 0; y < 40; ++y)
          for (int x = 0; x < 40; ++x)
            if (b >= 3 || (x >= 15 && x < 25 && y >= 14 && y < 24))
              img(b, (c * 40 + y) * 40 + x) = noise(b, (c * 40 + y) * 40 + x) * 0.8f;
    net.set_flip_check(0);
    net.set_mirror_agree(180);
    const PosePrediction plain = net.predict(img);
    for (const double k : {0.8, 1.5}) {
      CAPTURE(k);
      net.set_zoom_tta({k});
      CHECK(net.zoom_tta() == std::vector<double>{k});
      const PosePrediction tta = net.predict(img);
      net.set_zoom_tta({});
      for (int b = 0; b < 6; ++b) {
        CAPTURE(b);
        // The reference: the network's reading of the image magnified as the TTA does (a full frame cannot grow).
        const Eigen::VectorXf row = img.row(b).transpose();
        const double applied = k > 1 ? std::min(k, std::max(1.0, max_zoom_inside(row, 40))) : k;
        if (b >= 3 && k > 1) CHECK(applied == 1.0);
        if (b < 3) CHECK(applied == k);
        MatrixXfR one(1, img.cols());
        one.row(0) = (applied == 1 ? row : zoom_image(row, 40, applied)).transpose();
        const PosePrediction z = net.predict(one);
        Camera read = z.regressed[0];
        read.t *= applied;
        read.K(0, 2) = 20 + (read.K(0, 2) - 20) / applied;
        read.K(1, 2) = 20 + (read.K(1, 2) - 20) / applied;
        const Mat3 expect_r = nearest_rotation(plain.regressed[b].R + read.R);
        // Float network outputs, read in a batch of 6 and alone: equal up to float rounding.
        CHECK((tta.regressed[b].R - expect_r).norm() < 1e-5);
        CHECK((tta.regressed[b].t - 0.5 * (plain.regressed[b].t + read.t)).norm() < 1e-5);
        CHECK((tta.regressed[b].K - 0.5 * (plain.regressed[b].K + read.K)).norm() < 1e-5);
        for (int i = 0; i < 12; ++i)
          CHECK(tta.azimuth_prob[b][i] ==
                doctest::Approx(0.5 * (plain.azimuth_prob[b][i] + z.azimuth_prob[0][i])).epsilon(1e-5));
        if (b < 3) CHECK(rotation_angle_deg(read.R, plain.regressed[b].R) > 1e-3);  // a real second reading
      }
    }
    // Agreement angle 0: the magnified readings only enter the azimuth probabilities.
    net.set_mirror_agree(0);
    net.set_zoom_tta({0.8, 1.25});
    const PosePrediction kept = net.predict(img);
    for (int b = 0; b < 6; ++b) CHECK(rotation_angle_deg(kept.regressed[b].R, plain.regressed[b].R) < 1e-4);
  }
  PoseNet net(tiny_with_head(0), false);
  for (const double bad : {1.0, 0.4, 2.5, std::nan("")})
    CHECK_THROWS_AS(net.set_zoom_tta({0.9, bad}), InvalidInput);
}
