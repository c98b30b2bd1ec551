#include "recon/framing.h"

#include "core/error.h"
#include "models/net_input.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sdfkit {

namespace {

constexpr float kBackground = kNetBackground;  // the training renders' background (white)

std::string fmt(double v, int digits = 2) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

/// Object coverage of a mask pixel: its alpha when it has one, else its luminance.
float mask_value(const Image& mask, int x, int y) {
  float m = 0;
  if (mask.channels == 2 || mask.channels == 4)
    m = mask.at(x, y, mask.channels - 1);
  else
    m = mask.channels >= 3 ? (mask.at(x, y, 0) + mask.at(x, y, 1) + mask.at(x, y, 2)) / 3.f : mask.at(x, y, 0);
  return std::isfinite(m) ? std::clamp(m, 0.f, 1.f) : 0.f;
}

bool has_transparency(const Image& image) {
  if (image.channels != 2 && image.channels != 4) return false;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      if (image.at(x, y, image.channels - 1) < 0.999f) return true;
  return false;
}

/// The border's median colour and the share of border pixels within `tolerance` of it (every channel).
struct BorderStats {
  float colour[3] = {kBackground, kBackground, kBackground};
  double plain_share = 0;
};

BorderStats border_stats(const Image& rgb, double tolerance) {
  const int W = rgb.width, H = rgb.height;
  const int band = std::max(1, static_cast<int>(std::lround(0.02 * std::min(W, H))));
  std::vector<int> xs, ys;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (x < band || y < band || x >= W - band || y >= H - band) {
        xs.push_back(x);
        ys.push_back(y);
      }
  BorderStats s;
  std::vector<float> v(xs.size());
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < xs.size(); ++i) v[i] = rgb.at(xs[i], ys[i], c);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    s.colour[c] = v[v.size() / 2];
  }
  long plain = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    float d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(rgb.at(xs[i], ys[i], c) - s.colour[c]));
    plain += d <= tolerance;
  }
  s.plain_share = static_cast<double>(plain) / static_cast<double>(xs.size());
  return s;
}

/// Bhattacharyya coefficient of the colour histograms (8 bins per channel) of the pixels over and under 0.5 in
/// `mask`: 1 when object and background have the same colours (nothing stands out), 0 when they share none.
double colour_overlap(const Image& rgb, const Image& mask) {
  constexpr int kBins = 8;
  std::vector<double> fg(kBins * kBins * kBins, 0.0), bg(fg.size(), 0.0);
  double nf = 0, nb = 0;
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) {
      int bin = 0;
      for (int c = 0; c < 3; ++c) bin = bin * kBins + std::min(kBins - 1, static_cast<int>(rgb.at(x, y, c) * kBins));
      if (mask.at(x, y) > 0.5f) {
        fg[static_cast<size_t>(bin)] += 1;
        nf += 1;
      } else {
        bg[static_cast<size_t>(bin)] += 1;
        nb += 1;
      }
    }
  if (nf == 0 || nb == 0) return 1.0;
  double bc = 0;
  for (size_t i = 0; i < fg.size(); ++i) bc += std::sqrt(fg[i] / nf * bg[i] / nb);
  return bc;
}

/// Zero the coverage of connected specks (8-connected pixels over 0.5) smaller than `fraction` of the largest
/// piece; returns the number of pieces kept.
int drop_specks(Image& mask, double fraction) {
  cv::Mat hard(mask.height, mask.width, CV_8UC1);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) hard.at<uchar>(y, x) = mask.at(x, y) > 0.5f ? 255 : 0;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(hard, labels, stats, centroids, 8, CV_32S);
  int largest = 0;
  for (int i = 1; i < n; ++i) largest = std::max(largest, stats.at<int>(i, cv::CC_STAT_AREA));
  std::vector<char> keep(static_cast<size_t>(n), 0);
  int kept = 0;
  for (int i = 1; i < n; ++i)
    if (stats.at<int>(i, cv::CC_STAT_AREA) >= std::max(1.0, fraction * largest)) {
      keep[static_cast<size_t>(i)] = 1;
      ++kept;
    }
  // A pixel under 0.5 takes the fate of its nearest piece in its 3 x 3 neighbourhood (soft edges stay with their
  // object); isolated soft pixels go.
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      if (mask.at(x, y) <= 0) continue;
      bool ok = false;
      for (int dy = -1; dy <= 1 && !ok; ++dy)
        for (int dx = -1; dx <= 1 && !ok; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= mask.width || yy >= mask.height) continue;
          ok = keep[static_cast<size_t>(labels.at<int>(yy, xx))] != 0;
        }
      if (!ok) mask.at(x, y) = 0;
    }
  return kept;
}

/// Whether `marked` object pixels of a width x height image leave the object standing out: frame_input refuses
/// a mask covering more than kMaxObjectCover of the image.
bool stands_out(long marked, int width, int height) {
  return static_cast<double>(marked) <= kMaxObjectCover * static_cast<double>(width) * height;
}

