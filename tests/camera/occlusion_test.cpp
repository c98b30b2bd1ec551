#include "camera/occlusion.h"
#include "core/error.h"

#include <doctest/doctest.h>

using namespace sdfkit;

namespace {
/// 80 x 60 RGBA image with an opaque "object" box [20, 59] x [10, 49] on a transparent background.
Image object_image() {
  Image img(80, 60, 4, 0.0f);
  for (int y = 10; y < 50; ++y)
    for (int x = 20; x < 60; ++x) {
      img.at(x, y, 0) = 0.5f;
      img.at(x, y, 1) = 0.25f;
      img.at(x, y, 2) = 1.0f;
      img.at(x, y, 3) = 1.0f;
    }
  return img;
}
}  // namespace

TEST_CASE("occlusion: left and right halves of the object partition the image") {
  const Image clean = object_image();
  OcclusionSettings st;
  st.mode = OcclusionMode::kLeft;
  Image left = clean;
  const Image ml = apply_occlusion(left, st, 0);
  st.mode = OcclusionMode::kRight;
  Image right = clean;
  const Image mr = apply_occlusion(right, st, 0);
  // Split at the object's centre column: x = 40.
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      CHECK(ml.at(x, y) + mr.at(x, y) == 1.0f);
      CHECK(ml.at(x, y) == (x < 40 ? 1.0f : 0.0f));
      for (int c = 0; c < 4; ++c) {
        CHECK(left.at(x, y, c) == (x < 40 ? 0.0f : clean.at(x, y, c)));
        CHECK(right.at(x, y, c) == (x >= 40 ? 0.0f : clean.at(x, y, c)));
      }
    }
  // The image-centre variant splits at W / 2 = 40 too here; move the object to see the difference.
  Image shifted(80, 60, 4, 0.0f);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) shifted.at(x, y, 3) = 1.0f;
  st.mode = OcclusionMode::kLeft;
  Image a = shifted;
  CHECK(apply_occlusion(a, st, 0).at(5, 0) == 0.0f);  // object centre 5: column 5 is in the right half
  st.split_at_object = false;
  Image b = shifted;
  CHECK(apply_occlusion(b, st, 0).at(5, 0) == 1.0f);  // image centre 40: column 5 is in the left half
}

TEST_CASE("occlusion: random rectangles are seeded, on the object, and zero what the mask says") {
  const Image clean = object_image();
  OcclusionSettings st;
  st.mode = OcclusionMode::kRect;
  st.rectangles = 2;
  Image a = clean, b = clean, c = clean;
  const Image ma = apply_occlusion(a, st, 42);
  const Image mb = apply_occlusion(b, st, 42);
  const Image mc = apply_occlusion(c, st, 43);
  CHECK(ma.data == mb.data);
  CHECK(a.data == b.data);
  CHECK(ma.data != mc.data);
  double area = 0;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      area += ma.at(x, y);
      for (int k = 0; k < 4; ++k) CHECK(a.at(x, y, k) == (ma.at(x, y) > 0 ? 0.0f : clean.at(x, y, k)));
    }
  // One rectangle is at least 0.25 W x 0.25 H (clipped by the border at most to a quarter of it), two at
  // most 2 x 0.5 W x 0.5 H.
  CHECK(area >= 0.25 * 80 * 0.25 * 60 / 4);
  CHECK(area <= 2 * 0.5 * 80 * 0.5 * 60 + 1);
}

TEST_CASE("occlusion: none, parsing, bad settings") {
  Image img = object_image();
  const Image before = img;
  const Image m = apply_occlusion(img, OcclusionSettings{}, 1);
  CHECK(img.data == before.data);
  for (float v : m.data) CHECK(v == 0.0f);
  CHECK(parse_occlusion_mode("left") == OcclusionMode::kLeft);
  CHECK(to_string(OcclusionMode::kRect) == "rect");
  CHECK_THROWS_AS(parse_occlusion_mode("top"), InvalidInput);
  OcclusionSettings bad;
  bad.mode = OcclusionMode::kRect;
  bad.min_size = 0.8;
  bad.max_size = 0.4;
  CHECK_THROWS_AS(apply_occlusion(img, bad, 0), InvalidInput);
}
