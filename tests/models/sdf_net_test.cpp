#include "core/json.h"
#include "models/sdf_net.h"

#include "camera/camera.h"
#include "core/error.h"
#include "core/random.h"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

SdfNetConfig tiny_config(SdfVariant v, int first_stride = 2) {
  SdfNetConfig c;
  c.variant = v;
  c.first_stride = first_stride;
  c.image_size = 17;
  c.encoder_channels = {2, 3, 3};
  c.extra_convs = 1;
  c.global_features = 4;
  c.point_mlp = {5};
  c.decoder = {6, 4};
  c.one_stream_maps = 2;
  return c;
}

template <typename T>
TensorT<T> random_tensor(const Shape& s, Rng& rng, double lo, double hi) {
  TensorT<T> t(s);
  for (auto& v : t.data) v = static_cast<T>(rng.uniform(lo, hi));
  return t;
}

/// pred (1 x N) of one image and its points through `net`, with a fresh workspace.
/// A binary network adopted from an SDF model: its logit is -scale x the model's pred at every point, and the pred is
/// not all zeros (the comparison would be vacuous).
void check_logit_is_scaled_pred(const TensorT<double>& logit, const TensorT<double>& pred, int n, double scale) {
  double spread = 0;
  for (int i = 0; i < n; ++i) {
    CHECK(logit[i] == doctest::Approx(-scale * pred[i]).epsilon(1e-12).scale(1.0));
    spread += std::abs(pred[i]);
  }
  CHECK(spread > 1e-3);
}

TensorT<double> predict_points(const SdfNetT<double>& net, const TensorT<double>& image, const Camera& cam,
                               const TensorT<double>& points) {
  SdfNetT<double>::Workspace ws;
  TensorT<double> pred;
  net.forward(image, {cam}, points, ws, pred);
  return pred;
}

/// Every variant with the default stride-2 first stage, the two-stream network with a full-resolution one, and the
/// two-stream network reading RGB + mask.
std::vector<SdfNetConfig> tiny_configs() {
  std::vector<SdfNetConfig> all;
  for (SdfVariant v : {SdfVariant::kTwoStream, SdfVariant::kOneStream, SdfVariant::kGlobalOnly, SdfVariant::kBinary})
    all.push_back(tiny_config(v));
  all.push_back(tiny_config(SdfVariant::kTwoStream, 1));
  all.push_back(tiny_config(SdfVariant::kTwoStream));
  all.back().input_channels = 4;  // RGB + missing-data mask
  all.push_back(tiny_config(SdfVariant::kTwoStream, 1));
  all.back().mirror_features = true;  // one map sampled first (17 px > N), the others projected first
  all.push_back(tiny_config(SdfVariant::kOneStream));
  all.back().mirror_features = true;
  return all;
}

}  // namespace

TEST_CASE("SDF network: finite-difference gradient check of every parameter class, all variants") {
  for (const SdfNetConfig& config : tiny_configs()) {
    CAPTURE(config.to_json().dump());
    SdfNetT<double> net(config);
    net.allocate_grads(true);
    net.init(3);
    Rng rng(11);
    // 30 points: the 9 x 9 first map (17 x 17 with a stride-1 first stage) is sampled first, the smaller maps are
    // projected first (SdfNet's training takes the cheaper order per map): both orders are checked.
    const int B = 2, N = 30, S = 17;
    const TensorT<double> images = random_tensor<double>({B, config.input_channels, S, S}, rng, 0.0, 1.0);
    const TensorT<double> points = random_tensor<double>({B, N, 3}, rng, -0.6, 0.6);
    const std::vector<Camera> cams = {look_at(30, 20, 2.0, S, S), look_at(-100, 35, 2.2, S, S)};
    const TensorT<double> r = random_tensor<double>({B, N}, rng, -1.0, 1.0);  // L = sum(r * pred)
    SdfNetT<double>::Workspace ws;
    TensorT<double> pred;
    auto loss = [&] {
      SdfNetT<double>::Workspace w2;
      TensorT<double> p;
      net.forward(images, cams, points, w2, p);
      double L = 0;
      for (int64_t i = 0; i < p.size(); ++i) L += r[i] * p[i];
      return L;
    };
    net.forward(images, cams, points, ws, pred);
    net.params().zero_grad();
    net.backward(ws, r);
    const std::vector<double> grad(net.params().grads.begin(), net.params().grads.end());
    auto& w = net.params().values;
    REQUIRE(w.size() == grad.size());
    // Every layer's slice gets checked at a few entries (and the gradient must not be all zero).
    int checked = 0, bad = 0;
    double max_rel = 0;
    const auto& layers = net.params().layers();
    for (size_t li = 0; li < layers.size(); ++li) {
      const size_t n = layers[li]->n_params();
      if (n == 0) continue;
      const size_t off = net.params().offset(li);
      for (int k = 0; k < 6; ++k) {
        const size_t i = off + static_cast<size_t>(rng.below(n));
        const double keep = w[i], eps = 1e-6;
        w[i] = keep + eps;
        const double lp = loss();
        w[i] = keep - eps;
        const double lm = loss();
        w[i] = keep;
        const double num = (lp - lm) / (2 * eps);
        const double rel = std::abs(num - grad[i]) / std::max(1e-7, std::abs(num) + std::abs(grad[i]));
        max_rel = std::max(max_rel, rel);
        ++checked;
        if (rel > 1e-4 && std::abs(num - grad[i]) > 1e-8) ++bad;
      }
    }
    CHECK(checked > 30);
    CHECK(bad == 0);
    double gnorm = 0;
    for (double g : grad) gnorm += g * g;
    CHECK(gnorm > 0);
  }
}

