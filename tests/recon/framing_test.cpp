#include "recon/framing.h"

#include "camera/camera.h"
#include "core/error.h"
#include "core/random.h"
#include "train/dataset.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

/// An image of `w` x `h` with a filled ellipse (centre cx, cy; radii rx, ry) of colour (0.8, 0.3, 0.1) on `bg`;
/// with `alpha`, 4 channels and the ellipse opaque on a transparent background.
Image ellipse_image(int w, int h, double cx, double cy, double rx, double ry, const float bg[3], bool alpha = false) {
  Image im(w, h, alpha ? 4 : 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double u = (x + 0.5 - cx) / rx, v = (y + 0.5 - cy) / ry;
      const bool in = u * u + v * v <= 1.0;
      const float col[3] = {0.8f, 0.3f, 0.1f};
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = in ? col[c] : bg[c];
      if (alpha) im.at(x, y, 3) = in ? 1.f : 0.f;
    }
  return im;
}

/// A w x h blue-green checker of `cell` px squares with seeded uniform noise of +-`noise` in every channel.
Image noisy_checker(int w, int h, int cell, double noise, uint64_t seed) {
  Image im(w, h, 3);
  Rng rng(seed);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool dark = ((x / cell) + (y / cell)) % 2 == 0;
      const float n = static_cast<float>(rng.uniform(-noise, noise));
      im.at(x, y, 0) = 0.1f + n;
      im.at(x, y, 1) = (dark ? 0.35f : 0.6f) + n;
      im.at(x, y, 2) = (dark ? 0.45f : 0.75f) + n;
    }
  return im;
}

/// Paint the filled ellipse (centre cx, cy; radii rx, ry) in `colour` over an RGB image.
void paint_ellipse(Image& im, double cx, double cy, double rx, double ry, const float colour[3]) {
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const double u = (x + 0.5 - cx) / rx, v = (y + 0.5 - cy) / ry;
      if (u * u + v * v <= 1.0)
        for (int c = 0; c < 3; ++c) im.at(x, y, c) = colour[c];
    }
}

/// IoU of the pixels over 0.5 of a 1-channel mask and the ellipse.
double mask_iou(const Image& mask, double cx, double cy, double rx, double ry) {
  long inter = 0, uni = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const double u = (x + 0.5 - cx) / rx, v = (y + 0.5 - cy) / ry;
      const bool a = u * u + v * v <= 1.0, b = mask.at(x, y) > 0.5f;
      inter += a && b;
      uni += a || b;
    }
  return uni == 0 ? 0.0 : static_cast<double>(inter) / static_cast<double>(uni);
}

/// Box of the network image's pixels with alpha over 0.5.
PixelBox alpha_box(const Image& rgba) {
  int x0 = rgba.width, y0 = rgba.height, x1 = -1, y1 = -1;
  for (int y = 0; y < rgba.height; ++y)
    for (int x = 0; x < rgba.width; ++x)
      if (rgba.at(x, y, 3) > 0.5f) {
        x0 = std::min(x0, x);
        y0 = std::min(y0, y);
        x1 = std::max(x1, x);
        y1 = std::max(y1, y);
      }
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

const float kWhite[3] = {1.f, 1.f, 1.f};

}  // namespace

TEST_CASE("framing: a render framed like the training renders passes through unchanged") {
  // 137 px RGBA, object centred (with the training's small downward offset) at the median extent.
  const TrainingFraming tf;
  const double r = 0.5 * tf.extent * 137;
  const Image im = ellipse_image(137, 137, 68.5 + tf.centre_dx * 137, 68.5 + tf.centre_dy * 137, r, r, kWhite, true);
  const FramedInput f = frame_input(im, nullptr, FramingSettings{}, "render");
  CHECK(f.mask_source == "alpha");
  CHECK_FALSE(f.reframed);
  CHECK(f.x0 == 0);
  CHECK(f.side == 137);
  REQUIRE(f.image.width == 137);
  double worst = 0;
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x) {
      worst = std::max(worst, static_cast<double>(std::abs(f.image.at(x, y, 3) - im.at(x, y, 3))));
      if (im.at(x, y, 3) > 0)
        for (int c = 0; c < 3; ++c) worst = std::max(worst, static_cast<double>(std::abs(f.image.at(x, y, c) - im.at(x, y, c))));
    }
  CHECK(worst < 1e-6);
}

