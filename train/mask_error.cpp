#include "train/mask_error.h"

#include "core/error.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace sdfkit {

void MaskErrorSettings::validate() const {
  require(thin_radius_max >= 1 && thin_radius_max <= 16, "mask error: thin_radius_max must be in [1, 16]");
  require(thin_drop >= 0 && thin_drop <= 1, "mask error: thin_drop must be in [0, 1]");
  require(blob_prob >= 0 && blob_prob <= 1, "mask error: blob_prob must be in [0, 1]");
  require(blob_size_min > 0 && blob_size_min <= blob_size_max && blob_size_max <= 1,
          "mask error: need 0 < blob_size_min <= blob_size_max <= 1");
  require(keep_min >= 0 && keep_min <= 1, "mask error: keep_min must be in [0, 1]");
  require(edge_prob >= 0 && edge_prob <= 1 && edge_halo >= 0 && edge_halo <= 1,
          "mask error: edge_prob and edge_halo must be in [0, 1]");
  require(cut_prob >= 0 && cut_prob <= 1, "mask error: cut_prob must be in [0, 1]");
  require(cut_depth_min > 0 && cut_depth_min <= cut_depth_max && cut_depth_max < 1,
          "mask error: need 0 < cut_depth_min <= cut_depth_max < 1");
  require(cut_tilt_deg >= 0 && cut_tilt_deg <= 45, "mask error: cut_tilt_deg must be in [0, 45]");
}

namespace {

using Mask = BinaryMask;

// A smooth random colour field with noise: base + gradient over `reach` pixels about (cx, cy) + Gaussian noise,
// every channel in [0.02, 0.9] (never the white background).
struct Texture {
  double base[3], grad[3][2], noise, cx = 0, cy = 0, reach = 1;
  void draw(Rng& rng) {
    for (int c = 0; c < 3; ++c) {
      base[c] = rng.uniform(0.1, 0.85);
      grad[c][0] = rng.uniform(-0.3, 0.3);
      grad[c][1] = rng.uniform(-0.3, 0.3);
    }
    noise = rng.uniform(0.0, 0.08);
  }
  void paint(Image& rgba, int x, int y, Rng& noise_rng) const {
    const double px = x + 0.5 - cx, py = y + 0.5 - cy;
    for (int c = 0; c < 3; ++c) {
      const double value = base[c] + grad[c][0] * px / reach + grad[c][1] * py / reach + noise * noise_rng.normal();
      rgba.at(x, y, c) = static_cast<float>(std::clamp(value, 0.02, 0.9));
    }
    rgba.at(x, y, 3) = 1.0f;
  }
};

}  // namespace

