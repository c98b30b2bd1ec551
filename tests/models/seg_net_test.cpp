#include "models/seg_net.h"

#include "camera/mask_morphology.h"
#include "core/error.h"
#include "core/files.h"
#include "nets/checkpoint.h"
#include "nets/gradcheck.h"
#include "nets/loss.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A tiny segmenter: 16 px input, two stages (8 and 4 px maps), two decoder layers.
SegNetConfig tiny_config() {
  SegNetConfig c;
  c.size = 16;
  c.encoder = {3, 4};
  c.extra_convs = 1;
  c.decoder = {5, 3};
  return c;
}

}  // namespace

TEST_CASE("SegNet: every parameter's gradient matches central differences (double)") {
  for (const auto& arch : {std::pair{0, 0}, std::pair{1, 0}, std::pair{1, 2}}) {
    const int extra = arch.first, fine = arch.second;  // not a structured binding: clang 14 cannot capture one in INFO
    SegNetConfig c = tiny_config();
    c.extra_convs = extra;
    c.fine = fine;
    SegNetT<double> net(c, true);
    net.init(3);
    Rng rng(11);
    for (auto& v : net.params().values) v += 0.1 * rng.uniform(-1, 1);  // non-zero biases matter too
    const TensorD x = test::random_tensor({2, 3, 16, 16}, 5, 0.0, 1.0);
    const TensorD& y = net.forward(x, true);
    CHECK(y.shape == Shape{2, 1, 16, 16});
    const TensorD r = test::random_tensor(y.shape, 6);
    net.params().zero_grad();
    net.backward(r);
    auto loss = [&] { return test::dot(r, net.forward(x, false)); };
    // Indices spread over the whole buffer plus every parameter of the last 40 (the context term's and the head's).
    std::vector<size_t> idx = test::some_indices(net.n_params(), 150, 7);
    for (size_t i = net.n_params() - 40; i < net.n_params(); ++i) idx.push_back(i);
    std::vector<double> analytic;
    for (size_t i : idx) analytic.push_back(net.params().grads[i]);
    const double err = test::relative_error(analytic, test::numeric_gradient(loss, net.params().values.data(), idx));
    INFO("extra convs ", extra, " fine ", fine, " relative error ", err);
    CHECK(err < 1e-6);
  }
}

TEST_CASE("SegNet fine branch: starts from a coarse network disconnected, then resolves single pixels") {
  SegNetConfig c = tiny_config();
  SegNetT<double> coarse(c, false);
  coarse.init(4);
  c.fine = 3;
  SegNetT<double> fine(c, false);
  fine.init(9);
  fine.start_from_coarse(coarse);
  // The coarse parameters are the prefix; the projection of the fine map (the last 3 x 5 values) is zero, so the
  // fine convolutions do not reach the logits until training moves it.
  REQUIRE(fine.n_params() == coarse.n_params() + (3 * 3 * 3 * 3 + 3) + (3 * 3 * 3 * 3 + 3) + 3 * 5);
  for (size_t i = 0; i < coarse.n_params(); ++i) REQUIRE(fine.params().values[i] == coarse.params().values[i]);
  const TensorD x = test::random_tensor({1, 3, 16, 16}, 8, 0.0, 1.0);
  const TensorD y0 = fine.forward(x, false);
  for (size_t i = coarse.n_params(); i < fine.n_params() - 15; ++i) fine.params().values[i] += 0.3;
  CHECK(fine.forward(x, false).data == y0.data);
  // With the encoder cut (its stages' 168 + 260 parameters zero: every map is zero, the hypercolumn is the context
  // term's bias everywhere) the logits see the input through the fine branch alone: two 3x3 convolutions, so a pixel
  // moves the logits within 2 pixels of it and nowhere else; the coarse path would spread it over 4 x 4 blocks.
  for (size_t i = fine.n_params() - 15; i < fine.n_params(); ++i) fine.params().values[i] = 0.5;
  for (size_t i = 0; i < 168 + 260; ++i) fine.params().values[i] = 0;
  TensorD x2 = x;
  const int64_t at = 8 * 16 + 8;  // pixel (8, 8) of channel 0
  x2[at] += 0.5;
  const TensorD a = fine.forward(x, false), b = fine.forward(x2, false);
  int moved_near = 0;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) moved_near += b[at + dy * 16 + dx] != a[at + dy * 16 + dx];
  CHECK(moved_near > 0);
  for (int y = 0; y < 16; ++y)
    for (int xx = 0; xx < 16; ++xx)
      if (std::abs(y - 8) > 2 || std::abs(xx - 8) > 2) CHECK(b[y * 16 + xx] == a[y * 16 + xx]);
  // Settings other than the branch must agree.
  SegNetConfig other = c;
  other.decoder = {4, 3};
  SegNetT<double> wrong(other, false);
  CHECK_THROWS_AS(wrong.start_from_coarse(coarse), InvalidInput);
  CHECK_THROWS_AS(coarse.start_from_coarse(coarse), InvalidInput);
}