TEST_CASE("framing: an off-centre object in a non-square image on a plain colour is cropped to the training framing") {
  const float blue[3] = {0.1f, 0.2f, 0.7f};
  const double cx = 230, cy = 60, rx = 40, ry = 25;
  const Image im = ellipse_image(300, 180, cx, cy, rx, ry, blue);
  const FramedInput f = frame_input(im, nullptr, FramingSettings{}, "photo");
  CHECK(f.mask_source == "plain-background");
  CHECK(f.reframed);
  CHECK(f.warnings.empty());
  CHECK(mask_iou(f.mask, cx, cy, rx, ry) > 0.97);
  // In the network image the object's longer side is the training extent and its centre the training centre.
  const TrainingFraming tf;
  const PixelBox b = alpha_box(f.image);
  CHECK(std::abs(b.w - tf.extent * 137) <= 2.0);
  CHECK(std::abs(b.x + 0.5 * b.w - (0.5 + tf.centre_dx) * 137) <= 1.5);
  CHECK(std::abs(b.y + 0.5 * b.h - (0.5 + tf.centre_dy) * 137) <= 1.5);
  // The network image shows the object's colour, not the blue background.
  const int mx = b.x + b.w / 2, my = b.y + b.h / 2;
  CHECK(f.image.at(mx, my, 0) == doctest::Approx(0.8).epsilon(0.01));
  CHECK(f.image.at(2, 2, 3) == 0.f);  // outside the object: transparent (white after compositing)
}

TEST_CASE("framing: cameras map between the network image and the input image") {
  const float grey[3] = {0.5f, 0.5f, 0.5f};
  const Image im = ellipse_image(320, 200, 100, 120, 30, 45, grey);
  const FramedInput f = frame_input(im, nullptr, FramingSettings{}, "photo");
  REQUIRE(f.reframed);
  const Camera net = look_at(30, 25, 2.7);
  const Camera in = camera_in_input(net, f, 320, 200);
  CHECK(in.width == 320);
  CHECK(in.height == 200);
  const double s = f.side / 137;
  Rng rng(3);
  for (int i = 0; i < 20; ++i) {
    const Vec3 p(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5));
    const Eigen::Vector2d u = project(net, p), v = project(in, p);
    CHECK(v.x() == doctest::Approx(f.x0 + s * u.x()).epsilon(1e-9));
    CHECK(v.y() == doctest::Approx(f.y0 + s * u.y()).epsilon(1e-9));
  }
  const Camera back = camera_in_network(in, f);
  CHECK((back.K - net.K).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(back.width == 137);
}

TEST_CASE("framing: GrabCut separates an object from a textured background, the same way every time") {
  // A blue-green checker texture with noise: the border is not plain.
  Image im = noisy_checker(240, 180, 12, 0.05, 11);
  const double cx = 110, cy = 95, rx = 45, ry = 35;
  const float orange[3] = {0.85f, 0.25f, 0.1f};
  paint_ellipse(im, cx, cy, rx, ry, orange);
  const FramedInput f = frame_input(im, nullptr, FramingSettings{}, "textured");
  CHECK(f.mask_source == "grabcut");
  REQUIRE(f.warnings.size() == 1);
  CHECK(f.warnings[0].find("GrabCut") != std::string::npos);
  CHECK(mask_iou(f.mask, cx, cy, rx, ry) > 0.9);
  const FramedInput again = frame_input(im, nullptr, FramingSettings{}, "textured");
  CHECK(again.mask.data == f.mask.data);
  // With a box around the object GrabCut finds it too; the explicit mode gives no warning.
  FramingSettings st;
  st.segment = Segmentation::kGrabCut;
  st.box = PixelBox{55, 50, 110, 90};
  const FramedInput boxed = frame_input(im, nullptr, st, "textured");
  CHECK(boxed.warnings.empty());
  CHECK(mask_iou(boxed.mask, cx, cy, rx, ry) > 0.9);
}