MaskErrorResult apply_mask_error(Image& rgba, const MaskErrorSettings& s, uint64_t seed, float background) {
  s.validate();
  require(rgba.channels == 4, "mask error: the image needs 4 channels (RGBA), it has " + std::to_string(rgba.channels));
  const int W = rgba.width, H = rgba.height;
  const size_t n = static_cast<size_t>(W) * H;
  MaskErrorResult res;
  Mask obj(n);
  for (size_t i = 0; i < n; ++i) obj[i] = rgba.data[i * 4 + 3] > 0.5f;
  // Every draw is made in a fixed order whatever the image, so the choices depend on the seed only.
  Rng rng(seed);
  const int radius = 1 + static_cast<int>(rng.below(static_cast<uint64_t>(s.thin_radius_max)));
  const uint64_t part_seed = rng.next();
  const bool blob = rng.uniform() < s.blob_prob;
  const double blob_a = rng.uniform(s.blob_size_min, s.blob_size_max), blob_b = rng.uniform(s.blob_size_min, s.blob_size_max);
  const double blob_angle = rng.uniform(0, M_PI);
  const uint64_t blob_at = rng.next();
  Texture blob_texture, halo_texture;
  blob_texture.draw(rng);
  const uint64_t noise_seed = rng.next();
  // The outline's draws come last: with edge_prob 0 the other choices are those of a run without the outline step.
  const bool edge = rng.uniform() < s.edge_prob;
  const bool halo = rng.uniform() < s.edge_halo;
  const int edge_radius = 1 + static_cast<int>(rng.below(2));
  halo_texture.draw(rng);
  // The end cut's draws come after all the others (cut_prob 0 leaves every other choice as before it existed).
  const bool cut = rng.uniform() < s.cut_prob;
  const int cut_end = static_cast<int>(rng.below(4));
  const double cut_tilt = rng.uniform(-1.0, 1.0) * s.cut_tilt_deg * M_PI / 180.0;
  const double cut_depth = rng.uniform(s.cut_depth_min, s.cut_depth_max);
  auto drop_pixel = [&](size_t p) {
    obj[p] = 0;
    const int px = static_cast<int>(p % static_cast<size_t>(W)), py = static_cast<int>(p / static_cast<size_t>(W));
    for (int c = 0; c < 3; ++c) rgba.at(px, py, c) = background;
    rgba.at(px, py, 3) = 0.0f;
  };

  // 0. An end cut off: the object pixels whose centres lie beyond the line at cut_depth of the object's extent along
  //    the end's (tilted) direction, unless that would leave less than keep_min of the object.
  if (cut) {
    const double angle = cut_end * M_PI / 2 + cut_tilt;  // 0 = right, then bottom, left, top (image y down)
    const double dx = std::cos(angle), dy = std::sin(angle);
    auto along = [&](size_t i) {  // pixel i's centre projected on the end's direction
      return (static_cast<double>(i % static_cast<size_t>(W)) + 0.5) * dx +
             (static_cast<double>(i / static_cast<size_t>(W)) + 0.5) * dy;
    };
    double lo = 1e300, hi = -1e300;
    long total = 0;
    for (size_t i = 0; i < n; ++i)
      if (obj[i]) {
        const double t = along(i);
        lo = std::min(lo, t);
        hi = std::max(hi, t);
        ++total;
      }
    if (total > 0) {
      const double line = hi - cut_depth * (hi - lo);
      std::vector<size_t> beyond;
      for (size_t i = 0; i < n; ++i)
        if (obj[i] && along(i) > line) beyond.push_back(i);
      if (static_cast<double>(total - static_cast<long>(beyond.size())) >= s.keep_min * static_cast<double>(total)) {
        for (const size_t p : beyond) drop_pixel(p);
        res.cut_pixels = static_cast<long>(beyond.size());
      }
    }
  }

  // The object's pixel count and box, after the cut.
  long count = 0;
  int x0 = W, y0 = H, x1 = -1, y1 = -1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!obj[static_cast<size_t>(y) * W + x]) continue;
      ++count;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  if (count == 0) return res;
  Rng noise_rng(noise_seed);

  // 1. Thin parts: the residue of the opening, split into 8-connected parts, each dropped by its own coin.
  const Mask opened = open_mask(obj, W, H, radius);
  std::vector<int> label(n, -1);
  std::vector<size_t> stack;
  std::vector<std::vector<size_t>> parts;
  for (size_t i = 0; i < n; ++i) {
    if (!obj[i] || opened[i] || label[i] >= 0) continue;
    const int id = static_cast<int>(parts.size());
    parts.emplace_back();
    stack.assign(1, i);
    label[i] = id;
    while (!stack.empty()) {
      const size_t p = stack.back();
      stack.pop_back();
      parts[static_cast<size_t>(id)].push_back(p);
      const int px = static_cast<int>(p % static_cast<size_t>(W)), py = static_cast<int>(p / static_cast<size_t>(W));
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = px + dx, v = py + dy;
          if (u < 0 || v < 0 || u >= W || v >= H) continue;
          const size_t q = static_cast<size_t>(v) * W + u;
          if (obj[q] && !opened[q] && label[q] < 0) {
            label[q] = id;
            stack.push_back(q);
          }
        }
    }
  }
  res.thin_parts = static_cast<int>(parts.size());
  Rng part_rng(part_seed);
  std::vector<size_t> drop;
  for (const auto& part : parts)
    if (part_rng.uniform() < s.thin_drop) {
      ++res.dropped_parts;
      drop.insert(drop.end(), part.begin(), part.end());
    }
  if (static_cast<double>(count - static_cast<long>(drop.size())) < s.keep_min * static_cast<double>(count)) {
    drop.clear();
    res.dropped_parts = 0;
  }
  for (const size_t p : drop) drop_pixel(p);
  res.dropped_pixels = static_cast<long>(drop.size());

  // 2. The outline moved by a disc: outward, a textured halo where the dilation reaches outside the object; inward,
  //    the pixels the erosion removes (unless that would leave less than keep_min of the object).
  if (edge) {
    const auto e = disc_offsets(edge_radius);
    if (halo) {
      const Mask grown = morph_mask(obj, W, H, e, false);
      halo_texture.cx = 0.5 * (x0 + x1 + 1);
      halo_texture.cy = 0.5 * (y0 + y1 + 1);
      halo_texture.reach = std::max(1, std::max(x1 - x0 + 1, y1 - y0 + 1));
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t i = static_cast<size_t>(y) * W + x;
          if (!grown[i] || obj[i]) continue;
          halo_texture.paint(rgba, x, y, noise_rng);
          obj[i] = 1;  // part of the mask's object from now on
          ++res.halo_pixels;
        }
    } else {
      const Mask shrunk = morph_mask(obj, W, H, e, true);
      long left = 0, gone = 0;
      for (size_t i = 0; i < n; ++i) {
        left += shrunk[i] ? 1 : 0;
        gone += obj[i] && !shrunk[i] ? 1 : 0;
      }
      if (static_cast<double>(left) >= s.keep_min * static_cast<double>(count)) {
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const size_t i = static_cast<size_t>(y) * W + x;
            if (!obj[i] || shrunk[i]) continue;
            obj[i] = 0;
            for (int c = 0; c < 3; ++c) rgba.at(x, y, c) = background;
            rgba.at(x, y, 3) = 0.0f;
          }
        res.eroded_pixels = gone;
      }
    }
  }

  // 3. A blob beside the object: centred on an outline pixel of what is left (an object pixel with a background
  //    4-neighbour or on the image border), painted where there is no object.
  if (!blob) return res;
  std::vector<size_t> outline;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      if (!obj[i]) continue;
      const bool on_outline = x == 0 || y == 0 || x == W - 1 || y == H - 1 || !obj[i - 1] || !obj[i + 1] ||
                              !obj[i - static_cast<size_t>(W)] || !obj[i + static_cast<size_t>(W)];
      if (on_outline) outline.push_back(i);
    }
  if (outline.empty()) return res;
  const size_t at = outline[static_cast<size_t>(blob_at % outline.size())];
  const double cx = static_cast<double>(at % static_cast<size_t>(W)) + 0.5;
  const double cy = static_cast<double>(at / static_cast<size_t>(W)) + 0.5;
  const double side = std::max(x1 - x0 + 1, y1 - y0 + 1);
  const double a = std::max(1.0, blob_a * side), b = std::max(1.0, blob_b * side);
  const double ca = std::cos(blob_angle), sa = std::sin(blob_angle);
  const double reach = std::max(a, b);
  blob_texture.cx = cx;
  blob_texture.cy = cy;
  blob_texture.reach = reach;
  for (int y = std::max(0, static_cast<int>(cy - reach)); y <= std::min(H - 1, static_cast<int>(cy + reach)); ++y)
    for (int x = std::max(0, static_cast<int>(cx - reach)); x <= std::min(W - 1, static_cast<int>(cx + reach)); ++x) {
      const double px = x + 0.5 - cx, py = y + 0.5 - cy;
      const double u = (ca * px + sa * py) / a, v = (-sa * px + ca * py) / b;
      if (u * u + v * v > 1 || obj[static_cast<size_t>(y) * W + x]) continue;
      blob_texture.paint(rgba, x, y, noise_rng);
      ++res.blob_pixels;
    }
  return res;
}

}  // namespace sdfkit