TEST_CASE("SDF network: training forward and the per-shape inference path agree, every variant") {
  for (const SdfNetConfig& config : tiny_configs()) {
  CAPTURE(config.to_json().dump());
  SdfNetT<double> net(config);
  net.init(5);
  Rng rng(2);
  const int N = 40, S = 17;
  const TensorT<double> image = random_tensor<double>({1, config.input_channels, S, S}, rng, 0.0, 1.0);
  const TensorT<double> points = random_tensor<double>({1, N, 3}, rng, -0.7, 0.7);
  const Camera cam = look_at(70, 10, 2.0, S, S);
  SdfNetT<double>::Workspace ws;
  TensorT<double> pred;
  net.forward(image, {cam}, points, ws, pred);
  const auto code = net.encode(image.ptr(), cam);
  PointsF p(N, 3);
  for (int i = 0; i < N; ++i)
    for (int d = 0; d < 3; ++d) p(i, d) = static_cast<float>(points[3 * i + d]);
  Eigen::VectorXd inf;
  net.predict(code, p, inf, 7);  // several internal chunks
  // Points went through float in the inference path: compare with a tolerance of float rounding.
  for (int i = 0; i < N; ++i) CHECK(inf[i] == doctest::Approx(pred[i]).epsilon(1e-4).scale(1.0));
  // Block size must not change any value (blocks of 1 point, of 7, of the default).
  Eigen::VectorXd one, whole;
  net.predict(code, p, one, 1);
  net.predict(code, p, whole);
  for (int i = 0; i < N; ++i) {
    CHECK(one[i] == doctest::Approx(inf[i]).epsilon(1e-12).scale(1.0));
    CHECK(whole[i] == doctest::Approx(inf[i]).epsilon(1e-12).scale(1.0));
  }
  }
}