TEST_CASE("SegNet: the context vector reaches every pixel, and items do not mix") {
  SegNetT<double> net(tiny_config(), true);
  net.init(4);
  TensorD x = test::random_tensor({2, 3, 16, 16}, 8, 0.0, 1.0);
  const TensorD y0 = net.forward(x, false);
  // Changing one corner pixel of item 1 changes item 1's logits far from it (through the global context) and leaves
  // item 0's alone.
  x[x.item_size() + 0] += 0.5;
  const TensorD y1 = net.forward(x, false);
  const int64_t n = y0.item_size();
  for (int64_t i = 0; i < n; ++i) CHECK(y1[i] == y0[i]);
  CHECK(y1[n + n - 1] != y0[n + n - 1]);
}

TEST_CASE("SegNet: the segmentation loss (BCE + soft IoU) matches closed forms and central differences") {
  TensorD z = test::random_tensor({2, 1, 4, 4}, 21, -3, 3);
  TensorD t = test::random_tensor({2, 1, 4, 4}, 22, 0, 1);
  for (int64_t i = 0; i < t.size(); i += 3) t[i] = std::round(t[i]);
  // Without the IoU term it is nets/loss.h's BCE exactly.
  TensorD g0, g1;
  CHECK(segmentation_loss(z, t, 0.0, &g0) == bce_with_logits_loss(z, t, &g1));
  CHECK(g0.data == g1.data);
  for (const double w : {0.5, 2.0}) {
    TensorD g;
    double bce = 0;
    const double l = segmentation_loss(z, t, w, &g, &bce);
    CHECK(bce == doctest::Approx(bce_with_logits_loss<double>(z, t, nullptr)).epsilon(1e-12));
    // The IoU term by hand.
    double iou = 0;
    for (int b = 0; b < 2; ++b) {
      double I = 0, U = 1;
      for (int64_t i = 0; i < 16; ++i) {
        const double p = 1 / (1 + std::exp(-z[b * 16 + i])), y = t[b * 16 + i];
        I += p * y;
        U += p + y - p * y;
      }
      iou += I / U / 2;
    }
    CHECK(l == doctest::Approx(bce + w * (1 - iou)).epsilon(1e-12));
    std::vector<size_t> idx(static_cast<size_t>(z.size()));
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::vector<double> a(g.data.begin(), g.data.end());
    const auto num = test::numeric_gradient([&] { return segmentation_loss<double>(z, t, w, nullptr); }, z.ptr(), idx);
    CHECK(test::relative_error(a, num) < 1e-7);
  }
  // Confident right answers cost almost nothing; confident wrong ones a lot.
  TensorD labels({1, 1, 2, 2}), right({1, 1, 2, 2}), wrong({1, 1, 2, 2});
  for (int i = 0; i < 4; ++i) {
    labels[i] = i % 2;
    right[i] = i % 2 ? 30 : -30;
    wrong[i] = -right[i];
  }
  CHECK(segmentation_loss<double>(right, labels, 1.0, nullptr) < 0.34);  // the +1 of the union: 1 - 2/3
  CHECK(segmentation_loss<double>(right, labels, 0.0, nullptr) < 1e-12);
  CHECK(segmentation_loss<double>(wrong, labels, 1.0, nullptr) > 30);
  CHECK_THROWS_AS(segmentation_loss<double>(right, TensorD({1, 1, 2, 3}), 1.0, nullptr), InvalidInput);
}