/// Box of the pixels with coverage over 0.5 (w = 0 when there is none).
PixelBox hard_box(const Image& mask, long* count) {
  int x0 = mask.width, y0 = mask.height, x1 = -1, y1 = -1;
  long n = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y) > 0.5f) {
        x0 = std::min(x0, x);
        y0 = std::min(y0, y);
        x1 = std::max(x1, x);
        y1 = std::max(y1, y);
        ++n;
      }
  if (count) *count = n;
  if (x1 < 0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

/// The crop [x0, x0 + side]^2 of the premultiplied RGBA input resampled to size x size: each output pixel averages
/// ceil(side / size)^2 bilinear samples spread over its footprint; outside the input is transparent.
Image resample_crop(const Image& rgb, const Image& alpha, double x0, double y0, double side, int size) {
  const int W = rgb.width, H = rgb.height;
  const double s = side / size;
  const int n = std::max(1, static_cast<int>(std::ceil(s)));
  auto sample = [&](double u, double v, float out[4]) {
    if (u < 0 || v < 0 || u >= W || v >= H) {
      out[0] = out[1] = out[2] = out[3] = 0.f;
      return;
    }
    const double fx = std::clamp(u - 0.5, 0.0, W - 1.0), fy = std::clamp(v - 0.5, 0.0, H - 1.0);
    const int xa = static_cast<int>(std::floor(fx)), ya = static_cast<int>(std::floor(fy));
    const int xb = std::min(xa + 1, W - 1), yb = std::min(ya + 1, H - 1);
    const float ax = static_cast<float>(fx - xa), ay = static_cast<float>(fy - ya);
    const int xs[4] = {xa, xb, xa, xb}, ys[4] = {ya, ya, yb, yb};
    const float ws[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    out[0] = out[1] = out[2] = out[3] = 0.f;
    for (int k = 0; k < 4; ++k) {
      const float a = alpha.at(xs[k], ys[k]);
      for (int c = 0; c < 3; ++c) out[c] += ws[k] * a * rgb.at(xs[k], ys[k], c);
      out[3] += ws[k] * a;
    }
  };
  Image out(size, size, 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      double acc[4] = {0, 0, 0, 0};
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          float v[4];
          sample(x0 + (x + (i + 0.5) / n) * s, y0 + (y + (j + 0.5) / n) * s, v);
          for (int c = 0; c < 4; ++c) acc[c] += v[c];
        }
      const double a = acc[3] / (n * n);
      for (int c = 0; c < 3; ++c)
        out.at(x, y, c) = a > 1e-6 ? static_cast<float>(std::clamp(acc[c] / (n * n) / a, 0.0, 1.0)) : kBackground;
      out.at(x, y, 3) = static_cast<float>(std::clamp(a, 0.0, 1.0));
    }
  return out;
}

/// GrabCut's rectangle: --box, else the image minus a 3% margin. InvalidInput when too small to segment.
PixelBox grabcut_rect(const FramingSettings& st, int W, int H, const std::string& what) {
  PixelBox rect;
  if (st.box) {
    rect = *st.box;
  } else {
    const int mx = std::max(1, static_cast<int>(std::lround(0.03 * W)));
    const int my = std::max(1, static_cast<int>(std::lround(0.03 * H)));
    rect = {mx, my, W - 2 * mx, H - 2 * my};
  }
  if (rect.w < 2 || rect.h < 2)
    throw InvalidInput(what + ": image too small to segment (" + std::to_string(W) + "x" + std::to_string(H) + ")");
  return rect;
}

bool any_over_half(const Image& mask) {
  return std::any_of(mask.data.begin(), mask.data.end(), [](float v) { return v > 0.5f; });
}

/// The input's colours as the framing reads them (finite, in [0, 1]): composited on the training background, or
/// `straight` = the colour channels under the alpha as they are (an input whose alpha is the mask).
Image framing_rgb(const Image& image, bool straight) {
  Image rgb;
  if (!straight) {
    rgb = to_rgb(image, kBackground);
  } else {
    rgb = Image(image.width, image.height, 3);
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = image.at(x, y, image.channels >= 3 ? c : 0);
  }
  for (float& v : rgb.data) v = std::isfinite(v) ? std::clamp(v, 0.f, 1.f) : kBackground;
  return rgb;
}

/// The network image of `f`'s crop of `rgb`: the object premultiplied by its coverage (the image as it is for mask
/// source "none").
Image crop_network_image(const Image& rgb, const FramedInput& f) {
  const Image all(rgb.width, rgb.height, 1, 1.f);
  return resample_crop(rgb, f.mask_source == "none" ? all : f.mask, f.x0, f.y0, f.side, kNetImageSize);
}

}  // namespace