TEST_CASE("SDF network: an RGB + mask network adopting an RGB model computes the same field, and reads the mask") {
  const SdfNetConfig rgb_config = tiny_config(SdfVariant::kTwoStream, 1);
  SdfNetConfig masked_config = rgb_config;
  masked_config.input_channels = 4;
  SdfNetT<double> rgb(rgb_config), masked(masked_config);
  rgb.init(4);
  masked.init(9);
  masked.adopt_parameters(rgb);
  Rng rng(8);
  const int N = 25, S = 17;
  TensorT<double> image4 = random_tensor<double>({1, 4, S, S}, rng, 0.0, 1.0);
  for (int i = 0; i < S * S; ++i) image4[3 * S * S + i] = 0.0;  // nothing missing
  const TensorT<double> points = random_tensor<double>({1, N, 3}, rng, -0.6, 0.6);
  const Camera cam = look_at(40, 25, 2.1, S, S);
  TensorT<double> image3({1, 3, S, S});
  std::copy(image4.ptr(), image4.ptr() + 3 * S * S, image3.ptr());
  SdfNetT<double>::Workspace w3, w4;
  TensorT<double> p3, p4;
  rgb.forward(image3, {cam}, points, w3, p3);
  masked.forward(image4, {cam}, points, w4, p4);
  for (int i = 0; i < N; ++i) CHECK(p4[i] == doctest::Approx(p3[i]).epsilon(1e-12).scale(1.0));
  // The adopted network's gradient reaches the mask weights, and training them makes the mask matter.
  masked.allocate_grads(true);
  masked.params().zero_grad();
  TensorT<double> ones({1, N}, 1.0);
  masked.forward(image4, {cam}, points, w4, p4);
  masked.backward(w4, ones);
  const int out_c = rgb_config.encoder_channels[0];
  double mask_grad = 0;
  for (int o = 0; o < out_c; ++o)
    for (int k = 0; k < 9; ++k) {
      CHECK(masked.params().values[static_cast<size_t>(o * 36 + 27 + k)] == 0.0);
      mask_grad += std::abs(masked.params().grads[static_cast<size_t>(o * 36 + 27 + k)]);
    }
  CHECK(mask_grad > 0);
  for (int o = 0; o < out_c; ++o) masked.params().values[static_cast<size_t>(o * 36 + 27)] = 0.5;
  for (int i = 0; i < S * S; ++i) image4[3 * S * S + i] = i % 2;
  masked.forward(image4, {cam}, points, w4, p4);
  double moved = 0;
  for (int i = 0; i < N; ++i) moved += std::abs(p4[i] - p3[i]);
  CHECK(moved > 1e-6);
  // Only the RGB twin of the same architecture can be adopted.
  SdfNetConfig other = rgb_config;
  other.global_features = 5;
  SdfNetT<double> wrong(other);
  CHECK_THROWS_AS(masked.adopt_parameters(wrong), InvalidInput);
  CHECK_THROWS_AS(rgb.adopt_parameters(rgb), InvalidInput);
}

TEST_CASE("SDF network: a binary network adopting a two-stream model starts with logit = -scale x pred") {
  SdfNetConfig sdf_config = tiny_config(SdfVariant::kTwoStream, 1);
  sdf_config.mirror_features = true;
  SdfNetConfig binary_config = sdf_config;
  binary_config.variant = SdfVariant::kBinary;
  SdfNetT<double> sdf(sdf_config), binary(binary_config);
  sdf.init(5);
  binary.init(6);
  binary.adopt_as_binary(sdf, 10.0);
  Rng rng(3);
  const int N = 30, S = 17;
  const TensorT<double> image = random_tensor<double>({1, 3, S, S}, rng, 0.0, 1.0);
  const TensorT<double> points = random_tensor<double>({1, N, 3}, rng, -0.6, 0.6);
  const Camera cam = look_at(70, 28, 2.4, S, S);
  const TensorT<double> ps = predict_points(sdf, image, cam, points), pb = predict_points(binary, image, cam, points);
  check_logit_is_scaled_pred(pb, ps, N, 10.0);
  // Only a two-stream model of the same architecture, into a binary network, with a positive scale.
  SdfNetConfig other = binary_config;
  other.global_features = 5;
  SdfNetT<double> wrong(other);
  CHECK_THROWS_AS(wrong.adopt_as_binary(sdf, 10.0), InvalidInput);
  CHECK_THROWS_AS(sdf.adopt_as_binary(sdf, 10.0), InvalidInput);
  CHECK_THROWS_AS(binary.adopt_as_binary(binary, 10.0), InvalidInput);
  CHECK_THROWS_AS(binary.adopt_as_binary(sdf, 0.0), InvalidInput);
  CHECK(SdfNetT<double>::can_adopt_as_binary(sdf_config, binary_config));
  CHECK_FALSE(SdfNetT<double>::can_adopt_as_binary(binary_config, sdf_config));
}

TEST_CASE("SDF network: a binary RGB + mask network with mirror features adopting an RGB two-stream model") {
  // One step from an RGB model without mirror features to the binary variant with both: logit = -scale x pred on
  // inputs with nothing missing.
  const SdfNetConfig rgb_config = tiny_config(SdfVariant::kTwoStream, 1);
  SdfNetConfig binary_config = rgb_config;
  binary_config.variant = SdfVariant::kBinary;
  binary_config.input_channels = 4;
  binary_config.mirror_features = true;
  REQUIRE_FALSE(rgb_config.mirror_features);
  SdfNetT<double> rgb(rgb_config), binary(binary_config);
  rgb.init(5);
  binary.init(6);
  CHECK(SdfNetT<double>::can_adopt_as_binary(rgb_config, binary_config));
  binary.adopt_as_binary(rgb, 10.0);
  Rng rng(4);
  const int N = 30, S = 17;
  TensorT<double> image4 = random_tensor<double>({1, 4, S, S}, rng, 0.0, 1.0);
  for (int i = 0; i < S * S; ++i) image4[3 * S * S + i] = 0.0;
  TensorT<double> image3({1, 3, S, S});
  std::copy(image4.ptr(), image4.ptr() + 3 * S * S, image3.ptr());
  const TensorT<double> points = random_tensor<double>({1, N, 3}, rng, -0.6, 0.6);
  const Camera cam = look_at(70, 28, 2.4, S, S);
  const TensorT<double> ps = predict_points(rgb, image3, cam, points), pb = predict_points(binary, image4, cam, points);
  check_logit_is_scaled_pred(pb, ps, N, 10.0);
  // The other way (a binary model's mask channel dropped) is refused.
  SdfNetConfig rgb_binary = rgb_config;
  rgb_binary.variant = SdfVariant::kBinary;
  SdfNetConfig masked_sdf = binary_config;
  masked_sdf.variant = SdfVariant::kTwoStream;
  CHECK_FALSE(SdfNetT<double>::can_adopt_as_binary(masked_sdf, rgb_binary));
}

