#include "core/error.h"
#include "train/mask_error.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

using namespace sdfkit;

namespace {
/// 64 x 64 RGBA image on a transparent background: a 24 x 24 body [10, 34) x [10, 34) and a leg 2 px wide
/// (x 20-21) hanging from it down to row 55.
Image body_and_leg() {
  Image img(64, 64, 4, 0.0f);
  auto paint = [&](int x, int y) {
    img.at(x, y, 0) = 0.5f;
    img.at(x, y, 1) = 0.25f;
    img.at(x, y, 2) = 0.75f;
    img.at(x, y, 3) = 1.0f;
  };
  for (int y = 10; y < 34; ++y)
    for (int x = 10; x < 34; ++x) paint(x, y);
  for (int y = 34; y < 56; ++y)
    for (int x = 20; x < 22; ++x) paint(x, y);
  return img;
}
bool object(const Image& img, int x, int y) { return img.at(x, y, 3) > 0.5f; }
}  // namespace

TEST_CASE("mask error: thin parts are what an opening removes, dropped ones become background, the body stays") {
  MaskErrorSettings st;
  st.blob_prob = 0;
  st.edge_prob = 0;
  st.thin_drop = 1;
  for (uint64_t seed = 0; seed < 12; ++seed) {
    CAPTURE(seed);
    Image img = body_and_leg();
    const MaskErrorResult r = apply_mask_error(img, st, seed, 1.0f);
    CHECK(r.dropped_parts == r.thin_parts);
    CHECK(r.blob_pixels == 0);
    long dropped = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool was = object(body_and_leg(), x, y);
        if (was && !object(img, x, y)) {
          ++dropped;
          for (int c = 0; c < 3; ++c) CHECK(img.at(x, y, c) == 1.0f);
        }
        CHECK((!was ? !object(img, x, y) : true));  // nothing added without a blob
      }
    CHECK(dropped == r.dropped_pixels);
    // The leg (2 px wide) is thinner than any disc of radius >= 1 fits: every pixel of it more than 3 px below the
    // body is dropped. The body's pixels more than 3 px from its corners' diagonals stay.
    for (int y = 38; y < 56; ++y)
      for (int x = 20; x < 22; ++x) CHECK_FALSE(object(img, x, y));
    for (int y = 13; y < 31; ++y)
      for (int x = 13; x < 31; ++x) CHECK(object(img, x, y));
  }
  // thin_drop 0 drops nothing: the image is unchanged.
  st.thin_drop = 0;
  Image img = body_and_leg();
  const MaskErrorResult r = apply_mask_error(img, st, 5, 1.0f);
  CHECK(r.thin_parts > 0);
  CHECK(r.dropped_parts == 0);
  CHECK(img.data == body_and_leg().data);
}

TEST_CASE("thin parts: the leg and the body's corners by the opening's closed form, the ones the mask error drops") {
  Image mask(64, 64, 1, 0.0f);
  const Image rgba = body_and_leg();
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) mask.at(x, y) = rgba.at(x, y, 3);
  // Radius 1 (the 5-pixel cross): erosion keeps the body's inside [11, 33)^2, the two bottom-row pixels above the leg
  // (x 20-21, y 33: their neighbour below is the leg) and no leg pixel (2 px wide); dilating that back gives the body
  // without its 4 corner pixels, and the leg's first row. So the thin parts are the leg's rows 35-55 and the corners.
  const Image t1 = thin_parts(mask, 1);
  long n1 = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool leg = y >= 35 && y < 56 && x >= 20 && x < 22;
      const bool corner = (x == 10 || x == 33) && (y == 10 || y == 33);
      CAPTURE(x);
      CAPTURE(y);
      CHECK((t1.at(x, y) == 1.0f) == (leg || corner));
      n1 += t1.at(x, y) == 1.0f;
    }
  CHECK(n1 == 21 * 2 + 4);
  // A larger disc (radius 3) removes more of the corners, never the body's middle, and the leg's rows 35-55 still
  // (the eroded pixels above the leg, x 20-21 at y 31, reach row 34 only).
  const Image t3 = thin_parts(mask, 3);
  for (int y = 35; y < 56; ++y)
    for (int x = 20; x < 22; ++x) CHECK(t3.at(x, y) == 1.0f);
  for (int y = 14; y < 30; ++y)
    for (int x = 14; x < 30; ++x) CHECK(t3.at(x, y) == 0.0f);
  long n3 = 0;
  for (const float v : t3.data) n3 += v == 1.0f;
  CHECK(n3 > n1);
  // The mask error drops exactly these pixels when it drops every thin part with the same radius.
  MaskErrorSettings st;
  st.blob_prob = 0;
  st.edge_prob = 0;
  st.thin_drop = 1;
  st.thin_radius_max = 1;
  Image img = body_and_leg();
  apply_mask_error(img, st, 3, 1.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) CHECK((mask.at(x, y) > 0.5f && img.at(x, y, 3) < 0.5f) == (t1.at(x, y) == 1.0f));
  // An empty mask has no thin part; other channel counts and radii are refused.
  for (const float v : thin_parts(Image(8, 8, 1, 0.0f), 2).data) CHECK(v == 0.0f);
  CHECK_THROWS_AS(thin_parts(rgba, 1), InvalidInput);
  CHECK_THROWS_AS(thin_parts(mask, 0), InvalidInput);
}