Image grabcut_mask(const Image& rgb, const PixelBox& rect, int max_side, int iterations, GrabCutSeed seed,
                   const Image* seed_mask, const Image* sure_object, double sure_background_px) {
  require(seed != GrabCutSeed::kMask ||
              (seed_mask != nullptr && seed_mask->width == rgb.width && seed_mask->height == rgb.height &&
               seed_mask->channels == 1),
          "grabcut_mask: the mask seed needs a 1-channel mask of the image's size");
  require(sure_object == nullptr || (sure_object->width == rgb.width && sure_object->height == rgb.height &&
                                     sure_object->channels == 1),
          "grabcut_mask: the sure-object mask must have 1 channel and the image's size");
  require(std::isfinite(sure_background_px) && sure_background_px >= 0,
          "grabcut_mask: the sure-background distance must be finite and non-negative");
  const int W = rgb.width, H = rgb.height;
  const double scale = std::min(1.0, static_cast<double>(max_side) / std::max(W, H));
  cv::Mat full(H, W, CV_8UC3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c)  // OpenCV's channel order is BGR
        full.at<cv::Vec3b>(y, x)[2 - c] =
            static_cast<uchar>(std::lround(255.f * std::clamp(rgb.at(x, y, c), 0.f, 1.f)));
  cv::Mat small;
  const int w = std::max(1, static_cast<int>(std::lround(W * scale))), h = std::max(1, static_cast<int>(std::lround(H * scale)));
  if (scale < 1.0)
    cv::resize(full, small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  else
    small = full;
  cv::Rect r(static_cast<int>(std::floor(rect.x * scale)), static_cast<int>(std::floor(rect.y * scale)),
             std::max(1, static_cast<int>(std::ceil(rect.w * scale))), std::max(1, static_cast<int>(std::ceil(rect.h * scale))));
  r &= cv::Rect(0, 0, small.cols, small.rows);
  require(r.width > 0 && r.height > 0, "grabcut_mask: the rectangle lies outside the image");
  cv::Mat labels(small.size(), CV_8UC1, cv::Scalar(cv::GC_BGD)), bgd, fgd;
  // GrabCut from fresh colour models: from the rectangle, or from the labels set inside it.
  const auto grabcut = [&](int mode) {
    bgd.release();
    fgd.release();
    cv::theRNG().state = 0x5dfc0de5eedULL;
    cv::grabCut(small, labels, r, bgd, fgd, iterations, mode);
  };
  const auto is_object = [](uchar l) { return l == cv::GC_FGD || l == cv::GC_PR_FGD; };
  if (seed == GrabCutSeed::kMask) {
    // Inside the rectangle: the mask's object (over 0.5 at the pixel's centre in the input) probably object, the
    // rest probably background; outside it background. No object in the seed: no object.
    // With sure labels: the seed's pixels that `sure_object` also has are object, and pixels farther than
    // sure_background_px from the seed's object background, whatever their colours.
    bool any = false;
    for (int y = r.y; y < r.y + r.height; ++y)
      for (int x = r.x; x < r.x + r.width; ++x) {
        const int X = std::min(W - 1, static_cast<int>((x + 0.5) / scale));
        const int Y = std::min(H - 1, static_cast<int>((y + 0.5) / scale));
        const bool in = seed_mask->at(X, Y) > 0.5f;
        const bool sure = in && sure_object != nullptr && sure_object->at(X, Y) > 0.5f;
        labels.at<uchar>(y, x) = sure ? cv::GC_FGD : in ? cv::GC_PR_FGD : cv::GC_PR_BGD;
        any = any || in;
      }
    if (any && sure_background_px > 0) {
      // Distance (small-image pixels) of every pixel from the seed's object: 0 on it.
      cv::Mat outside(small.size(), CV_8UC1);
      for (int y = 0; y < small.rows; ++y)
        for (int x = 0; x < small.cols; ++x) {
          const uchar l = labels.at<uchar>(y, x);
          outside.at<uchar>(y, x) = (l == cv::GC_FGD || l == cv::GC_PR_FGD) ? 0 : 255;
        }
      cv::Mat dist;
      cv::distanceTransform(outside, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
      const float band = static_cast<float>(sure_background_px * scale);
      for (int y = r.y; y < r.y + r.height; ++y)
        for (int x = r.x; x < r.x + r.width; ++x)
          if (dist.at<float>(y, x) > band) labels.at<uchar>(y, x) = cv::GC_BGD;
    }
    if (any) grabcut(cv::GC_INIT_WITH_MASK);
  } else if (seed != GrabCutSeed::kColour) {
    grabcut(cv::GC_INIT_WITH_RECT);
  }
  const auto any_foreground = [&] {
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x)
        if (is_object(labels.at<uchar>(y, x))) return true;
    return false;
  };
  if (seed == GrabCutSeed::kColour || (seed == GrabCutSeed::kRectThenColour && !any_foreground())) {
    // The rectangle's colour models converged to "all background" (the object is a small part of a busy rectangle).
    // Seed again from colour: inside the rectangle, pixels whose colour (8 bins per channel) is rare outside it
    // (under 0.1% of the outside pixels) start as probable object, the rest as probable background.
    std::vector<double> outside(512, 0.0);
    double n_out = 0;
    const auto bin_of = [&](int x, int y) {
      const cv::Vec3b& v = small.at<cv::Vec3b>(y, x);
      return (v[2] / 32) * 64 + (v[1] / 32) * 8 + v[0] / 32;
    };
    for (int y = 0; y < small.rows; ++y)
      for (int x = 0; x < small.cols; ++x)
        if (!r.contains(cv::Point(x, y))) {
          outside[static_cast<size_t>(bin_of(x, y))] += 1;
          n_out += 1;
        }
    bool seeded = false;
    labels.setTo(cv::Scalar(cv::GC_BGD));
    for (int y = r.y; y < r.y + r.height; ++y)
      for (int x = r.x; x < r.x + r.width; ++x) {
        const bool rare = n_out == 0 || outside[static_cast<size_t>(bin_of(x, y))] < 0.001 * n_out;
        labels.at<uchar>(y, x) = rare ? cv::GC_PR_FGD : cv::GC_PR_BGD;
        seeded = seeded || rare;
      }
    if (seeded) grabcut(cv::GC_INIT_WITH_MASK);
  }
  cv::Mat fg(small.size(), CV_32FC1);
  for (int y = 0; y < small.rows; ++y)
    for (int x = 0; x < small.cols; ++x) fg.at<float>(y, x) = is_object(labels.at<uchar>(y, x)) ? 1.f : 0.f;
  cv::Mat up;
  if (scale < 1.0)
    cv::resize(fg, up, cv::Size(W, H), 0, 0, cv::INTER_LINEAR);
  else
    up = fg;
  Image out(W, H, 1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) out.at(x, y) = std::clamp(up.at<float>(y, x), 0.f, 1.f);
  return out;
}

SquareCrop training_crop(const Camera& network_camera, const FramedInput& framed, const Vec3& centre, double radius,
                         double d_min, double d_max, const TrainingFraming& tf) {
  require(framed.side > 0, "training_crop: the framing has no crop");
  if (!(radius > 0 && std::isfinite(radius) && centre.allFinite()))
    throw InvalidInput("training_crop: the shape's radius must be positive and its centre finite");
  if (!(d_min > 0 && d_min <= d_max && std::isfinite(d_max)))
    throw InvalidInput("training_crop: the render distances must be 0 < min <= max");
  const Camera& c = network_camera;
  // The unit-sphere frame's points y sit at x = centre + radius y; the camera sees them at
  // R x + t = radius (R y + t'), t' = (R centre + t) / radius: its origin at t', i.e. at distance |t'|.
  const Vec3 t1 = (c.R * centre + c.t) / radius;
  if (!(t1.z() > kMinDepth))
    throw InvalidInput("training_crop: the camera sees the shape's centre from behind");
  const Eigen::Vector3d h = c.K * t1;
  const double qx = h.x() / h.z(), qy = h.y() / h.z();  // the origin's pixel in the network image
  const double focal = std::sqrt(std::abs(c.K(0, 0) * c.K(1, 1)));
  require(focal > 0, "training_crop: the camera has no focal length");
  const double d1 = t1.norm(), dt = std::clamp(d1, d_min, d_max);
  // A unit sphere at distance d appears with size ~ f / d: the render shows it k times larger than this image.
  const double longer = std::max(framed.object_box.w, framed.object_box.h);
  const double s = framed.side / network_camera.width;  // input pixels per network pixel
  double k = kDisnFocal * d1 / (focal * dt);
  // The object's extent in the new crop is longer / (side / k): kept within the renders' range.
  const double extent_now = longer / framed.side;
  k = std::clamp(k, tf.extent_min / extent_now, tf.extent_max / extent_now);
  // Network pixel v of the new crop is u = q + (v - c0) / k of the current one: the origin q goes to the centre c0.
  const double c0x = 0.5 * network_camera.width, c0y = 0.5 * network_camera.height;
  SquareCrop out;
  out.side = framed.side / k;
  out.x0 = framed.x0 + s * (qx - c0x / k);
  out.y0 = framed.y0 + s * (qy - c0y / k);
  // The object's box centre within centre_tolerance of the renders' median place (in crop sides).
  const PixelBox& ob = framed.object_box;
  const double bx = ob.x + 0.5 * ob.w, by = ob.y + 0.5 * ob.h;
  const double dx = (bx - out.x0) / out.side - 0.5 - tf.centre_dx, dy = (by - out.y0) / out.side - 0.5 - tf.centre_dy;
  out.x0 += (dx - std::clamp(dx, -tf.centre_tolerance, tf.centre_tolerance)) * out.side;
  out.y0 += (dy - std::clamp(dy, -tf.centre_tolerance, tf.centre_tolerance)) * out.side;
  return out;
}

void recrop(FramedInput& framed, const Image& image, const SquareCrop& crop) {
  require(crop.side > 0 && std::isfinite(crop.side) && std::isfinite(crop.x0) && std::isfinite(crop.y0),
          "recrop: the crop must have a positive, finite side");
  require(framed.mask.width == image.width && framed.mask.height == image.height,
          "recrop: the image is not the one framed");
  framed.x0 = crop.x0;
  framed.y0 = crop.y0;
  framed.side = crop.side;
  framed.extent = std::max(framed.object_box.w, framed.object_box.h) / crop.side;
  framed.reframed = true;
  framed.image = crop_network_image(framing_rgb(image, framed.mask_source == "alpha"), framed);
}

Segmentation parse_segmentation(const std::string& name) {
  if (name == "auto") return Segmentation::kAuto;
  if (name == "none") return Segmentation::kNone;
  if (name == "grabcut") return Segmentation::kGrabCut;
  if (name == "net") return Segmentation::kNet;
  throw InvalidInput("segmentation '" + name + "': use auto, none, grabcut or net");
}

std::string segmentation_name(Segmentation s) {
  switch (s) {
    case Segmentation::kAuto: return "auto";
    case Segmentation::kNone: return "none";
    case Segmentation::kGrabCut: return "grabcut";
    case Segmentation::kNet: return "net";
  }
  return "auto";
}

Reframing parse_reframing(const std::string& name) {
  if (name == "auto") return Reframing::kAuto;
  if (name == "always") return Reframing::kAlways;
  if (name == "none") return Reframing::kNone;
  throw InvalidInput("framing '" + name + "': use auto, always or none");
}

std::string reframing_name(Reframing r) {
  switch (r) {
    case Reframing::kAuto: return "auto";
    case Reframing::kAlways: return "always";
    case Reframing::kNone: return "none";
  }
  return "auto";
}

PixelBox parse_pixel_box(const std::string& text) {
  PixelBox b;
  char c1 = 0, c2 = 0, c3 = 0;
  std::istringstream in(text);
  std::string rest;
  if (!(in >> b.x >> c1 >> b.y >> c2 >> b.w >> c3 >> b.h) || c1 != ',' || c2 != ',' || c3 != ',' || (in >> rest))
    throw InvalidInput("box '" + text + "': expected X,Y,W,H in pixels (e.g. 40,20,200,180)");
  if (b.x < 0 || b.y < 0 || b.w <= 0 || b.h <= 0)
    throw InvalidInput("box '" + text + "': X and Y must be >= 0, W and H > 0");
  return b;
}

Image plain_background_mask(const Image& rgb, const float background[3], double tolerance) {
  require(rgb.channels >= 3, "plain_background_mask: RGB image required");
  require(tolerance > 0, "plain_background_mask: tolerance must be positive");
  Image out(rgb.width, rgb.height, 1);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) {
      float d = 0;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(rgb.at(x, y, c) - background[c]));
      out.at(x, y) = static_cast<float>(std::clamp((d - tolerance) / tolerance, 0.0, 1.0));
    }
  return out;
}