TEST_CASE("framing: a given mask replaces alpha and segmentation, --segment none keeps the image as it is") {
  const Image im = ellipse_image(200, 200, 100, 100, 50, 50, kWhite);
  Image mask(200, 200, 1, 0.f);
  for (int y = 80; y < 120; ++y)
    for (int x = 60; x < 140; ++x) mask.at(x, y) = 1.f;
  const FramedInput f = frame_input(im, &mask, FramingSettings{}, "masked");
  CHECK(f.mask_source == "mask");
  CHECK(f.object_box.x == 60);
  CHECK(f.object_box.w == 80);
  CHECK(f.object_box.h == 40);
  FramingSettings none;
  none.segment = Segmentation::kNone;
  none.reframe = Reframing::kNone;
  const FramedInput g = frame_input(ellipse_image(200, 100, 100, 50, 30, 30, kWhite), nullptr, none, "none");
  CHECK(g.mask_source == "none");
  CHECK_FALSE(g.reframed);
  CHECK(g.side == 200);
  CHECK(g.y0 == -50);  // padded above and below to a square
  CHECK(g.image.at(68, 5, 3) == 0.f);
  CHECK(g.image.at(68, 68, 3) == 1.f);
}

TEST_CASE("framing refuses empty, tiny, background-only and objectless images with one line naming the input") {
  const FramingSettings st;
  CHECK_THROWS_AS(frame_input(Image(), nullptr, st, "e.png"), InvalidInput);
  // A fifth channel (RGBA + depth, say): which channel is alpha would be a guess.
  const Image rgba = ellipse_image(100, 100, 50, 50, 30, 30, kWhite, true);
  Image five(100, 100, 5, 0.5f);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x)
      for (int c = 0; c < 4; ++c) five.at(x, y, c) = rgba.at(x, y, c);
  CHECK_NOTHROW(frame_input(rgba, nullptr, st, "rgba.png"));
  CHECK_THROWS_WITH_AS(frame_input(five, nullptr, st, "five.tif"), doctest::Contains("five.tif: 5 channels"),
                       InvalidInput);
  Image one(1, 1, 3, 0.2f);
  CHECK_THROWS_WITH_AS(frame_input(one, nullptr, st, "one.png"), doctest::Contains("one.png"), InvalidInput);
  Image plain(120, 90, 3, 0.7f);
  CHECK_THROWS_WITH_AS(frame_input(plain, nullptr, st, "plain.png"), doctest::Contains("only background"), InvalidInput);
  const Image tiny = ellipse_image(300, 300, 150, 150, 4, 4, kWhite);
  CHECK_THROWS_WITH_AS(frame_input(tiny, nullptr, st, "tiny.png"), doctest::Contains("too small"), InvalidInput);
  Image noise(200, 150, 3);
  Rng rng(5);
  for (float& v : noise.data) v = static_cast<float>(rng.uniform());
  CHECK_THROWS_WITH_AS(frame_input(noise, nullptr, st, "noise.png"), doctest::Contains("noise.png"), InvalidInput);
  Image wrong(10, 10, 1, 1.f);
  const Image im = ellipse_image(100, 100, 50, 50, 30, 30, kWhite);
  CHECK_THROWS_WITH_AS(frame_input(im, &wrong, st, "m.png"), doctest::Contains("mask is 10x10"), InvalidInput);
  CHECK_THROWS_AS(parse_pixel_box("1,2,3"), InvalidInput);
  CHECK_THROWS_AS(parse_pixel_box("1,2,0,4"), InvalidInput);
  CHECK(parse_pixel_box("4,5,6,7").h == 7);
  CHECK_THROWS_AS(parse_segmentation("magic"), InvalidInput);
  CHECK(parse_reframing("always") == Reframing::kAlways);
}

TEST_CASE("framing warns when the object touches the border or is small") {
  const Image im = ellipse_image(200, 200, 20, 100, 40, 20, kWhite);  // cut by the left border
  const FramedInput f = frame_input(im, nullptr, FramingSettings{}, "cut");
  REQUIRE_FALSE(f.warnings.empty());
  CHECK(f.warnings[0].find("border") != std::string::npos);
  const FramedInput s = frame_input(ellipse_image(400, 400, 200, 200, 12, 10, kWhite), nullptr, FramingSettings{}, "small");
  REQUIRE(s.warnings.size() == 1);
  CHECK(s.warnings[0].find("small") != std::string::npos);
}