TEST_CASE("SegNet: the thin-part weighted loss matches the weighted sum and central differences") {
  TensorD z = test::random_tensor({2, 1, 8, 8}, 31, -3, 3);
  TensorD t({2, 1, 8, 8});
  // Item 0: a 4 x 4 block with a 1-px tail 3 px long; item 1: nothing.
  for (int y = 1; y < 5; ++y)
    for (int x = 1; x < 5; ++x) t[y * 8 + x] = 1;
  for (int y = 5; y < 8; ++y) t[y * 8 + 2] = 1;
  const TensorD w = thin_part_weights(t, 3.0, 1);
  // The weights are 3 exactly on camera/mask_morphology.h's thin parts of each item (closed forms in its test), 1
  // elsewhere; the tail's end is among them and the block's middle is not.
  for (int b = 0; b < 2; ++b) {
    Image label(8, 8, 1);
    for (int i = 0; i < 64; ++i) label.data[static_cast<size_t>(i)] = static_cast<float>(t[b * 64 + i]);
    const Image thin = thin_parts(label, 1);
    for (int i = 0; i < 64; ++i) CHECK(w[b * 64 + i] == (thin.data[static_cast<size_t>(i)] == 1.0f ? 3.0 : 1.0));
  }
  CHECK(w[7 * 8 + 2] == 3.0);
  CHECK(w[2 * 8 + 2] == 1.0);
  // Weights of 1 give the unweighted loss exactly; the weighted BCE is the weighted mean by hand.
  TensorD ones({2, 1, 8, 8}), g0, g1;
  ones.data.assign(ones.data.size(), 1.0);
  CHECK(segmentation_loss(z, t, 0.5, &g0, nullptr, &ones) == segmentation_loss(z, t, 0.5, &g1));
  CHECK(g0.data == g1.data);
  double by_hand = 0;
  for (int64_t i = 0; i < z.size(); ++i) {
    const double p = 1 / (1 + std::exp(-z[i]));
    by_hand -= w[i] * (t[i] * std::log(p) + (1 - t[i]) * std::log(1 - p));
  }
  by_hand /= static_cast<double>(z.size());
  double bce = 0;
  TensorD g;
  const double l = segmentation_loss(z, t, 0.5, &g, &bce, &w);
  CHECK(bce == doctest::Approx(by_hand).epsilon(1e-12));
  // The soft-IoU term is not weighted.
  const double iou_term = segmentation_loss<double>(z, t, 0.5, nullptr) - bce_with_logits_loss<double>(z, t, nullptr);
  CHECK(l == doctest::Approx(bce + iou_term).epsilon(1e-12));
  std::vector<size_t> idx(static_cast<size_t>(z.size()));
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::vector<double> a(g.data.begin(), g.data.end());
  const auto num = test::numeric_gradient([&] { return segmentation_loss<double>(z, t, 0.5, nullptr, nullptr, &w); },
                                          z.ptr(), idx);
  CHECK(test::relative_error(a, num) < 1e-7);
  // Bad weights and settings are refused.
  TensorD negative = ones;
  negative[3] = -1;
  CHECK_THROWS_AS(segmentation_loss<double>(z, t, 0.5, nullptr, nullptr, &negative), InvalidInput);
  const TensorD short_weights({1, 1, 8, 8});
  CHECK_THROWS_AS(segmentation_loss<double>(z, t, 0.5, nullptr, nullptr, &short_weights), InvalidInput);
  CHECK_THROWS_AS(thin_part_weights(t, 0.5, 1), InvalidInput);
  CHECK_THROWS_AS(thin_part_weights(t, 2.0, 0), InvalidInput);
  CHECK_THROWS_AS(thin_part_weights(TensorD({2, 2, 8, 8}), 2.0, 1), InvalidInput);
}