MaskAgreement mask_agreement(const Image& mask, const Image& truth) {
  if (mask.width != truth.width || mask.height != truth.height)
    throw InvalidInput("mask_iou: masks of different sizes (" + std::to_string(mask.width) + "x" +
                       std::to_string(mask.height) + " and " + std::to_string(truth.width) + "x" +
                       std::to_string(truth.height) + ")");
  long both = 0, only_mask = 0, only_truth = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const bool in_m = mask_value(mask, x, y) > 0.5f, in_t = mask_value(truth, x, y) > 0.5f;
      both += in_m && in_t;
      only_mask += in_m && !in_t;
      only_truth += in_t && !in_m;
    }
  MaskAgreement a;
  const long either = both + only_mask + only_truth, truth_count = both + only_truth;
  a.iou = either == 0 ? 1.0 : static_cast<double>(both) / static_cast<double>(either);
  if (truth_count > 0) {
    a.missed = static_cast<double>(only_truth) / static_cast<double>(truth_count);
    a.extra = static_cast<double>(only_mask) / static_cast<double>(truth_count);
  }
  return a;
}

double mask_iou(const Image& a, const Image& b) { return mask_agreement(a, b).iou; }

Image zoomed_foreground(const std::function<Image(const Image& rgb)>& segmenter, const Image& rgb, int rounds,
                        double fill, const std::string& what, int* zooms, bool windows, SegmenterScan* scan,
                        const std::function<std::vector<Image>(const std::vector<Image>& rgbs)>& batch) {
  require(static_cast<bool>(segmenter), "zoomed_foreground: no segmenter");
  require(rounds >= 0 && fill > 0 && fill <= 1, "zoomed_foreground: rounds >= 0 and fill in (0, 1] required");
  const int W = rgb.width, H = rgb.height;
  // The segmenter's answers for `ims`, one call when a batch reader is given.
  const auto read = [&](const std::vector<Image>& ims) {
    std::vector<Image> ps;
    if (batch && ims.size() > 1) {
      ps = batch(ims);
      if (ps.size() != ims.size()) throw InvalidInput(what + ": the segmenter answered for another number of images");
    } else {
      for (const Image& im : ims) ps.push_back(segmenter(im));
    }
    for (size_t k = 0; k < ims.size(); ++k)
      if (ps[k].width != ims[k].width || ps[k].height != ims[k].height || ps[k].channels != 1)
        throw InvalidInput(what + ": the segmenter answered with a map of another size");
    return ps;
  };
  // A square [ox, ox + side)^2 of rgb (pixels outside repeat its edge), and its answer placed in a full-size map.
  struct Square {
    int ox = 0, oy = 0, side = 0;
  };
  const auto cut = [&](const Square& q) {
    Image square(q.side, q.side, rgb.channels);
    for (int y = 0; y < q.side; ++y)
      for (int x = 0; x < q.side; ++x) {
        const int sx = std::clamp(q.ox + x, 0, W - 1), sy = std::clamp(q.oy + y, 0, H - 1);
        for (int c = 0; c < rgb.channels; ++c) square.at(x, y, c) = rgb.at(sx, sy, c);
      }
    return square;
  };
  const auto place = [&](const Image& answer, const Square& q) {
    Image full(W, H, 1, 0.0f);
    for (int y = std::max(0, q.oy); y < std::min(H, q.oy + q.side); ++y)
      for (int x = std::max(0, q.ox); x < std::min(W, q.ox + q.side); ++x) full.at(x, y) = answer.at(x - q.ox, y - q.oy);
    return full;
  };
  struct Zoomed {
    Image p;
    int zooms = 0;
  };
  // Every candidate zoomed in on its own answer, the candidates' squares of a round read together: a candidate
  // stops at the first round whose answer has no object or whose square would be no smaller than the image.
  const auto zoom_all = [&](std::vector<Image> first) {
    std::vector<Zoomed> z(first.size());
    for (size_t k = 0; k < z.size(); ++k) z[k].p = std::move(first[k]);
    std::vector<char> active(z.size(), 1);
    for (int round = 0; round < rounds; ++round) {
      std::vector<size_t> who;
      std::vector<Square> squares;
      std::vector<Image> ims;
      for (size_t k = 0; k < z.size(); ++k) {
        if (!active[k]) continue;
        long count = 0;
        const PixelBox b = hard_box(z[k].p, &count);
        const int side = std::max(8, static_cast<int>(std::lround(std::max(b.w, b.h) / fill)));
        if (count == 0 || side >= std::max(W, H)) {
          active[k] = 0;
          continue;
        }
        const Square q{(2 * b.x + b.w) / 2 - side / 2, (2 * b.y + b.h) / 2 - side / 2, side};
        who.push_back(k);
        squares.push_back(q);
        ims.push_back(cut(q));
      }
      if (who.empty()) break;
      const std::vector<Image> answers = read(ims);
      for (size_t i = 0; i < who.size(); ++i) {
        z[who[i]].p = place(answers[i], squares[i]);
        ++z[who[i]].zooms;
      }
    }
    return z;
  };
  if (scan != nullptr) *scan = {};
  // The scan's windows: squares of 0.6 of the longer side, at most half a square apart along each axis, each read
  // and zoomed in on as the whole image is. In the whole image's 128 px letterbox a small or thin object can go
  // unseen while a salient part of the photo is taken for the object; a window shows it 1.7 times larger.
  std::vector<Square> windows_at;
  if (windows && rounds > 0) {
    const int L = std::max(W, H), side = static_cast<int>(std::lround(kScanWindow * L));
    const auto places = [side](int extent) {
      std::vector<int> out;
      if (extent <= side) return std::vector<int>{(extent - side) / 2};
      const int n = 1 + static_cast<int>(std::ceil((extent - side) / (0.5 * side)));
      for (int i = 0; i < n; ++i) out.push_back(static_cast<int>(std::lround(double(i) * (extent - side) / (n - 1))));
      return out;
    };
    for (const int oy : places(H))
      for (const int ox : places(W)) windows_at.push_back({ox, oy, side});
  }
  // The whole image and the windows, read and zoomed in on together.
  std::vector<Image> firsts{rgb};
  for (const Square& q : windows_at) firsts.push_back(cut(q));
  std::vector<Image> answers = read(firsts);
  for (size_t k = 0; k < windows_at.size(); ++k) answers[k + 1] = place(answers[k + 1], windows_at[k]);
  std::vector<Zoomed> cands = zoom_all(std::move(answers));
  long marked = 0;
  for (const float v : cands[0].p.data) marked += v > 0.5f;
  // An answer covering nearly the whole image (frame_input refuses it: no object stands out) is kept as it is:
  // windows of such an image would each find a window-sized "object" and agree on one.
  if (windows_at.empty() || !stands_out(marked, W, H)) {
    if (zooms != nullptr) *zooms = cands[0].zooms;
    return std::move(cands[0].p);
  }
  // Each candidate's final answer (p > 0.5) against every other's: the object is what most readings agree on,
  // a salient region of the photo is what one window's reading alone takes for it.
  const size_t n = cands.size();
  std::vector<std::vector<char>> hard(n, std::vector<char>(static_cast<size_t>(W) * H));
  for (size_t k = 0; k < n; ++k)
    for (size_t i = 0; i < hard[k].size(); ++i) hard[k][i] = cands[k].p.data[i] > 0.5f;
  size_t best = 0;
  double best_score = -1;
  for (size_t k = 0; k < n; ++k) {
    double sum = 0;
    for (size_t l = 0; l < n; ++l) {
      if (l == k) continue;
      long both = 0, either = 0;
      for (size_t i = 0; i < hard[k].size(); ++i) {
        both += hard[k][i] && hard[l][i];
        either += hard[k][i] || hard[l][i];
      }
      sum += either == 0 ? 0.0 : static_cast<double>(both) / static_cast<double>(either);
    }
    const double score = sum / static_cast<double>(n - 1);
    if (score > best_score) {  // ties keep the earlier candidate: the whole image first
      best_score = score;
      best = k;
    }
  }
  if (scan != nullptr) {
    scan->candidates = static_cast<int>(n);
    scan->chosen = static_cast<int>(best);
    scan->agreement = best_score;
  }
  if (zooms != nullptr) *zooms = cands[best].zooms;
  return std::move(cands[best].p);
}