TEST_CASE("framing: a channel of the input's size follows the crop (identity when kept, the object's place when cropped)") {
  // Kept as it is: the channel comes back unchanged.
  const TrainingFraming tf;
  const double r = 0.5 * tf.extent * 137;
  const Image im = ellipse_image(137, 137, 68.5, 68.5 + tf.centre_dy * 137, r, r, kWhite, true);
  const FramedInput kept = frame_input(im, nullptr, FramingSettings{}, "render");
  REQUIRE_FALSE(kept.reframed);
  Image half(137, 137, 1, 0.f);
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 60; ++x) half.at(x, y) = 1.f;
  const Image same = frame_channel(half, kept);
  double worst = 0;
  for (size_t i = 0; i < half.data.size(); ++i) worst = std::max(worst, double(std::abs(same.data[i] - half.data[i])));
  CHECK(worst < 1e-6);
  // Cropped: the channel that marks the object's pixels lands on the network image's object.
  const float blue[3] = {0.1f, 0.2f, 0.7f};
  const Image photo = ellipse_image(300, 180, 230, 60, 40, 25, blue);
  const FramedInput f = frame_input(photo, nullptr, FramingSettings{}, "photo");
  REQUIRE(f.reframed);
  Image object(300, 180, 1);
  for (int y = 0; y < 180; ++y)
    for (int x = 0; x < 300; ++x) object.at(x, y) = f.mask.at(x, y);
  const Image framed = frame_channel(object, f);
  double diff = 0;
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x) diff = std::max(diff, double(std::abs(framed.at(x, y) - f.image.at(x, y, 3))));
  CHECK(diff < 1e-5);
  CHECK_THROWS_AS(frame_channel(Image(10, 10, 1), f), InvalidInput);
}

TEST_CASE("framing: the context input is the unmasked crop and the object's coverage") {
  // An ellipse near the top-right corner of a blue photo: the crop reaches past the image's edges.
  const float blue[3] = {0.1f, 0.2f, 0.7f};
  const Image photo = ellipse_image(300, 180, 262, 30, 36, 24, blue);
  const FramedInput f = frame_input(photo, nullptr, FramingSettings{}, "photo");
  REQUIRE(f.reframed);
  REQUIRE(f.x0 + f.side > 300);
  const Eigen::VectorXf ctx = context_input(photo, f);
  const int n = kNetImageSize * kNetImageSize;
  REQUIRE(ctx.size() == 4 * n);
  const Eigen::VectorXf composite = network_image(f.image);
  long object = 0, background = 0, outside = 0;
  for (int y = 0; y < kNetImageSize; ++y)
    for (int x = 0; x < kNetImageSize; ++x) {
      const int i = y * kNetImageSize + x;
      CHECK(ctx[3 * n + i] == f.image.at(x, y, 3));  // the mask channel: the framing's coverage
      // The input pixel at this network pixel's centre, and whether its footprint lies inside the image.
      const double s = f.side / kNetImageSize;
      const double u = f.x0 + (x + 0.5) * s, v = f.y0 + (y + 0.5) * s;
      const bool inside = u > s && v > s && u < 300 - s && v < 180 - s;
      if (!inside) {
        if (u > 300 + s || v < -s) {  // wholly outside: white
          ++outside;
          for (int c = 0; c < 3; ++c) CHECK(ctx[c * n + i] == doctest::Approx(1.0));
        }
        continue;
      }
      const float a = f.image.at(x, y, 3);
      if (a > 0.999f) {  // the object: the composite's colour (up to the footprint's edge samples it mixes)
        ++object;
        for (int c = 0; c < 3; ++c) CHECK(std::abs(ctx[c * n + i] - composite[c * n + i]) < 2e-3);
      } else if (a < 1e-3f) {  // the background: the photo's blue where the composite is white
        ++background;
        for (int c = 0; c < 3; ++c) {
          CHECK(ctx[c * n + i] == doctest::Approx(blue[c]).epsilon(1e-4));
          CHECK(composite[c * n + i] == doctest::Approx(1.0));
        }
      }
    }
  CHECK(object > 1000);
  CHECK(background > 1000);
  CHECK(outside > 0);
  CHECK_THROWS_AS(context_input(Image(10, 10, 3), f), InvalidInput);
}

