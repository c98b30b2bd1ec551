#include "models/net_input.h"

#include "camera/mask_morphology.h"
#include "core/error.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {

Eigen::VectorXf network_image(const Image& image, int size) {
  const int H = image.height, W = image.width, C = image.channels;
  require(H > 0 && W > 0 && C > 0, "network_image: empty image");
  require(size > 0, "network_image: size must be positive");
  // 1. Composite to RGB on the background (camera/image.h), clamp to [0, 1], replace non-finite values.
  Image rgb_image = to_rgb(image, kNetBackground);
  std::vector<float>& rgb = rgb_image.data;
  for (float& v : rgb) v = std::isfinite(v) ? std::clamp(v, 0.f, 1.f) : kNetBackground;
  // 2. Resample to size x size. Each output pixel averages the input over its footprint (box filter of the
  // footprint size when shrinking, bilinear interpolation when enlarging): pixel centres map as
  // x_in = (x_out + 0.5) * W / size - 0.5.
  Eigen::VectorXf out(3 * size * size);
  if (W == size && H == size) {  // the footprints are the pixels: a copy to planar order (what the filter gives)
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        for (int c = 0; c < 3; ++c)
          out[(static_cast<Eigen::Index>(c) * size + y) * size + x] = rgb[(static_cast<size_t>(y) * W + x) * 3 + c];
    return out;
  }
  const double sx = static_cast<double>(W) / size, sy = static_cast<double>(H) / size;
  auto sample = [&](double fx, double fy, int c) {  // bilinear, clamped
    fx = std::clamp(fx, 0.0, W - 1.0);
    fy = std::clamp(fy, 0.0, H - 1.0);
    const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
    const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
    const double ax = fx - x0, ay = fy - y0;
    auto at = [&](int x, int y) { return static_cast<double>(rgb[(static_cast<size_t>(y) * W + x) * 3 + c]); };
    return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) + ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
  };
  const int nx = std::max(1, static_cast<int>(std::ceil(sx))), ny = std::max(1, static_cast<int>(std::ceil(sy)));
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int c = 0; c < 3; ++c) {
        double acc = 0;
        // nx x ny sub-samples spread evenly over the footprint (1 x 1 = plain bilinear when enlarging).
        for (int j = 0; j < ny; ++j)
          for (int i = 0; i < nx; ++i) {
            const double fx = x * sx + (i + 0.5) * sx / nx - 0.5;
            const double fy = y * sy + (j + 0.5) * sy / ny - 0.5;
            acc += sample(fx, fy, c);
          }
        out[(static_cast<Eigen::Index>(c) * size + y) * size + x] = static_cast<float>(acc / (nx * ny));
      }
  return out;
}

int square_side(Eigen::Index values, const char* what) {
  const Eigen::Index plane = values / 3;
  const auto side = static_cast<Eigen::Index>(std::lround(std::sqrt(static_cast<double>(plane))));
  require(values % 3 == 0 && side * side == plane && side > 0,
          std::string(what) + ": rows must hold 3 square channels, got " + std::to_string(values) + " values");
  return static_cast<int>(side);
}

InkBox ink_box(const Eigen::Ref<const Eigen::VectorXf>& image, int size) {
  require(size > 0 && image.size() == 3L * size * size, "ink box: image is not 3 x " + std::to_string(size) + "^2");
  const Eigen::Index plane = static_cast<Eigen::Index>(size) * size;
  int x0 = size, y0 = size, x1 = -1, y1 = -1;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const Eigen::Index i = static_cast<Eigen::Index>(y) * size + x;
      if (!is_ink(image[i], image[plane + i], image[2 * plane + i])) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  InkBox box;
  if (x1 < 0) return box;
  box = {double(x0), double(y0), double(x1 + 1), double(y1 + 1), false};
  return box;
}

double max_zoom_inside(const Eigen::Ref<const Eigen::VectorXf>& image, int size) {
  require(size > 2 && image.size() == 3L * size * size, "zoom: image is not 3 x " + std::to_string(size) + "^2");
  const InkBox box = ink_box(image, size);
  if (box.empty) return std::numeric_limits<double>::infinity();
  // Farthest pixel edge of the object from the centre, in pixels (max norm).
  const double c = 0.5 * size;
  const double r = std::max({c - box.x0, box.x1 - c, c - box.y0, box.y1 - c});
  return (c - 1.0) / r;
}