FramedInput frame_input(const Image& image, const Image* mask, const FramingSettings& st, const std::string& what) {
  if (image.empty() || image.width <= 0 || image.height <= 0 || image.channels <= 0)
    throw InvalidInput(what + ": empty image");
  // With more channels, which one is alpha is a guess (to_rgb would take the fourth, has_alpha none).
  if (image.channels > 4)
    throw InvalidInput(what + ": " + std::to_string(image.channels) +
                       " channels; give a grey, grey + alpha, RGB or RGBA image");
  const int W = image.width, H = image.height;
  FramedInput f;
  // 1. The object's coverage at the input's size.
  Image rgb = framing_rgb(image, false);
  bool clean = false;
  if (mask != nullptr) {
    if (mask->empty()) throw InvalidInput(what + ": empty mask");
    if (mask->width != W || mask->height != H)
      throw InvalidInput(what + ": mask is " + std::to_string(mask->width) + "x" + std::to_string(mask->height) +
                         " but the image is " + std::to_string(W) + "x" + std::to_string(H));
    f.mask = Image(W, H, 1);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) f.mask.at(x, y) = mask_value(*mask, x, y);
    f.mask_source = "mask";
  } else if (has_transparency(image)) {
    f.mask = alpha_of(image);
    for (float& v : f.mask.data) v = std::isfinite(v) ? std::clamp(v, 0.f, 1.f) : 0.f;
    f.mask_source = "alpha";
    rgb = framing_rgb(image, true);
  } else if (st.segment == Segmentation::kNone) {
    f.mask = Image(W, H, 1);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        f.mask.at(x, y) = is_ink(rgb.at(x, y, 0), rgb.at(x, y, 1), rgb.at(x, y, 2)) ? 1.f : 0.f;
      }
    f.mask_source = "none";
  } else {
    const BorderStats border = border_stats(rgb, st.background_tolerance);
    const bool plain = border.plain_share >= st.plain_share;
    if (st.segment == Segmentation::kAuto && plain) {
      f.mask = plain_background_mask(rgb, border.colour, st.background_tolerance);
      f.mask_source = "plain-background";
    } else if (st.segment == Segmentation::kNet || (st.segment == Segmentation::kAuto && st.segmenter)) {
      if (!st.segmenter) throw InvalidInput(what + ": --segment net needs a segmenter model (--seg-model)");
      require(st.segmenter_high > st.segmenter_low, "framing: the segmenter's ramp needs low < high");
      const Image p =
          zoomed_foreground(st.segmenter, rgb, st.segmenter_zoom_rounds, st.segmenter_zoom_fill, what, &f.segmenter_zooms,
                            st.segmenter_scan, &f.segmenter_scan, st.segmenter_batch);
      f.mask = Image(W, H, 1);
      const double span = st.segmenter_high - st.segmenter_low;
      for (size_t i = 0; i < p.data.size(); ++i) {
        const double v = std::isfinite(p.data[i]) ? (p.data[i] - st.segmenter_low) / span : 0.0;
        f.mask.data[i] = static_cast<float>(std::clamp(v, 0.0, 1.0));
      }
      f.mask_source = "net";
      long marked = 0;
      const PixelBox net_box = hard_box(f.mask, &marked);
      // A network's mask covering nearly the whole image is refused below (no object stands out); GrabCut seeded
      // with it, its confident pixels sure object, would only trim the margin and hide that.
      if (st.segment == Segmentation::kAuto && stands_out(marked, W, H)) {
        // GrabCut seeded with the network's mask: the network tells which object the image is about, GrabCut
        // follows its edges in this image's colours. When GrabCut keeps nothing of it (a thin object whose colours
        // the background shares) or strays far from it (background of the object's colours taken in, thin parts
        // dropped: their IoU under grabcut_min_agreement), the network's mask as it is; only when the network found
        // no object, the rectangle's GrabCut (then by colour), which on a cluttered photo rarely finds the object
        // either.
        const PixelBox rect = grabcut_rect(st, W, H, what);
        Image sure_object;
        if (st.grabcut_sure_object <= 1.0) {
          sure_object = Image(W, H, 1);
          for (size_t i = 0; i < p.data.size(); ++i)
            sure_object.data[i] = std::isfinite(p.data[i]) && p.data[i] >= st.grabcut_sure_object ? 1.f : 0.f;
        }
        const double band_px = st.grabcut_sure_background * std::max(net_box.w, net_box.h);  // 0 without an object
        Image cut = grabcut_mask(rgb, rect, st.grabcut_max_side, st.grabcut_iterations, GrabCutSeed::kMask, &f.mask,
                                 sure_object.empty() ? nullptr : &sure_object, band_px);
        if (any_over_half(cut) && mask_iou(cut, f.mask) >= st.grabcut_min_agreement) {
          f.mask = std::move(cut);
          f.mask_source = "net+grabcut";
        } else if (any_over_half(f.mask)) {
          // the network's mask, source "net"
        } else if (cut = grabcut_mask(rgb, rect, st.grabcut_max_side, st.grabcut_iterations,
                                      GrabCutSeed::kRectThenColour);
                   any_over_half(cut)) {
          f.mask = std::move(cut);
          f.mask_source = "grabcut";
        }
        f.warnings.push_back("the background is not plain (" + fmt(100 * border.plain_share, 0) +
                             "% of the border is one colour): the object was segmented by the segmenter network and "
                             "GrabCut; check the mask");
      }
    } else {
      const PixelBox rect = grabcut_rect(st, W, H, what);
      f.mask = grabcut_mask(rgb, rect, st.grabcut_max_side, st.grabcut_iterations, GrabCutSeed::kRectThenColour);
      f.mask_source = "grabcut";
      if (st.segment == Segmentation::kAuto)
        f.warnings.push_back("the background is not plain (" + fmt(100 * border.plain_share, 0) +
                             "% of the border is one colour): the object was segmented by GrabCut; check the mask");
    }
    clean = true;
  }
  if (st.box) {
    const PixelBox& b = *st.box;
    if (b.x >= W || b.y >= H)
      throw InvalidInput(what + ": --box starts outside the " + std::to_string(W) + "x" + std::to_string(H) + " image");
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (x < b.x || y < b.y || x >= b.x + b.w || y >= b.y + b.h) f.mask.at(x, y) = 0;
  }
  if (clean) drop_specks(f.mask, 0.02);

  // 2. The object's box; refuse what is not an object.
  long count = 0;
  f.object_box = hard_box(f.mask, &count);
  const PixelBox& ob = f.object_box;
  if (count == 0)
    throw InvalidInput(what + ": the image shows only background (no object pixel; mask source " + f.mask_source + ")");
  const int longer = std::max(ob.w, ob.h);
  if (longer < st.min_object_px)
    throw InvalidInput(what + ": the object is too small (" + std::to_string(ob.w) + "x" + std::to_string(ob.h) +
                       " px; at least " + std::to_string(st.min_object_px) + " px on its longer side)");
  const double cover = static_cast<double>(count) / (static_cast<double>(W) * H);
  if (clean && cover > kMaxObjectCover)
    throw InvalidInput(what + ": no object stands out from the background (the " + f.mask_source +
                       " mask covers " + fmt(100 * cover, 0) + "% of the image); give --mask or --box");
  if (f.mask_source == "grabcut" && colour_overlap(rgb, f.mask) > st.max_colour_overlap)
    throw InvalidInput(what + ": no object stands out from the background (GrabCut's object and background have the "
                       "same colours); give --mask or --box");
  const bool touches = ob.x == 0 || ob.y == 0 || ob.x + ob.w == W || ob.y + ob.h == H;
  if (touches) f.warnings.push_back("the object touches the image border: it may be cut off");
  if (longer < 48)
    f.warnings.push_back("the object is small (" + std::to_string(ob.w) + "x" + std::to_string(ob.h) +
                         " px): details below a few pixels are lost");

  // 3. The crop.
  const TrainingFraming& tf = st.training;
  const double bx = ob.x + 0.5 * ob.w, by = ob.y + 0.5 * ob.h;
  bool reframe = st.reframe == Reframing::kAlways;
  if (st.reframe == Reframing::kAuto) {
    const bool square = std::abs(W - H) <= std::max(1, static_cast<int>(0.01 * std::max(W, H)));
    const double extent = static_cast<double>(longer) / std::max(W, H);
    const double dx = bx / W - 0.5 - tf.centre_dx, dy = by / H - 0.5 - tf.centre_dy;
    const bool like_training = square && !touches && extent >= tf.extent_min && extent <= tf.extent_max &&
                               std::abs(dx) <= tf.centre_tolerance && std::abs(dy) <= tf.centre_tolerance;
    reframe = !like_training;
  }
  // 4. The network image: the crop of the object (premultiplied by its coverage) at 137 px. Reframed: the object's
  // longer side is the renders' median share of the crop, its box centre at their median place.
  if (reframe) {
    f.side = longer / tf.extent;
    f.x0 = bx - (0.5 + tf.centre_dx) * f.side;
    f.y0 = by - (0.5 + tf.centre_dy) * f.side;
  } else {
    f.side = std::max(W, H);
    f.x0 = 0.5 * (W - f.side);
    f.y0 = 0.5 * (H - f.side);
  }
  f.extent = longer / f.side;
  f.reframed = reframe;
  f.image = crop_network_image(rgb, f);
  long shown = 0;
  for (int y = 0; y < kNetImageSize; ++y)
    for (int x = 0; x < kNetImageSize; ++x) {
      const float a = f.image.at(x, y, 3);
      const auto shown_as = [&](int c) { return a * f.image.at(x, y, c) + (1 - a) * kBackground; };
      shown += is_ink(shown_as(0), shown_as(1), shown_as(2));
    }
  const double n = static_cast<double>(kNetImageSize) * kNetImageSize;
  if (shown < st.min_object_share * n)
    throw InvalidInput(what + ": the image shows only background (" + std::to_string(shown) + " of " +
                       std::to_string(static_cast<long>(n)) +
                       " pixels of the framed image differ from the white background; mask source " + f.mask_source + ")");
  return f;
}