TEST_CASE("mask error: an object made only of thin parts is kept whole (keep_min), an empty image unchanged") {
  MaskErrorSettings st;
  st.blob_prob = 0;
  st.edge_prob = 0;
  st.thin_drop = 1;
  Image line(40, 40, 4, 0.0f);
  for (int x = 5; x < 35; ++x) line.at(x, 20, 3) = line.at(x, 21, 3) = 1.0f;
  const Image before = line;
  const MaskErrorResult r = apply_mask_error(line, st, 3, 1.0f);
  CHECK(r.thin_parts >= 1);
  CHECK(r.dropped_pixels == 0);
  CHECK(line.data == before.data);
  Image empty(20, 20, 4, 0.0f);
  st.blob_prob = 1;
  CHECK(apply_mask_error(empty, st, 3, 1.0f).blob_pixels == 0);
  CHECK(empty.data == Image(20, 20, 4, 0.0f).data);
}

TEST_CASE("mask error: a blob is added outside the object, touching it, in non-background colours") {
  MaskErrorSettings st;
  st.thin_drop = 0;
  st.edge_prob = 0;
  st.blob_prob = 1;
  st.blob_size_min = 0.1;
  st.blob_size_max = 0.3;
  int blobs = 0;
  for (uint64_t seed = 0; seed < 8; ++seed) {
    CAPTURE(seed);
    const Image clean = body_and_leg();
    Image img = clean;
    const MaskErrorResult r = apply_mask_error(img, st, seed, 1.0f);
    long added = 0;
    bool touches = false;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        if (object(clean, x, y)) {  // the object's pixels are never changed
          for (int c = 0; c < 4; ++c) CHECK(img.at(x, y, c) == clean.at(x, y, c));
          continue;
        }
        if (!object(img, x, y)) continue;
        ++added;
        for (int c = 0; c < 3; ++c) {
          CHECK(img.at(x, y, c) >= 0.02f);
          CHECK(img.at(x, y, c) <= 0.9f);
        }
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
            touches = touches || object(clean, std::clamp(x + dx, 0, 63), std::clamp(y + dy, 0, 63));
      }
    CHECK(added == r.blob_pixels);
    // Semi-axes at most 0.3 of the box's longer side (46 px): the blob fits in the ellipse's area.
    CHECK(static_cast<double>(added) <= M_PI * (0.3 * 46 + 1) * (0.3 * 46 + 1));
    if (added > 0) {
      CHECK(touches);
      ++blobs;
    }
  }
  CHECK(blobs >= 6);  // a blob centred on the outline always has outside pixels unless it is tiny
}

TEST_CASE("mask error: the outline moves by at most 2 px, a textured halo outward or an eroded rim inward") {
  MaskErrorSettings st;
  st.thin_drop = 0;
  st.blob_prob = 0;
  st.edge_prob = 1;
  int halos = 0, erosions = 0;
  for (uint64_t seed = 0; seed < 16; ++seed) {
    CAPTURE(seed);
    const Image clean = body_and_leg();
    Image img = clean;
    const MaskErrorResult r = apply_mask_error(img, st, seed, 1.0f);
    CHECK((r.halo_pixels > 0) != (r.eroded_pixels > 0));  // one of the two, never both
    halos += r.halo_pixels > 0;
    erosions += r.eroded_pixels > 0;
    // Distance (chessboard, an upper bound of the disc's reach) from a pixel to the nearest pixel of `in` state.
    auto near = [&](int x, int y, bool want_object) {
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const int u = x + dx, v = y + dy;
          const bool in = u >= 0 && v >= 0 && u < 64 && v < 64 && object(clean, u, v);
          if (in == want_object) return true;
        }
      return false;
    };
    long added = 0, removed = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool was = object(clean, x, y), is = object(img, x, y);
        if (!was && is) {
          ++added;
          CHECK(near(x, y, true));  // a halo pixel is within 2 px of the object
          for (int c = 0; c < 3; ++c) CHECK(img.at(x, y, c) <= 0.9f);
        }
        if (was && !is) {
          ++removed;
          CHECK(near(x, y, false));  // an eroded pixel is within 2 px of the background
          CHECK(img.at(x, y, 0) == 1.0f);
        }
        if (was && is) CHECK(img.at(x, y, 0) == clean.at(x, y, 0));  // the object's kept pixels are untouched
      }
    CHECK(added == r.halo_pixels);
    CHECK(removed == r.eroded_pixels);
  }
  CHECK(halos > 0);
  CHECK(erosions > 0);
}