TEST_CASE("the training reframing augmentation frames a render where recon frames it") {
  // Defaults: the augmentation's framing is recon's (the apps set it with frame_like_recon; the structs agree too).
  const TrainingFraming tf;
  const ReframeAugmentSettings aug;
  CHECK(aug.extent == tf.extent);
  CHECK(aug.centre_dx == tf.centre_dx);
  CHECK(aug.centre_dy == tf.centre_dy);
  ReframeAugmentSettings other;
  other.prob = 0.3;
  other.extent = 0.5;
  other.centre_dy = -0.1;
  other.camera = ZoomAugmentSettings::CameraFollow::kDistance;
  frame_like_recon(other, tf);
  CHECK(other.extent == tf.extent);
  CHECK(other.centre_dx == tf.centre_dx);
  CHECK(other.centre_dy == tf.centre_dy);
  CHECK(other.prob == 0.3);
  CHECK(other.camera == ZoomAugmentSettings::CameraFollow::kDistance);
  // A small off-centre object in a 137 px render, framed by recon (always reframed) and by the augmentation: the
  // object's box lands at the same size and place, to a pixel.
  const Image im = ellipse_image(137, 137, 45, 88, 14, 20, kWhite, true);
  FramingSettings fs;
  fs.reframe = Reframing::kAlways;
  const FramedInput f = frame_input(im, nullptr, fs, "render");
  REQUIRE(f.reframed);
  const InkBox by_recon = ink_box(network_image(f.image), kNetImageSize);
  MatrixXfR rows(1, 3 * kNetImageSize * kNetImageSize);
  rows.row(0) = network_image(im).transpose();
  std::vector<Camera> cams = {look_at(0, 20, 2.5)};
  ReframeAugmentSettings r = aug;
  r.prob = 1;
  reframe_images(rows, cams, r, 1, 0);
  const InkBox by_aug = ink_box(rows.row(0).transpose(), kNetImageSize);
  REQUIRE(!by_recon.empty);
  REQUIRE(!by_aug.empty);
  for (const auto& [a, b] : {std::pair{by_recon.x0, by_aug.x0}, {by_recon.x1, by_aug.x1}, {by_recon.y0, by_aug.y0},
                            {by_recon.y1, by_aug.y1}})
    CHECK(std::abs(a - b) <= 1.0);
  // The object's height becomes 0.67 of the image, plus the magnified edge's blur (k = 2.3: a pixel either side).
  CHECK(by_aug.y1 - by_aug.y0 == doctest::Approx(tf.extent * kNetImageSize).epsilon(3.0 / 92));
}

namespace {

/// A 137 px "render" (an off-centre ellipse on transparent) pasted a times larger at (ox, oy) on a transparent
/// W x H canvas, drawn analytically at both sizes; the canvas's camera is `render_camera` scaled and moved alike.
struct Pasted {
  Image render, canvas;
  Camera canvas_camera;
};
Pasted pasted_render(const Camera& render_camera, double a, double ox, double oy, int W, int H) {
  const double cx = 80, cy = 60, rx = 30, ry = 42;  // in the render: right of and above the origin's pixel
  Pasted p;
  p.render = ellipse_image(137, 137, cx, cy, rx, ry, kWhite, true);
  p.canvas = ellipse_image(W, H, ox + a * cx, oy + a * cy, a * rx, a * ry, kWhite, true);
  p.canvas_camera = render_camera;
  Eigen::Matrix3d A;
  A << a, 0, ox, 0, a, oy, 0, 0, 1;
  p.canvas_camera.K = A * render_camera.K;
  p.canvas_camera.width = W;
  p.canvas_camera.height = H;
  return p;
}

}  // namespace