Eigen::VectorXf resample_similarity(const Eigen::Ref<const Eigen::VectorXf>& image, int size, double k, double mx,
                                    double my, double dx, double dy) {
  require(size > 2 && image.size() == 3L * size * size, "resample: image is not 3 x " + std::to_string(size) + "^2");
  require(std::isfinite(k) && k > 0, "resample: the magnification must be positive");
  require(std::isfinite(mx) && std::isfinite(my) && std::isfinite(dx) && std::isfinite(dy),
          "resample: the centres must be finite");
  const Eigen::Index plane = static_cast<Eigen::Index>(size) * size;
  Eigen::VectorXf out(image.size());
  // Source value at integer pixel (x, y), white outside the image.
  const auto at = [&](const float* ch, int x, int y) -> float {
    return (x < 0 || y < 0 || x >= size || y >= size) ? kNetBackground : ch[static_cast<Eigen::Index>(y) * size + x];
  };
  // Magnifying: one bilinear sample per pixel. Shrinking: 2 x 2 samples, as an area average would see.
  static constexpr double kOne[1] = {0.0}, kTwo[2] = {-0.25, 0.25};
  const int n = k >= 1 ? 1 : 2;
  const double* sub = k >= 1 ? kOne : kTwo;
  const double weight = 1.0 / (n * n);
  // Continuous source coordinates with pixel centres at integers: the column of output column x's sub-sample s
  // depends on x alone, the row on y alone, so both are found once for all rows, columns and channels.
  struct Tap {
    int i0;      // first source pixel (clamped to [-2, size + 1], where the image is white)
    double f;    // weight of the second
  };
  const auto taps = [&](double m, double d) {
    std::vector<Tap> t(static_cast<size_t>(size) * n);
    for (int x = 0; x < size; ++x)
      for (int s = 0; s < n; ++s) {
        const double u = m + (x + 0.5 + sub[s] - d) / k - 0.5;
        const double fu = std::floor(u);
        t[static_cast<size_t>(x) * n + s] = {static_cast<int>(std::max(-2.0, std::min(fu, double(size) + 1))), u - fu};
      }
    return t;
  };
  const std::vector<Tap> cols = taps(mx, dx), rows = taps(my, dy);
  for (int ch = 0; ch < 3; ++ch) {
    const float* src = image.data() + ch * plane;
    float* dst = out.data() + ch * plane;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        double acc = 0;
        for (int sy = 0; sy < n; ++sy)
          for (int sx = 0; sx < n; ++sx) {
            const Tap& c = cols[static_cast<size_t>(x) * n + sx];
            const Tap& r = rows[static_cast<size_t>(y) * n + sy];
            const int x0 = c.i0, y0 = r.i0;
            const double a = c.f, b = r.f;
            acc += (1 - b) * ((1 - a) * at(src, x0, y0) + a * at(src, x0 + 1, y0)) +
                   b * ((1 - a) * at(src, x0, y0 + 1) + a * at(src, x0 + 1, y0 + 1));
          }
        dst[static_cast<Eigen::Index>(y) * size + x] = static_cast<float>(weight * acc);
      }
  }
  return out;
}

Eigen::VectorXf zoom_image(const Eigen::Ref<const Eigen::VectorXf>& image, int size, double k) {
  require(size > 2 && image.size() == 3L * size * size, "zoom: image is not 3 x " + std::to_string(size) + "^2");
  require(std::isfinite(k) && k > 0, "zoom: the magnification must be positive");
  const double c = 0.5 * size;
  return resample_similarity(image, size, k, c, c, c, c);
}

Eigen::VectorXf ink_mask(const Eigen::Ref<const Eigen::VectorXf>& image) {
  const Eigen::Index n = image.size() / 3;
  require(image.size() == 3 * n, "ink_mask: the image must hold 3 channels");
  Eigen::VectorXf m(n);
  for (Eigen::Index i = 0; i < n; ++i) m[i] = is_ink(image[i], image[n + i], image[2 * n + i]) ? 1.f : 0.f;
  return m;
}

Image ink_rgba(const Eigen::Ref<const Eigen::VectorXf>& image, int size) {
  const int64_t n = static_cast<int64_t>(size) * size;
  Image rgba(size, size, 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const int64_t i = static_cast<int64_t>(y) * size + x;
      const float r = image[i], g = image[n + i], b = image[2 * n + i];
      rgba.at(x, y, 0) = r;
      rgba.at(x, y, 1) = g;
      rgba.at(x, y, 2) = b;
      rgba.at(x, y, 3) = is_ink(r, g, b) ? 1.0f : 0.0f;
    }
  return rgba;
}

Eigen::VectorXf network_input(const Eigen::Ref<const Eigen::VectorXf>& rgb, const Eigen::VectorXf* mask, int channels) {
  require(channels == 3 || channels == 4, "network input: 3 (RGB) or 4 (RGB + mask) channels");
  const Eigen::Index n = rgb.size() / 3;
  require(rgb.size() == 3 * n && (!mask || mask->size() == n), "network input: mask and image sizes differ");
  if (channels == 3) return rgb;
  Eigen::VectorXf out(4 * n);
  out.head(3 * n) = rgb;
  if (mask)
    out.tail(n) = *mask;
  else
    out.tail(n).setZero();
  return out;
}

void keep_band(Eigen::Ref<Eigen::VectorXf> image, int channels, const Eigen::Ref<const Eigen::VectorXf>& mask, int band,
               float background) {
  const Eigen::Index n = mask.size();
  const auto S = static_cast<int>(std::lround(std::sqrt(static_cast<double>(n))));
  require(band >= 0, "keep_band: the band must be non-negative");
  require(static_cast<Eigen::Index>(S) * S == n && channels > 0 && image.size() == channels * n,
          "keep_band: the image and the mask must be square images of one size");
  if (band == 0) return;
  Image object(S, S, 1);
  for (Eigen::Index i = 0; i < n; ++i) object.data[static_cast<size_t>(i)] = mask[i];
  const Image keep = dilate_mask(object, band);
  for (Eigen::Index i = 0; i < n; ++i)
    if (keep.data[static_cast<size_t>(i)] == 0.f)
      for (int c = 0; c < channels; ++c) image[c * n + i] = background;
}

}  // namespace sdfkit