TEST_CASE("mask error: the end cut drops the rows or columns beyond a line across one end, as deep as drawn") {
  // The body alone (no leg, no thin parts dropped, no outline or blob): a 24 x 24 square whose pixel centres span
  // 10.5-33.5 along both axes. Without tilt the cut at depth d drops the k = floor(23 d) + 1 outermost rows or
  // columns of one end (d in [0.05, 0.3]: k in [2, 7]), and what is left is a rectangle.
  Image square(64, 64, 4, 0.0f);
  for (int y = 10; y < 34; ++y)
    for (int x = 10; x < 34; ++x) {
      for (int c = 0; c < 3; ++c) square.at(x, y, c) = 0.4f;
      square.at(x, y, 3) = 1.0f;
    }
  MaskErrorSettings st;
  st.blob_prob = 0;
  st.edge_prob = 0;
  st.thin_drop = 0;
  st.cut_prob = 1;
  st.cut_tilt_deg = 0;
  int ends[4] = {0, 0, 0, 0};  // left, top, right, bottom
  for (uint64_t seed = 0; seed < 40; ++seed) {
    CAPTURE(seed);
    Image img = square;
    const MaskErrorResult r = apply_mask_error(img, st, seed, 1.0f);
    int x0 = 64, y0 = 64, x1 = -1, y1 = -1;
    long left = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        if (!object(img, x, y)) {
          if (object(square, x, y))
            for (int c = 0; c < 3; ++c) CHECK(img.at(x, y, c) == 1.0f);
          continue;
        }
        ++left;
        x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
      }
    CHECK(left == static_cast<long>(x1 - x0 + 1) * (y1 - y0 + 1));  // a rectangle
    const int cut[4] = {x0 - 10, y0 - 10, 33 - x1, 33 - y1};
    int sides = 0;
    for (int e = 0; e < 4; ++e)
      if (cut[e] != 0) {
        ++sides;
        ++ends[e];
        CHECK(cut[e] >= 2);
        CHECK(cut[e] <= 7);
        CHECK(r.cut_pixels == 24L * cut[e]);
      }
    CHECK(sides == 1);
    CHECK(r.dropped_pixels == 0);
  }
  for (int e = 0; e < 4; ++e) CHECK(ends[e] > 0);

  // Tilted by up to 15 degrees at depth 0.25, the line cuts a trapezoid off a corner's side: 97-144 px of the
  // square (3-6 of its rows or columns' worth; the bounds below leave room for the pixel grid). keep_min refuses a
  // cut that would leave too little.
  st.cut_tilt_deg = 15;
  st.cut_depth_min = st.cut_depth_max = 0.25;
  for (uint64_t seed = 0; seed < 20; ++seed) {
    Image img = square;
    const MaskErrorResult r = apply_mask_error(img, st, seed, 1.0f);
    CHECK(r.cut_pixels >= 24 * 3);
    CHECK(r.cut_pixels <= 24 * 10);
  }
  st.keep_min = 0.9;
  Image img = square;
  CHECK(apply_mask_error(img, st, 3, 1.0f).cut_pixels == 0);
  CHECK(img.data == square.data);
}

TEST_CASE("mask error: seeded, and rejects bad settings and images without alpha") {
  MaskErrorSettings st;
  st.blob_prob = 0.5;
  Image a = body_and_leg(), b = body_and_leg(), c = body_and_leg();
  apply_mask_error(a, st, 7, 1.0f);
  apply_mask_error(b, st, 7, 1.0f);
  CHECK(a.data == b.data);
  bool differs = false;
  for (uint64_t seed = 8; seed < 16 && !differs; ++seed) {
    c = body_and_leg();
    apply_mask_error(c, st, seed, 1.0f);
    differs = c.data != a.data;
  }
  CHECK(differs);
  // The outline's draws come after the others: without the outline step its settings change nothing.
  MaskErrorSettings no_edge = st;
  no_edge.edge_prob = 0;
  Image d = body_and_leg(), e = body_and_leg();
  apply_mask_error(d, no_edge, 7, 1.0f);
  no_edge.edge_halo = 0.1;
  apply_mask_error(e, no_edge, 7, 1.0f);
  CHECK(d.data == e.data);
  // The end cut's draws come last too: with cut_prob 0 its other settings change nothing, and a cut changes the
  // result.
  MaskErrorSettings no_cut = st;
  no_cut.cut_depth_min = 0.2;
  no_cut.cut_tilt_deg = 30;
  Image f = body_and_leg();
  apply_mask_error(f, no_cut, 7, 1.0f);
  CHECK(f.data == a.data);
  no_cut.cut_prob = 1;
  f = body_and_leg();
  apply_mask_error(f, no_cut, 7, 1.0f);
  CHECK(f.data != a.data);
  Image rgb(8, 8, 3, 0.0f);
  CHECK_THROWS_AS(apply_mask_error(rgb, st, 1, 1.0f), InvalidInput);
  MaskErrorSettings bad = st;
  bad.thin_drop = 1.5;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
  bad = st;
  bad.blob_size_min = 0.5;
  bad.blob_size_max = 0.2;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
  bad = st;
  bad.edge_halo = -0.1;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
  bad = st;
  bad.thin_radius_max = 0;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
  bad = st;
  bad.cut_depth_max = 1.0;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
  bad = st;
  bad.cut_prob = 2;
  CHECK_THROWS_AS(apply_mask_error(a, bad, 1, 1.0f), InvalidInput);
}