TEST_CASE("framing: the training crop of the true camera undoes a paste, exactly") {
  // A render at a render distance pasted 1.6 times larger, off-centre, on a non-square canvas: recon's crop centres
  // the object's box; the training crop through the canvas's true camera is the pasted render's square again.
  const Camera cam = look_at(40, 27, 2.8);
  const double a = 1.6, ox = 120, oy = 15;
  const Pasted p = pasted_render(cam, a, ox, oy, 400, 260);
  FramingSettings fs;
  fs.reframe = Reframing::kAlways;
  FramedInput f = frame_input(p.canvas, nullptr, fs, "canvas");
  REQUIRE(f.reframed);
  CHECK(std::abs(f.x0 - ox) > 5);  // the box-centred crop is elsewhere
  const Camera net = camera_in_network(p.canvas_camera, f);
  const SquareCrop c = training_crop(net, f, Vec3::Zero(), 1.0, 2.45, 3.0);
  CHECK(c.x0 == doctest::Approx(ox).epsilon(1e-9));
  CHECK(c.y0 == doctest::Approx(oy).epsilon(1e-9));
  CHECK(c.side == doctest::Approx(137 * a).epsilon(1e-9));

  // Re-cut there, the network image is the render again (edges resampled: alpha within a few per cent in all).
  recrop(f, p.canvas, c);
  CHECK(f.reframed);
  CHECK(f.side == doctest::Approx(137 * a));
  CHECK(f.extent == doctest::Approx(std::max(f.object_box.w, f.object_box.h) / (137 * a)));
  double diff = 0, area = 0;
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x) {
      diff += std::abs(f.image.at(x, y, 3) - p.render.at(x, y, 3));
      area += p.render.at(x, y, 3);
    }
  INFO("alpha difference " << diff << " over an object of " << area << " px");
  CHECK(diff < 0.03 * area);
  // and the network camera through the new crop is the render's camera.
  const Camera back = camera_in_network(p.canvas_camera, f);
  CHECK((back.K - cam.K).cwiseAbs().maxCoeff() < 1e-9);
}

TEST_CASE("framing: the training crop moves a camera's distance into the renders' range and reads a shape's frame") {
  const Camera cam = look_at(200, 26, 4.0);  // farther than any render: the render at 3.0 shows it 4/3 larger
  const Pasted p = pasted_render(cam, 1.3, 60, 30, 320, 224);
  FramingSettings fs;
  fs.reframe = Reframing::kAlways;
  const FramedInput f = frame_input(p.canvas, nullptr, fs, "canvas");
  const Camera net = camera_in_network(p.canvas_camera, f);
  const SquareCrop c = training_crop(net, f, Vec3::Zero(), 1.0, 2.45, 3.0);
  CHECK(c.side == doctest::Approx(137 * 1.3 * 3.0 / 4.0).epsilon(1e-9));
  // The origin's pixel on the canvas (60 + 1.3 * 68.5) is the new crop's centre.
  CHECK(c.x0 + 0.5 * c.side == doctest::Approx(60 + 1.3 * 68.5).epsilon(1e-9));
  CHECK(c.y0 + 0.5 * c.side == doctest::Approx(30 + 1.3 * 68.5).epsilon(1e-9));

  // The shape's own frame: the object moved to `centre` and scaled by `radius`, seen by the camera that shows it
  // as `net` showed the original (t' = radius t - R centre), has the same training crop.
  const Vec3 centre(0.2, -0.1, 0.3);
  const double radius = 0.7;
  Camera moved = net;
  moved.t = radius * net.t - net.R * centre;
  const SquareCrop m = training_crop(moved, f, centre, radius, 2.45, 3.0);
  CHECK(m.x0 == doctest::Approx(c.x0).epsilon(1e-9));
  CHECK(m.y0 == doctest::Approx(c.y0).epsilon(1e-9));
  CHECK(m.side == doctest::Approx(c.side).epsilon(1e-9));

  // Bounded by the renders' framing: a camera whose origin projects far off the object keeps the object's box
  // within the centre tolerance, and its size within the renders' extents.
  Camera off = net;
  off.K(0, 2) += 300;
  const TrainingFraming tf;
  const SquareCrop b = training_crop(off, f, Vec3::Zero(), 1.0, 2.45, 3.0);
  const double bx = f.object_box.x + 0.5 * f.object_box.w;
  CHECK((bx - b.x0) / b.side - 0.5 - tf.centre_dx == doctest::Approx(-tf.centre_tolerance).epsilon(1e-9));
  const SquareCrop tiny = training_crop(net, f, Vec3::Zero(), 1e-3, 2.45, 3.0);  // a speck: the box at its largest
  CHECK(std::max(f.object_box.w, f.object_box.h) / tiny.side == doctest::Approx(tf.extent_max).epsilon(1e-9));

  CHECK_THROWS_AS((void)training_crop(net, f, Vec3::Zero(), 0.0, 2.45, 3.0), InvalidInput);
  CHECK_THROWS_AS((void)training_crop(net, f, Vec3::Zero(), 1.0, 3.0, 2.45), InvalidInput);
  Camera behind = net;
  behind.t = -behind.t;
  CHECK_THROWS_AS((void)training_crop(behind, f, Vec3::Zero(), 1.0, 2.45, 3.0), InvalidInput);
}

