#include "camera/mask_morphology.h"

#include "core/error.h"

#include <string>

namespace sdfkit {

std::vector<std::pair<int, int>> disc_offsets(int r) {
  std::vector<std::pair<int, int>> d;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      if (dx * dx + dy * dy <= r * r) d.emplace_back(dx, dy);
  return d;
}

BinaryMask morph_mask(const BinaryMask& m, int W, int H, const std::vector<std::pair<int, int>>& d, bool erode) {
  BinaryMask out(m.size(), 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool all = true, any = false;
      for (const auto& [dx, dy] : d) {
        const int u = x + dx, v = y + dy;
        const bool in = u >= 0 && v >= 0 && u < W && v < H && m[static_cast<size_t>(v) * W + u];
        all = all && in;
        any = any || in;
        if (erode ? !all : any) break;
      }
      out[static_cast<size_t>(y) * W + x] = erode ? all : any;
    }
  return out;
}

BinaryMask open_mask(const BinaryMask& m, int W, int H, int r) {
  const auto d = disc_offsets(r);
  return morph_mask(morph_mask(m, W, H, d, true), W, H, d, false);
}

BinaryMask mask_over_half(const Image& mask) {
  BinaryMask m(mask.data.size());
  for (size_t i = 0; i < m.size(); ++i) m[i] = mask.data[i] > 0.5f;
  return m;
}

Image thin_parts(const Image& mask, int radius) {
  require(mask.channels == 1, "thin parts: the mask needs 1 channel, it has " + std::to_string(mask.channels));
  require(radius >= 1, "thin parts: the radius must be >= 1 px");
  const int W = mask.width, H = mask.height;
  const BinaryMask obj = mask_over_half(mask);
  const BinaryMask opened = open_mask(obj, W, H, radius);
  Image thin(W, H, 1);
  for (size_t i = 0; i < obj.size(); ++i) thin.data[i] = obj[i] && !opened[i] ? 1.f : 0.f;
  return thin;
}

Image dilate_mask(const Image& mask, int radius) {
  require(mask.channels == 1, "dilate mask: the mask needs 1 channel, it has " + std::to_string(mask.channels));
  require(radius >= 0, "dilate mask: the radius must be >= 0 px");
  const BinaryMask grown = morph_mask(mask_over_half(mask), mask.width, mask.height, disc_offsets(radius), false);
  Image out(mask.width, mask.height, 1);
  for (size_t i = 0; i < grown.size(); ++i) out.data[i] = grown[i] ? 1.f : 0.f;
  return out;
}

}  // namespace sdfkit