TEST_CASE("SDF network: mirror features read the image where the point's mirror image projects") {
  // Independent reference: with its own local weights zeroed and its mirror weights set to a plain network's
  // local weights, a mirror network seen through the mirrored camera R diag(-1, 1, 1) projects (-x, y, z) where
  // the plain network projects (x, y, z), so the two compute the same field (the point MLPs see the same point).
  const SdfNetConfig plain_config = tiny_config(SdfVariant::kTwoStream, 1);
  SdfNetConfig mirror_config = plain_config;
  mirror_config.mirror_features = true;
  SdfNetT<double> plain(plain_config), mirror(mirror_config);
  plain.init(3);
  mirror.init(11);
  CHECK(mirror.n_params() > plain.n_params());
  mirror.adopt_parameters(plain);
  Rng rng(6);
  const int N = 30, S = 17;
  const TensorT<double> image = random_tensor<double>({1, 3, S, S}, rng, 0.0, 1.0);
  const TensorT<double> points = random_tensor<double>({1, N, 3}, rng, -0.6, 0.6);
  const Camera cam = look_at(35, 20, 2.0, S, S);
  const TensorT<double> pp = predict_points(plain, image, cam, points);
  // 1. Adopted with zero mirror weights: the same field.
  TensorT<double> pm = predict_points(mirror, image, cam, points);
  for (int i = 0; i < N; ++i) CHECK(pm[i] == doctest::Approx(pp[i]).epsilon(1e-12).scale(1.0));
  // 2. Own local weights zeroed, mirror weights = the plain network's local weights, mirrored camera.
  const size_t tail = plain.n_params();
  auto& v = mirror.params().values;
  const auto& layers = mirror.params().layers();
  size_t local_begin = 0, local_end = 0;  // the plain local weights are the last Conv2d layers before `tail`
  for (size_t l = 0; l < layers.size(); ++l)
    if (layers[l]->type() == "conv2d" && mirror.params().offset(l) < tail &&
        static_cast<const Conv2d<double>*>(layers[l])->settings().kernel == 1) {
      if (local_begin == 0) local_begin = mirror.params().offset(l);
      local_end = mirror.params().offset(l) + layers[l]->n_params();
    }
  REQUIRE(local_end > local_begin);
  REQUIRE(v.size() - tail == local_end - local_begin);
  std::copy(v.begin() + static_cast<std::ptrdiff_t>(local_begin), v.begin() + static_cast<std::ptrdiff_t>(local_end),
            v.begin() + static_cast<std::ptrdiff_t>(tail));
  std::fill(v.begin() + static_cast<std::ptrdiff_t>(local_begin), v.begin() + static_cast<std::ptrdiff_t>(local_end), 0.0);
  Camera mirrored = cam;
  mirrored.R = cam.R * Eigen::Vector3d(-1, 1, 1).asDiagonal();
  pm = predict_points(mirror, image, mirrored, points);
  for (int i = 0; i < N; ++i) CHECK(pm[i] == doctest::Approx(pp[i]).epsilon(1e-10).scale(1.0));
  // ... which the unmirrored camera does not give (the mirror weights are read).
  pm = predict_points(mirror, image, cam, points);
  double differs = 0;
  for (int i = 0; i < N; ++i) differs += std::abs(pm[i] - pp[i]);
  CHECK(differs > 1e-6);
  // 3. The per-shape inference path agrees.
  const auto code = mirror.encode(image.ptr(), mirrored);
  PointsF p(N, 3);
  for (int i = 0; i < N; ++i)
    for (int d = 0; d < 3; ++d) p(i, d) = static_cast<float>(points[3 * i + d]);
  Eigen::VectorXd inf;
  mirror.predict(code, p, inf);
  for (int i = 0; i < N; ++i) CHECK(inf[i] == doctest::Approx(pp[i]).epsilon(1e-4).scale(1.0));
  // 4. RGB without mirror -> RGB + mask with mirror in one adoption; the reverse and the identity are refused.
  SdfNetConfig both = mirror_config;
  both.input_channels = 4;
  SdfNetT<double> masked_mirror(both);
  masked_mirror.adopt_parameters(plain);
  TensorT<double> image4({1, 4, S, S}, 0.0);
  std::copy(image.ptr(), image.ptr() + 3 * S * S, image4.ptr());
  const TensorT<double> p4 = predict_points(masked_mirror, image4, cam, points);
  for (int i = 0; i < N; ++i) CHECK(p4[i] == doctest::Approx(pp[i]).epsilon(1e-12).scale(1.0));
  CHECK_THROWS_AS(plain.adopt_parameters(mirror), InvalidInput);
  CHECK_THROWS_AS(mirror.adopt_parameters(mirror), InvalidInput);
  CHECK(SdfNetConfig::from_json(mirror_config.to_json()).mirror_features);
  Json old = plain_config.to_json();
  old.erase("mirror_features");
  CHECK_FALSE(SdfNetConfig::from_json(old).mirror_features);
}