TEST_CASE("framing: GrabCut seeded by colour finds an object whose colour the background lacks") {
  // Wavy greens and browns over the whole image (every colour of the inside also near the border) and a small
  // grey-blue object whose colour the background lacks. Seeded by colour (the pixels whose colour is rare outside the rectangle), GrabCut finds the object.
  Image im(320, 224, 3);
  Rng rng(5);
  for (int y = 0; y < 224; ++y)
    for (int x = 0; x < 320; ++x) {
      const double a = 0.5 + 0.5 * std::sin(x / 9.0 + 2 * std::sin(y / 23.0)), b = 0.5 + 0.5 * std::cos(y / 7.0 + x / 31.0);
      const double n = rng.uniform(-0.03, 0.03);
      im.at(x, y, 0) = static_cast<float>(0.2 + 0.4 * a + n);
      im.at(x, y, 1) = static_cast<float>(0.3 + 0.5 * b + n);
      im.at(x, y, 2) = static_cast<float>(0.05 + 0.15 * a * b + n);
    }
  const double cx = 200, cy = 90, rx = 16, ry = 12;
  const float grey_blue[3] = {0.55f, 0.6f, 0.8f};
  paint_ellipse(im, cx, cy, rx, ry, grey_blue);
  const PixelBox rect{10, 7, 300, 210};  // the image minus 3%, as frame_input seeds it
  const Image by_colour = grabcut_mask(im, rect, 400, 5, GrabCutSeed::kColour);
  const Image by_rect = grabcut_mask(im, rect, 400, 5, GrabCutSeed::kRect);
  INFO("mask IoU: colour seed " << mask_iou(by_colour, cx, cy, rx, ry) << ", rectangle " << mask_iou(by_rect, cx, cy, rx, ry));
  CHECK(mask_iou(by_colour, cx, cy, rx, ry) > 0.9);
  // The fallback keeps the rectangle's answer when it found an object.
  CHECK(grabcut_mask(im, rect, 400, 5, GrabCutSeed::kRectThenColour).data == by_rect.data);
  // A colour-seeded rectangle with nothing rare in it finds no object.
  Image plain(100, 80, 3, 0.5f);
  const Image none = grabcut_mask(plain, PixelBox{5, 5, 90, 70}, 400, 5, GrabCutSeed::kColour);
  CHECK(*std::max_element(none.data.begin(), none.data.end()) == 0.f);
}