TEST_CASE("SegNet letterbox: geometry, edge replication, and the way back reproduces affine ramps") {
  const Letterbox g = letterbox_geometry(200, 100, 128);
  CHECK(g.width == 128);
  CHECK(g.height == 64);
  CHECK(g.x0 == 0);
  CHECK(g.y0 == 32);
  const Letterbox t = letterbox_geometry(90, 160, 128);
  CHECK(t.height == 128);
  CHECK(t.width == 72);
  CHECK(t.x0 == 28);
  CHECK_THROWS_AS(letterbox_geometry(0, 10, 128), InvalidInput);

  // An affine ramp in x and y; the letterbox area-averages it (exact for an affine function away from the clamp).
  Image img(200, 100, 1);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 200; ++x) img.at(x, y) = static_cast<float>(0.002 * x + 0.003 * y + 0.1);
  Letterbox gb;
  const Image lb = letterbox(img, 128, &gb);
  CHECK(lb.width == 128);
  CHECK(lb.height == 128);
  // Rows above and below the image repeat its first and last rows.
  for (int x = 0; x < 128; x += 9) {
    CHECK(lb.at(x, 0) == lb.at(x, gb.y0));
    CHECK(lb.at(x, 127) == lb.at(x, gb.y0 + gb.height - 1));
  }
  const Image back = unletterbox(lb, gb);
  CHECK(back.width == 200);
  CHECK(back.height == 100);
  for (int y = 3; y < 97; y += 7)
    for (int x = 3; x < 197; x += 11) CHECK(back.at(x, y) == doctest::Approx(img.at(x, y)).epsilon(1e-5));
  CHECK_THROWS_AS(unletterbox(img, gb), InvalidInput);
}

TEST_CASE("SegNet model file: round trip gives the same probabilities, foreign or damaged files are refused") {
  const fs::path dir = test::scratch_dir("seg_net_model");
  SegNetConfig c = tiny_config();
  SegNet net(c, true);
  net.init(9);
  const std::string path = (dir / "seg.ckpt").string();
  save_seg_model(path, net, {{"step", 3}});
  Json training;
  auto loaded = load_seg_model(path, &training);
  CHECK(training.at("step").get<int>() == 3);
  CHECK(loaded->architecture() == net.architecture());
  Image photo(37, 23, 3);
  Rng rng(2);
  for (float& v : photo.data) v = static_cast<float>(rng.uniform());
  const Image a = predict_foreground(net, photo), b = predict_foreground(*loaded, photo);
  CHECK(a.width == 37);
  CHECK(a.height == 23);
  CHECK(a.channels == 1);
  CHECK(a.data == b.data);
  for (const float v : a.data) CHECK((v > 0 && v < 1));
  // Several images of different sizes in one forward pass: each as read alone (up to float rounding).
  Image wide(60, 20, 3), grey(25, 31, 1);
  for (float& v : wide.data) v = static_cast<float>(rng.uniform());
  for (float& v : grey.data) v = static_cast<float>(rng.uniform());
  const std::vector<Image> together = predict_foreground(net, std::vector<Image>{photo, wide, grey});
  REQUIRE(together.size() == 3);
  for (const auto& [one, alone] : {std::pair{&together[0], a}, std::pair{&together[1], predict_foreground(net, wide)},
                                  std::pair{&together[2], predict_foreground(net, grey)}}) {
    REQUIRE(one->width == alone.width);
    REQUIRE(one->height == alone.height);
    for (size_t i = 0; i < alone.data.size(); ++i) CHECK(one->data[i] == doctest::Approx(alone.data[i]).epsilon(1e-5));
  }
  CHECK_THROWS_AS((void)predict_foreground(net, std::vector<Image>{}), InvalidInput);
  // Another kind of checkpoint, and a truncated file.
  Checkpoint other;
  other.header["kind"] = "pose_model";
  other.set_block("params", {1.f});
  save_checkpoint((dir / "pose.ckpt").string(), other);
  CHECK_THROWS_AS(load_seg_model((dir / "pose.ckpt").string()), IoError);
  const std::string bytes = read_file(path);
  write_text_atomic((dir / "cut.ckpt").string(), bytes.substr(0, bytes.size() / 2));
  CHECK_THROWS_AS(load_seg_model((dir / "cut.ckpt").string()), IoError);
  CHECK_THROWS_AS(SegNet(SegNetConfig{100, {16, 32, 64}, 1, {8}}, false), InvalidInput);  // 100 % 8 != 0
}