TEST_CASE("SDF network: the local-feature path is used and samples where the point projects") {
  SdfNetT<double> net(tiny_config(SdfVariant::kTwoStream));
  net.init(9);
  Rng rng(4);
  const int S = 17;
  const TensorT<double> image = random_tensor<double>({1, 3, S, S}, rng, 0.0, 1.0);
  const Camera cam = look_at(40, 25, 2.0, S, S);
  auto code = net.encode(image.ptr(), cam);
  PointsF p(3, 3);
  p << 0.1f, 0.2f, -0.1f, -0.3f, 0.05f, 0.25f, 0.2f, -0.3f, 0.1f;

  // 1. A point moved within the image plane: its local feature is the bilinear interpolation of every map at the
  //    new projection (computed here independently from the camera and the map sizes).
  const Vec3 x_axis = cam.R.row(0).transpose();  // camera x in object-frame coordinates
  PointsF moved = p;
  for (int i = 0; i < 3; ++i) moved.row(i) += (0.037f * (i + 1)) * x_axis.cast<float>().transpose();
  TensorT<double> f;
  net.local_features(code, moved, f);
  const auto sizes = net.map_sizes();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d px = project(cam, moved.row(i).transpose().cast<double>());
    int col = 0;
    for (size_t k = 0; k < code.maps.size(); ++k) {
      const auto& map = code.maps[k];
      const int C = static_cast<int>(map.dim(1)), W = sizes[k];
      // pixel -> network image (centre at integers) -> map, corner-aligned (nets/bilinear_sample.h).
      double x = (px.x() - 0.5) * (W - 1) / (S - 1.0), y = (px.y() - 0.5) * (W - 1) / (S - 1.0);
      x = std::clamp(x, 0.0, W - 1.0);
      y = std::clamp(y, 0.0, W - 1.0);
      const int x0 = std::min(static_cast<int>(std::floor(x)), W - 2), y0 = std::min(static_cast<int>(std::floor(y)), W - 2);
      const double ax = x - x0, ay = y - y0;
      for (int c = 0; c < C; ++c) {
        auto at = [&](int yy, int xx) { return map[(static_cast<int64_t>(c) * W + yy) * W + xx]; };
        const double expect = (1 - ay) * ((1 - ax) * at(y0, x0) + ax * at(y0, x0 + 1)) +
                              ay * ((1 - ax) * at(y0 + 1, x0) + ax * at(y0 + 1, x0 + 1));
        CHECK(f[i * f.dim(1) + col + c] == doctest::Approx(expect).epsilon(1e-5));
      }
      col += C;
    }
    CHECK(col == f.dim(1));
  }

  // 2. A point moved along its camera ray keeps its local feature (same projection).
  const Vec3 C = camera_center(cam);
  PointsF along = p;
  for (int i = 0; i < 3; ++i) {
    const Vec3 x = p.row(i).transpose().cast<double>();
    along.row(i) = (C + 0.8 * (x - C)).cast<float>().transpose();
  }
  TensorT<double> f1, f2;
  net.local_features(code, p, f1);
  net.local_features(code, along, f2);
  for (int64_t i = 0; i < f1.size(); ++i) CHECK(f1[i] == doctest::Approx(f2[i]).epsilon(1e-4));

  // 3. Zeroing the feature maps changes the output (the local stream reads them through their per-image 1x1
  //    projections, which are what the point evaluation samples: zero those).
  Eigen::VectorXd before, after;
  net.predict(code, p, before);
  for (auto& m : code.maps) m.fill(0.0);
  for (auto& stream : code.proj)
    for (auto& m : stream) m.fill(0.0);
  net.predict(code, p, after);
  CHECK((before - after).cwiseAbs().maxCoeff() > 1e-6);
  // ... while for the global-only variant the maps are not read by the decoder at all.
  SdfNetT<double> g(tiny_config(SdfVariant::kGlobalOnly));
  g.init(9);
  auto gcode = g.encode(image.ptr(), cam);
  g.predict(gcode, p, before);
  for (auto& m : gcode.maps) m.fill(0.0);
  CHECK(gcode.proj.size() == 1);
  CHECK(gcode.proj[0].empty());
  g.predict(gcode, p, after);
  CHECK((before - after).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("SDF network configuration round-trips through JSON and rejects bad values") {
  SdfNetConfig c = tiny_config(SdfVariant::kOneStream);
  const SdfNetConfig d = SdfNetConfig::from_json(c.to_json());
  CHECK(d.to_json() == c.to_json());
  Json bad = c.to_json();
  bad["variant"] = "three-stream";
  CHECK_THROWS_AS(SdfNetConfig::from_json(bad), IoError);
  bad = c.to_json();
  bad.erase("decoder");
  CHECK_THROWS_AS(SdfNetConfig::from_json(bad), IoError);
  // Models written before first_stride existed load with the stride-2 first stage they were trained with.
  bad = tiny_config(SdfVariant::kTwoStream, 1).to_json();
  CHECK(SdfNetConfig::from_json(bad).first_stride == 1);
  bad.erase("first_stride");
  CHECK(SdfNetConfig::from_json(bad).first_stride == 2);
  CHECK(SdfNetT<float>{tiny_config(SdfVariant::kTwoStream, 1)}.map_sizes() == std::vector<int>{17, 9, 5});
  CHECK(SdfNetT<float>{tiny_config(SdfVariant::kTwoStream, 2)}.map_sizes() == std::vector<int>{9, 5, 3});
  c.first_stride = 3;
  CHECK_THROWS_AS(SdfNetT<float>{c}, InvalidInput);
  c.first_stride = 2;
  c.one_stream_maps = 7;
  CHECK_THROWS_AS(SdfNetT<float>{c}, InvalidInput);
  // Models written before the mask channel existed read RGB; only 3 or 4 input channels exist.
  bad = tiny_config(SdfVariant::kTwoStream).to_json();
  bad.erase("input_channels");
  CHECK(SdfNetConfig::from_json(bad).input_channels == 3);
  c = tiny_config(SdfVariant::kTwoStream);
  c.input_channels = 2;
  CHECK_THROWS_AS(SdfNetT<float>{c}, InvalidInput);
  // The fourth channel's meaning: written only for the object mask (older models keep their bytes), read back,
  // absent = the missing-data mask, another name refused; an object mask needs the fourth channel.
  c = tiny_config(SdfVariant::kTwoStream);
  c.input_channels = 4;
  CHECK(!c.to_json().contains("mask_channel"));
  CHECK(!c.reads_context());
  c.mask_channel = SdfNetConfig::MaskChannel::kObject;
  CHECK(c.to_json().at("mask_channel") == "object");
  c.context_band = 6;
  CHECK(SdfNetConfig::from_json(c.to_json()).context_band == 6);
  c.context_band = -1;
  CHECK_THROWS_AS(SdfNetT<float>{c}, InvalidInput);
  c.context_band = 6;
  CHECK(SdfNetConfig::from_json(c.to_json()).reads_context());
  CHECK(SdfNetConfig::from_json(c.to_json()).to_json() == c.to_json());
  bad = c.to_json();
  bad["mask_channel"] = "depth";
  CHECK_THROWS_AS(SdfNetConfig::from_json(bad), IoError);
  c.input_channels = 3;
  CHECK(!c.reads_context());
  CHECK_THROWS_AS(SdfNetT<float>{c}, InvalidInput);
}