Image frame_channel(const Image& channel, const FramedInput& framed) {
  require(channel.channels == 1 && channel.width == framed.mask.width && channel.height == framed.mask.height,
          "frame_channel: a 1-channel image of the input's size is needed");
  require(framed.side > 0, "frame_channel: the framing has no crop");
  Image grey(channel.width, channel.height, 3);
  for (size_t i = 0; i < channel.data.size(); ++i)
    grey.data[3 * i] = grey.data[3 * i + 1] = grey.data[3 * i + 2] = channel.data[i];
  // Resampled with an opaque alpha: channel 0 is the mean over the footprint's samples inside the input, alpha the
  // share of them inside; their product counts the outside as 0.
  const Image rgba = resample_crop(grey, Image(channel.width, channel.height, 1, 1.f), framed.x0, framed.y0,
                                   framed.side, kNetImageSize);
  Image out(kNetImageSize, kNetImageSize, 1);
  for (int y = 0; y < kNetImageSize; ++y)
    for (int x = 0; x < kNetImageSize; ++x) out.at(x, y) = rgba.at(x, y, 0) * rgba.at(x, y, 3);
  return out;
}

Eigen::VectorXf context_input(const Image& image, const FramedInput& framed) {
  require(framed.mask.width == image.width && framed.mask.height == image.height,
          "context_input: the image is not the one framed");
  require(framed.side > 0 && framed.image.width == kNetImageSize && framed.image.height == kNetImageSize &&
              framed.image.channels == 4,
          "context_input: the framing has no crop");
  const Image rgb = framing_rgb(image, false);
  const Image crop =
      resample_crop(rgb, Image(rgb.width, rgb.height, 1, 1.f), framed.x0, framed.y0, framed.side, kNetImageSize);
  const Eigen::VectorXf pixels = network_image(crop);  // the crop's part outside the input composited on white
  const Eigen::Index n = static_cast<Eigen::Index>(kNetImageSize) * kNetImageSize;
  Eigen::VectorXf out(4 * n);
  out.head(3 * n) = pixels;
  for (int y = 0; y < kNetImageSize; ++y)
    for (int x = 0; x < kNetImageSize; ++x)
      out[3 * n + static_cast<Eigen::Index>(y) * kNetImageSize + x] = std::clamp(framed.image.at(x, y, 3), 0.f, 1.f);
  return out;
}

Camera camera_in_input(const Camera& network_camera, const FramedInput& framed, int input_width, int input_height) {
  require(framed.side > 0, "camera_in_input: the framing has no crop");
  require(input_width > 0 && input_height > 0, "camera_in_input: input size must be positive");
  // Network-image pixel u maps to input pixel x0 + u * s (s = side / network width).
  Camera c = network_camera;
  const double s = framed.side / network_camera.width;
  Eigen::Matrix3d A;
  A << s, 0, framed.x0, 0, framed.side / network_camera.height, framed.y0, 0, 0, 1;
  c.K = A * network_camera.K;
  c.width = input_width;
  c.height = input_height;
  return c;
}

Camera camera_in_network(const Camera& input_camera, const FramedInput& framed) {
  require(framed.side > 0, "camera_in_network: the framing has no crop");
  Camera c = input_camera;
  const double s = framed.side / kNetImageSize;
  Eigen::Matrix3d A_inv;
  A_inv << 1 / s, 0, -framed.x0 / s, 0, 1 / s, -framed.y0 / s, 0, 0, 1;
  c.K = A_inv * input_camera.K;
  c.width = c.height = kNetImageSize;
  return c;
}

}  // namespace sdfkit