TEST_CASE("framing: GrabCut's sure labels keep a far blob of the object's colour out and a background-coloured part in") {
  // A noisy blue-green checker; the object: an orange disc with a band of the checker's colours across it; far from
  // it, a second orange disc. The seed (the network's mask) is the first disc.
  Image im = noisy_checker(320, 224, 10, 0.04, 17);
  const float orange[3] = {0.85f, 0.25f, 0.1f};
  const double cx = 100, cy = 110, r = 45;
  paint_ellipse(im, cx, cy, r, r, orange);
  paint_ellipse(im, 260, 60, 25, 25, orange);
  for (int y = 104; y < 116; ++y)
    for (int x = 55; x < 146; ++x)
      if ((x - cx) * (x - cx) + (y + 0.5 - cy) * (y + 0.5 - cy) <= r * r)
        for (int c = 0; c < 3; ++c) im.at(x, y, c) = im.at(x, y + 60, c);  // the checker, band included
  Image seed(320, 224, 1);
  for (int y = 0; y < 224; ++y)
    for (int x = 0; x < 320; ++x)
      seed.at(x, y) = (x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy) <= r * r ? 1.f : 0.f;
  const PixelBox rect{10, 7, 300, 210};
  const auto coverage = [](const Image& m, int x0, int y0, int x1, int y1) {
    double s = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) s += m.at(x, y);
    return s / ((x1 - x0) * (y1 - y0));
  };
  // Without sure labels GrabCut follows the colours: the far disc joins the object, the band leaves it.
  const Image free = grabcut_mask(im, rect, 400, 5, GrabCutSeed::kMask, &seed);
  CHECK(coverage(free, 250, 50, 270, 70) > 0.9);
  CHECK(coverage(free, 80, 106, 120, 114) < 0.1);
  // Sure background beyond 20 px of the seed: the far disc stays out; sure object on the seed: the band stays in.
  const Image sure = grabcut_mask(im, rect, 400, 5, GrabCutSeed::kMask, &seed, &seed, 20);
  CHECK(coverage(sure, 250, 50, 270, 70) == 0.0);
  CHECK(coverage(sure, 80, 106, 120, 114) == 1.0);
  CHECK(mask_iou(sure, cx, cy, r, r) > 0.97);
  // Sure labels are the only change: without them (no sure object, distance 0) the mask is the free one.
  CHECK(grabcut_mask(im, rect, 400, 5, GrabCutSeed::kMask, &seed, nullptr, 0).data == free.data);
  // A sure-object mask of the wrong size is refused.
  const Image small(10, 10, 1);
  CHECK_THROWS(grabcut_mask(im, rect, 400, 5, GrabCutSeed::kMask, &seed, &small, 0));
}

TEST_CASE("mask_iou: overlapping rectangles in alpha and grey masks, closed form") {
  // a: columns 2-9, rows 1-4 (32 px) as an RGBA mask's alpha; b: columns 6-13, rows 3-6 (32 px) as a grey mask.
  Image a(16, 8, 4, 0.0f), b(16, 8, 1, 0.0f);
  for (int y = 1; y <= 4; ++y)
    for (int x = 2; x <= 9; ++x) {
      a.at(x, y, 0) = 1.0f;  // colour does not count, the alpha does
      a.at(x, y, 3) = 0.9f;
    }
  for (int y = 3; y <= 6; ++y)
    for (int x = 6; x <= 13; ++x) b.at(x, y) = 0.6f;
  // Intersection: columns 6-9, rows 3-4 = 8 px; union 32 + 32 - 8 = 56.
  CHECK(mask_iou(a, b) == doctest::Approx(8.0 / 56.0));
  CHECK(mask_iou(b, a) == doctest::Approx(8.0 / 56.0));
  CHECK(mask_iou(a, a) == 1.0);
  b.at(7, 3) = 0.5f;  // not over 0.5: background
  CHECK(mask_iou(a, b) == doctest::Approx(7.0 / 56.0));
  CHECK(mask_iou(Image(4, 4, 1, 0.0f), Image(4, 4, 1, 0.0f)) == 1.0);  // no object in either: they agree
  CHECK_THROWS_AS(mask_iou(a, Image(8, 8, 1, 0.0f)), InvalidInput);
  // mask_agreement: a against b (now 31 px, 7 shared): a misses 24 of b's 31 pixels and adds 25 outside them.
  const MaskAgreement m = mask_agreement(a, b);
  CHECK(m.iou == doctest::Approx(7.0 / 56.0));
  CHECK(m.missed == doctest::Approx(24.0 / 31.0));
  CHECK(m.extra == doctest::Approx(25.0 / 31.0));
  const MaskAgreement self = mask_agreement(b, b);
  CHECK(self.iou == 1.0);
  CHECK(self.missed == 0.0);
  CHECK(self.extra == 0.0);
  // Against a reference without object: nothing to miss, and no share to take.
  const MaskAgreement empty = mask_agreement(a, Image(16, 8, 1, 0.0f));
  CHECK(empty.iou == 0.0);
  CHECK(empty.missed == 0.0);
  CHECK(empty.extra == 0.0);
  CHECK_THROWS_AS(mask_agreement(a, Image(8, 8, 1, 0.0f)), InvalidInput);
}
