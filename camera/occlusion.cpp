#include "camera/occlusion.h"

#include "core/error.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {

OcclusionMode parse_occlusion_mode(const std::string& name) {
  if (name == "none") return OcclusionMode::kNone;
  if (name == "left") return OcclusionMode::kLeft;
  if (name == "right") return OcclusionMode::kRight;
  if (name == "rect") return OcclusionMode::kRect;
  throw InvalidInput("unknown occlusion mode '" + name + "' (use none, left, right or rect)");
}

std::string to_string(OcclusionMode mode) {
  switch (mode) {
    case OcclusionMode::kNone: return "none";
    case OcclusionMode::kLeft: return "left";
    case OcclusionMode::kRight: return "right";
    case OcclusionMode::kRect: return "rect";
  }
  return "none";
}

Image apply_occlusion(Image& image, const OcclusionSettings& st, uint64_t seed) {
  require(!image.empty(), "apply_occlusion: empty image");
  require(st.rectangles >= 0 && st.min_size > 0 && st.min_size <= st.max_size && st.max_size <= 1,
          "apply_occlusion: need rectangles >= 0 and 0 < min_size <= max_size <= 1");
  const int W = image.width, H = image.height;
  Image mask(W, H, 1, 0.0f);
  if (st.mode == OcclusionMode::kNone) return mask;

  // The object's extent: bounding box of alpha > 0 (whole image without alpha or when nothing is visible).
  int bx0 = 0, bx1 = W - 1, by0 = 0, by1 = H - 1;
  if (image.channels == 2 || image.channels == 4) {
    int x0 = W, x1 = -1, y0 = H, y1 = -1;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (image.at(x, y, image.channels - 1) > 0) {
          x0 = std::min(x0, x);
          x1 = std::max(x1, x);
          y0 = std::min(y0, y);
          y1 = std::max(y1, y);
        }
    if (x1 >= 0) {
      bx0 = x0;
      bx1 = x1;
      by0 = y0;
      by1 = y1;
    }
  }

  auto remove = [&](int x, int y) {
    mask.at(x, y) = 1.0f;
    for (int c = 0; c < image.channels; ++c) image.at(x, y, c) = 0.0f;
  };
  if (st.mode == OcclusionMode::kLeft || st.mode == OcclusionMode::kRight) {
    // A column is in the left half when its centre lies left of the split, so the halves partition the image.
    const double split = st.split_at_object ? 0.5 * (bx0 + bx1 + 1) : 0.5 * W;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const bool left = x + 0.5 < split;
        if (left == (st.mode == OcclusionMode::kLeft)) remove(x, y);
      }
    return mask;
  }
  // Random rectangles.
  Rng rng(seed);
  const int ox0 = st.rects_on_object ? bx0 : 0, ox1 = st.rects_on_object ? bx1 : W - 1;
  const int oy0 = st.rects_on_object ? by0 : 0, oy1 = st.rects_on_object ? by1 : H - 1;
  for (int r = 0; r < st.rectangles; ++r) {
    const int rw = std::max(1, static_cast<int>(std::lround(rng.uniform(st.min_size, st.max_size) * W)));
    const int rh = std::max(1, static_cast<int>(std::lround(rng.uniform(st.min_size, st.max_size) * H)));
    const double cx = rng.uniform(ox0, ox1 + 1), cy = rng.uniform(oy0, oy1 + 1);
    const int x0 = std::max(0, static_cast<int>(std::floor(cx - 0.5 * rw)));
    const int y0 = std::max(0, static_cast<int>(std::floor(cy - 0.5 * rh)));
    const int x1 = std::min(W, x0 + rw), y1 = std::min(H, y0 + rh);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) remove(x, y);
  }
  return mask;
}

}  // namespace sdfkit
