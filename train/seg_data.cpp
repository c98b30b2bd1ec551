#include "train/seg_data.h"

#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "core/random.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit {
namespace {
using Rgb = std::array<float, 3>;

// RGBA with the colour premultiplied by the alpha (an image without alpha: opaque).
Image premultiplied_rgba(const Image& img) {
  const Image rgb = to_rgb(img, 0.0f), a = alpha_of(img);
  Image out(img.width, img.height, 4);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = rgb.at(x, y, c);
      out.at(x, y, 3) = a.at(x, y);
    }
  return out;
}
constexpr double kPi = 3.14159265358979323846;
}  // namespace

std::string procedural_name(ProceduralBackground k) {
  switch (k) {
    case ProceduralBackground::kFlat: return "flat";
    case ProceduralBackground::kGradient: return "gradient";
    case ProceduralBackground::kNoise: return "noise";
    case ProceduralBackground::kStripes: return "stripes";
    case ProceduralBackground::kChecker: return "checker";
  }
  return "?";
}

Json SegCompositeSettings::to_json() const {
  std::vector<std::string> k;
  for (const auto kind : kinds) k.push_back(procedural_name(kind));
  Json j = {{"size", size},
          {"procedural", procedural},
          {"object_min", object_min},
          {"object_max", object_max},
          {"max_aspect", max_aspect},
          {"overflow", overflow},
          {"object_jitter", object_jitter},
          {"background_jitter", background_jitter},
          {"procedural_noise", procedural_noise},
          {"clutter", clutter},
          {"clutter_shapes", clutter_shapes},
          {"kinds", k}};
  // Only when on, so that the settings recorded before the cut-outs existed still match.
  if (cutouts > 0)
    j["cutouts"] = {{"prob", cutouts}, {"max", cutouts_max}, {"size", {cutout_min, cutout_max}}};
  return j;
}

void SegCompositeSettings::validate() const {
  require(size >= 8 && size <= 1024, "segmenter data: the size must be 8..1024");
  require(procedural >= 0 && procedural <= 1, "segmenter data: the procedural share must be in [0, 1]");
  require(object_min > 0 && object_min <= object_max && object_max <= 1.5,
          "segmenter data: need 0 < object-min <= object-max <= 1.5");
  require(max_aspect >= 1 && max_aspect <= 8, "segmenter data: the largest aspect ratio must be in [1, 8]");
  require(overflow >= 0 && overflow < 0.5, "segmenter data: the overflow must be in [0, 0.5)");
  require(object_jitter >= 0 && object_jitter < 1 && background_jitter >= 0 && background_jitter < 1,
          "segmenter data: jitters must be in [0, 1)");
  require(cutouts >= 0 && cutouts <= 1, "segmenter data: the cut-out probability must be in [0, 1]");
  require(cutouts_max >= 1 && cutouts_max <= 100, "segmenter data: the cut-outs per composite must be 1..100");
  require(cutout_min > 0 && cutout_min <= cutout_max && cutout_max <= 2,
          "segmenter data: need 0 < cutout-min <= cutout-max <= 2");
  require(!kinds.empty(), "segmenter data: no procedural background kind");
  require(procedural_noise >= 0 && procedural_noise <= 0.5, "segmenter data: the procedural noise must be in [0, 0.5]");
  require(clutter >= 0 && clutter <= 1, "segmenter data: the clutter probability must be in [0, 1]");
  require(clutter_shapes >= 1 && clutter_shapes <= 1000, "segmenter data: the clutter shapes must be 1..1000");
}

// ----------------------------------------------------------------------------------------------- backgrounds
namespace {

bool has_image_extension(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char* x : {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".exr", ".webp"})
    if (e == x) return true;
  return false;
}

}  // namespace

std::vector<std::string> list_background_files(const std::string& source) {
  std::vector<std::string> files;
  std::error_code ec;
  if (fs::is_directory(source, ec)) {
    for (fs::recursive_directory_iterator it(source, fs::directory_options::skip_permission_denied, ec), end;
         !ec && it != end; it.increment(ec))
      if (it->is_regular_file(ec) && has_image_extension(it->path())) files.push_back(it->path().string());
    if (ec) throw IoError(source + ": cannot list the background folder (" + ec.message() + ")");
    std::sort(files.begin(), files.end());
    if (files.empty()) throw IoError(source + ": no background images (png, jpg, tif, bmp, exr, webp) in the folder");
    return files;
  }
  if (!fs::is_regular_file(source, ec)) throw IoError(source + ": no such background folder or list file");
  const fs::path base = fs::path(source).parent_path();
  std::istringstream in(read_file(source));
  std::string line;
  while (std::getline(in, line)) {
    const auto b = line.find_first_not_of(" \t\r"), e = line.find_last_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    const fs::path p(line.substr(b, e - b + 1));
    files.push_back((p.is_absolute() ? p : base / p).string());
  }
  if (files.empty()) throw IoError(source + ": the background list names no image");
  return files;
}

BackgroundSet::BackgroundSet(const std::string& source, int max_side, bool alpha) {
  require(max_side >= 8, "backgrounds: the largest side must be >= 8");
  paths_ = list_background_files(source);
  images_.resize(paths_.size());
  parallel_for_ordered_errors(size_t(0), paths_.size(), [&](size_t i) {  // an unreadable file: the first one
    const Image img = read_image(paths_[i]);
    Image rgb = alpha ? premultiplied_rgba(img) : to_rgb(img, 1.0f);
    for (float& v : rgb.data) v = std::clamp(v, 0.0f, 1.0f);
    const int longer = std::max(rgb.width, rgb.height);
    if (longer > max_side) {
      const double s = static_cast<double>(max_side) / longer;
      rgb = resample_image(rgb, std::max(1, static_cast<int>(std::lround(rgb.width * s))),
                           std::max(1, static_cast<int>(std::lround(rgb.height * s))));
    }
    images_[i] = std::move(rgb);
  });
}

// ----------------------------------------------------------------------------------------------- composites
namespace {

float clamp01(double v) { return static_cast<float>(std::clamp(v, 0.0, 1.0)); }

Rgb random_colour(Rng& rng) {
  return {static_cast<float>(rng.uniform()), static_cast<float>(rng.uniform()), static_cast<float>(rng.uniform())};
}

/// A background colour: white-ish, near `near` (the object's mean colour), or random; a third each.
Rgb pick_colour(Rng& rng, const Rgb& near) {
  const uint64_t k = rng.below(3);
  if (k == 0) {
    const auto g = static_cast<float>(rng.uniform(0.88, 1.0));
    return {g, g, g};
  }
  if (k == 1) {
    Rgb c;
    for (int i = 0; i < 3; ++i) c[static_cast<size_t>(i)] = clamp01(near[static_cast<size_t>(i)] + rng.uniform(-0.12, 0.12));
    return c;
  }
  return random_colour(rng);
}

void fill_procedural(Image& bg, ProceduralBackground kind, const Rgb& near, double max_noise, Rng& rng) {
  const int W = bg.width, H = bg.height;
  const Rgb a = pick_colour(rng, near), b = pick_colour(rng, near);
  auto put = [&](int x, int y, double t) {
    for (int c = 0; c < 3; ++c)
      bg.at(x, y, c) = clamp01(a[static_cast<size_t>(c)] + t * (b[static_cast<size_t>(c)] - a[static_cast<size_t>(c)]));
  };
  const double angle = rng.uniform(0, kPi), ca = std::cos(angle), sa = std::sin(angle);
  switch (kind) {
    case ProceduralBackground::kFlat:
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) put(x, y, 0);
      break;
    case ProceduralBackground::kGradient: {
      // t runs from 0 to 1 across the canvas along the direction.
      const double span = std::abs(ca) * W + std::abs(sa) * H;
      const double lo = std::min({0.0, ca * W, sa * H, ca * W + sa * H});
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) put(x, y, ((x + 0.5) * ca + (y + 0.5) * sa - lo) / span);
      break;
    }
    case ProceduralBackground::kNoise: {
      // Two octaves of value noise on lattices of cell `cell` and cell / 2.5, smoothstep-interpolated.
      const double cell = std::exp(rng.uniform(std::log(3.0), std::log(64.0)));
      std::vector<double> t(static_cast<size_t>(W) * H, 0.0);
      double weight = 0.65;
      for (const double c : {cell, std::max(1.5, cell / 2.5)}) {
        const int gw = static_cast<int>(W / c) + 2, gh = static_cast<int>(H / c) + 2;
        std::vector<double> lat(static_cast<size_t>(gw) * gh);
        for (double& v : lat) v = rng.uniform();
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const double u = (x + 0.5) / c, v = (y + 0.5) / c;
            const int i = static_cast<int>(u), j = static_cast<int>(v);
            double fu = u - i, fv = v - j;
            fu = fu * fu * (3 - 2 * fu);
            fv = fv * fv * (3 - 2 * fv);
            auto L = [&](int p, int q) { return lat[static_cast<size_t>(q) * gw + p]; };
            const double top = L(i, j) + fu * (L(i + 1, j) - L(i, j));
            const double bot = L(i, j + 1) + fu * (L(i + 1, j + 1) - L(i, j + 1));
            t[static_cast<size_t>(y) * W + x] += weight * (top + fv * (bot - top));
          }
        weight = 0.35;
      }
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) put(x, y, t[static_cast<size_t>(y) * W + x]);
      break;
    }
    case ProceduralBackground::kStripes: {
      const double period = rng.uniform(4, 40);
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const double s = ((x + 0.5) * ca + (y + 0.5) * sa) / period;
          put(x, y, s - std::floor(s) < 0.5 ? 0 : 1);
        }
      break;
    }
    case ProceduralBackground::kChecker: {
      const double cell = rng.uniform(4, 40);
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const double u = ((x + 0.5) * ca + (y + 0.5) * sa) / cell, v = (-(x + 0.5) * sa + (y + 0.5) * ca) / cell;
          const long k = static_cast<long>(std::floor(u)) + static_cast<long>(std::floor(v));
          put(x, y, (k & 1) ? 1 : 0);
        }
      break;
    }
  }
  const double sigma = rng.uniform(0, max_noise);
  Rng noise(rng.next());
  if (sigma > 0)
    for (float& v : bg.data) v = clamp01(v + sigma * noise.normal());
}

/// Adds the bilinear sample of channels 0..C-1 at pixel-centre coordinates (fx, fy), clamped to the image, to acc.
template <int C>
void add_bilinear(const Image& img, double fx, double fy, double* acc) {
  fx = std::clamp(fx, 0.0, img.width - 1.0), fy = std::clamp(fy, 0.0, img.height - 1.0);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  const int x1 = std::min(x0 + 1, img.width - 1), y1 = std::min(y0 + 1, img.height - 1);
  const double ax = fx - x0, ay = fy - y0;
  for (int c = 0; c < C; ++c)
    acc[c] += (1 - ay) * ((1 - ax) * img.at(x0, y0, c) + ax * img.at(x1, y0, c)) +
              ay * ((1 - ax) * img.at(x0, y1, c) + ax * img.at(x1, y1, c));
}

/// A crop of a photo, resampled to the canvas and jittered.
void fill_photo(Image& bg, const Image& photo, double jitter, Rng& rng) {
  const int W = bg.width, H = bg.height, PW = photo.width, PH = photo.height;
  const double aspect = static_cast<double>(W) / H;
  const double cw_max = std::min<double>(PW, PH * aspect);
  const double cw = cw_max * rng.uniform(0.4, 1.0), ch = cw / aspect;
  const double ox = rng.uniform(0, std::max(0.0, PW - cw)), oy = rng.uniform(0, std::max(0.0, PH - ch));
  const bool flip = rng.uniform() < 0.5;
  const double bright = rng.uniform(1 - jitter, 1 + jitter);
  Rgb tint;
  for (float& t : tint) t = static_cast<float>(bright * rng.uniform(1 - jitter / 3, 1 + jitter / 3));
  const double sx = cw / W, sy = ch / H;
  const int nx = std::clamp(static_cast<int>(std::ceil(sx)), 1, 4), ny = std::clamp(static_cast<int>(std::ceil(sy)), 1, 4);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int xs = flip ? W - 1 - x : x;
      double acc[3] = {0, 0, 0};
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          add_bilinear<3>(photo, ox + (xs + (i + 0.5) / nx) * sx - 0.5, oy + (y + (j + 0.5) / ny) * sy - 0.5, acc);
      for (int c = 0; c < 3; ++c) bg.at(x, y, c) = clamp01(acc[c] / (nx * ny) * tint[static_cast<size_t>(c)]);
    }
}

/// Step 5 of the header comment: dead-leaves clutter drawn over `bg`.
void add_clutter(Image& bg, const BackgroundSet* photos, int max_shapes, double jitter, Rng& rng) {
  const int W = bg.width, H = bg.height;
  const double diag = std::hypot(W, H);
  const auto n = static_cast<int>(1 + rng.below(static_cast<uint64_t>(max_shapes)));
  constexpr int kSub = 4;  // coverage samples per pixel side
  for (int k = 0; k < n; ++k) {
    const auto type = rng.below(3);  // ellipse, rectangle, triangle
    const double half = 0.5 * diag * std::exp(rng.uniform(std::log(0.04), std::log(0.5)));
    const double half_minor = half * std::exp(rng.uniform(std::log(0.15), 0.0));
    const double cx = rng.uniform(-0.1 * W, 1.1 * W), cy = rng.uniform(-0.1 * H, 1.1 * H);
    const double angle = rng.uniform(0, kPi), ca = std::cos(angle), sa = std::sin(angle);
    const int x0 = std::max(0, static_cast<int>(std::floor(cx - half))), x1 = std::min(W - 1, static_cast<int>(cx + half));
    const int y0 = std::max(0, static_cast<int>(std::floor(cy - half))), y1 = std::min(H - 1, static_cast<int>(cy + half));
    const bool textured = photos != nullptr && !photos->empty() && rng.uniform() < 0.5;
    Image texture;
    Rgb colour{};
    double ramp = 0, ramp_c = 1, ramp_s = 0;
    if (textured) {
      const size_t i = static_cast<size_t>(rng.below(photos->size()));
      texture = Image(std::max(1, x1 - x0 + 1), std::max(1, y1 - y0 + 1), 3);
      fill_photo(texture, photos->image(i), jitter, rng);
    } else {
      colour = random_colour(rng);
      ramp = rng.uniform(-0.3, 0.3);
      const double ra = rng.uniform(0, 2 * kPi);
      ramp_c = std::cos(ra), ramp_s = std::sin(ra);
    }
    if (x0 > x1 || y0 > y1) continue;  // off the canvas (its draws are made all the same)
    auto inside = [&](double px, double py) {
      const double u = ((px - cx) * ca + (py - cy) * sa) / half, v = (-(px - cx) * sa + (py - cy) * ca) / half_minor;
      if (type == 0) return u * u + v * v <= 1;
      if (type == 1) return std::abs(u) <= 1 && std::abs(v) <= 1;
      return v >= -1 && v <= 1 - 2 * std::abs(u);
    };
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        int hits = 0;
        for (int j = 0; j < kSub; ++j)
          for (int i = 0; i < kSub; ++i) hits += inside(x + (i + 0.5) / kSub, y + (j + 0.5) / kSub) ? 1 : 0;
        if (hits == 0) continue;
        const float cover = static_cast<float>(hits) / (kSub * kSub);
        Rgb fill;
        if (textured) {
          for (int c = 0; c < 3; ++c) fill[static_cast<size_t>(c)] = texture.at(x - x0, y - y0, c);
        } else {
          const double t = ((x + 0.5 - cx) * ramp_c + (y + 0.5 - cy) * ramp_s) / half;  // in [-1, 1] on the shape
          for (int c = 0; c < 3; ++c)
            fill[static_cast<size_t>(c)] = clamp01(colour[static_cast<size_t>(c)] * (1 + ramp * t));
        }
        for (int c = 0; c < 3; ++c)
          bg.at(x, y, c) = cover * fill[static_cast<size_t>(c)] + (1 - cover) * bg.at(x, y, c);
      }
  }
}

/// Step 6 of the header comment: cut-out objects (premultiplied RGBA) pasted over `bg`.
void add_cutouts(Image& bg, const BackgroundSet& cutouts, const SegCompositeSettings& s, Rng& rng) {
  const int W = bg.width, H = bg.height;
  const auto n = static_cast<int>(1 + rng.below(static_cast<uint64_t>(s.cutouts_max)));
  for (int k = 0; k < n; ++k) {
    const Image& cut = cutouts.image(static_cast<size_t>(rng.below(cutouts.size())));
    const double longer = rng.uniform(s.cutout_min, s.cutout_max) * std::max(W, H);
    const double cx = rng.uniform(0, W), cy = rng.uniform(0, H);
    const bool flip = rng.uniform() < 0.5;
    const double bright = rng.uniform(1 - s.background_jitter, 1 + s.background_jitter);
    const double scale = longer / std::max(cut.width, cut.height);  // canvas px per cut-out px
    const double cw = cut.width * scale, ch = cut.height * scale;
    const int x0 = std::max(0, static_cast<int>(std::floor(cx - cw / 2)));
    const int x1 = std::min(W - 1, static_cast<int>(std::ceil(cx + cw / 2)));
    const int y0 = std::max(0, static_cast<int>(std::floor(cy - ch / 2)));
    const int y1 = std::min(H - 1, static_cast<int>(std::ceil(cy + ch / 2)));
    const int m = std::clamp(static_cast<int>(std::ceil(1.0 / scale)), 1, 4);  // samples per pixel side when shrinking
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double acc[4] = {0, 0, 0, 0};
        for (int j = 0; j < m; ++j)
          for (int i = 0; i < m; ++i) {
            double u = (x + (i + 0.5) / m - (cx - cw / 2)) / scale - 0.5;  // cut-out pixel-centre coordinates
            const double v = (y + (j + 0.5) / m - (cy - ch / 2)) / scale - 0.5;
            if (flip) u = cut.width - 1 - u;
            if (u < -0.5 || v < -0.5 || u > cut.width - 0.5 || v > cut.height - 0.5) continue;
            add_bilinear<4>(cut, u, v, acc);
          }
        const double inv = 1.0 / (m * m), a = acc[3] * inv;
        if (a <= 0) continue;
        for (int c = 0; c < 3; ++c)
          bg.at(x, y, c) = clamp01(acc[c] * inv * bright + (1 - a) * bg.at(x, y, c));
      }
  }
}

}  // namespace

Image draw_background(int width, int height, const BackgroundSet* backgrounds, const SegCompositeSettings& s,
                      const std::array<float, 3>& near, Rng& rng, std::string* name, const BackgroundSet* cutouts) {
  require(width > 0 && height > 0, "segmenter data: a background needs a positive size");
  Image bg(width, height, 3);
  std::string what;
  const bool photo = backgrounds && !backgrounds->empty() && !(rng.uniform() < s.procedural);
  if (photo) {
    const size_t i = static_cast<size_t>(rng.below(backgrounds->size()));
    fill_photo(bg, backgrounds->image(i), s.background_jitter, rng);
    what = "photo:" + std::to_string(i);
  } else {
    const ProceduralBackground kind = s.kinds[static_cast<size_t>(rng.below(s.kinds.size()))];
    fill_procedural(bg, kind, near, s.procedural_noise, rng);
    what = procedural_name(kind);
  }
  if (s.clutter > 0 && rng.uniform() < s.clutter) {
    add_clutter(bg, backgrounds, s.clutter_shapes, s.background_jitter, rng);
    what += "+clutter";
  }
  // Drawn only when on (with a set), so that composites made before the cut-outs existed repeat.
  if (s.cutouts > 0 && cutouts != nullptr && !cutouts->empty() && rng.uniform() < s.cutouts) {
    add_cutouts(bg, *cutouts, s, rng);
    what += "+cutouts";
  }
  if (name) *name = std::move(what);
  return bg;
}

SegSample make_composite(const Image& render, const BackgroundSet* backgrounds, const SegCompositeSettings& s,
                         uint64_t seed, uint64_t stream, const BackgroundSet* cutouts) {
  require(!render.empty(), "segmenter data: empty render");
  Rng rng = Rng::derived(seed, stream);
  const int S = s.size;
  // Premultiplied RGBA of the render and its alpha box.
  const int RW = render.width, RH = render.height;
  const bool has_alpha = render.channels == 2 || render.channels == 4;
  const Image rgb = to_rgb(render, 0.0f);  // premultiplied: composited on black
  std::vector<float> alpha(static_cast<size_t>(RW) * RH, 1.0f);
  if (has_alpha)
    for (int y = 0; y < RH; ++y)
      for (int x = 0; x < RW; ++x)
        alpha[static_cast<size_t>(y) * RW + x] = std::clamp(render.at(x, y, render.channels - 1), 0.0f, 1.0f);
  int bx0 = RW, by0 = RH, bx1 = -1, by1 = -1;
  double mean[3] = {0, 0, 0}, mass = 0;
  for (int y = 0; y < RH; ++y)
    for (int x = 0; x < RW; ++x) {
      const float a = alpha[static_cast<size_t>(y) * RW + x];
      if (a <= 0.01f) continue;
      bx0 = std::min(bx0, x), by0 = std::min(by0, y), bx1 = std::max(bx1, x), by1 = std::max(by1, y);
      for (int c = 0; c < 3; ++c) mean[c] += std::clamp(rgb.at(x, y, c), 0.0f, 1.0f);
      mass += a;
    }
  const bool empty = bx1 < 0;
  if (empty) bx0 = by0 = 0, bx1 = RW - 1, by1 = RH - 1;

  // 1. The canvas.
  const double aspect = std::exp(rng.uniform(0, std::log(s.max_aspect)));
  const bool landscape = rng.uniform() < 0.5;
  const int shorter = std::clamp(static_cast<int>(std::lround(S / aspect)), 1, S);
  const int W = landscape ? S : shorter, H = landscape ? shorter : S;
  // 2. The object's size and place (pixel-edge coordinates; its box [bx0, bx1 + 1) x [by0, by1 + 1)).
  const double bw = bx1 + 1 - bx0, bh = by1 + 1 - by0;
  // Capped so that the box also fits the canvas's shorter side (at object_max of it): a tall object on a wide
  // canvas is not cut in half.
  const double k = std::min({rng.uniform(s.object_min, s.object_max) * S / std::max(bw, bh), s.object_max * W / bw,
                             s.object_max * H / bh});
  auto place = [&](double size, int canvas) {
    double lo = size / 2 - s.overflow * size, hi = canvas - size / 2 + s.overflow * size;
    if (lo > hi) lo = hi = canvas / 2.0;
    return rng.uniform(lo, hi);
  };
  const double dx = place(k * bw, W), dy = place(k * bh, H);
  const double mx = 0.5 * (bx0 + bx1 + 1), my = 0.5 * (by0 + by1 + 1);
  // 3. Object jitter.
  const double bright = rng.uniform(1 - s.object_jitter, 1 + s.object_jitter);
  Rgb gain;
  for (float& g : gain) g = static_cast<float>(bright * rng.uniform(1 - s.object_jitter / 2, 1 + s.object_jitter / 2));
  Rgb near = {1, 1, 1};
  if (mass > 0)
    for (int c = 0; c < 3; ++c) near[static_cast<size_t>(c)] = clamp01(mean[c] / mass * gain[static_cast<size_t>(c)]);
  // 4-5. The background and its clutter.
  SegSample out;
  const Image bg = draw_background(W, H, backgrounds, s, near, rng, &out.background, cutouts);

  // The object resampled onto the canvas: canvas point q -> render point m + (q - d) / k.
  Image canvas(W, H, 3), label(W, H, 1);
  const int n = std::clamp(static_cast<int>(std::ceil(1.0 / k)), 1, 4);
  auto sample = [&](double fx, double fy, float px[4]) {  // bilinear in pixel-centre coordinates, 0 outside
    px[0] = px[1] = px[2] = px[3] = 0;
    const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
    const double ax = fx - x0, ay = fy - y0;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int x = x0 + i, y = y0 + j;
        if (x < 0 || y < 0 || x >= RW || y >= RH) continue;
        const auto w = static_cast<float>((i ? ax : 1 - ax) * (j ? ay : 1 - ay));
        for (int c = 0; c < 3; ++c) px[c] += w * rgb.at(x, y, c);
        px[3] += w * alpha[static_cast<size_t>(y) * RW + x];
      }
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float acc[4] = {0, 0, 0, 0};
      if (!empty || has_alpha)
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const double qx = x + (i + 0.5) / n, qy = y + (j + 0.5) / n;
            float px[4];
            sample(mx + (qx - dx) / k - 0.5, my + (qy - dy) / k - 0.5, px);
            for (int c = 0; c < 4; ++c) acc[c] += px[c];
          }
      const float inv = 1.0f / static_cast<float>(n * n);
      const float a = std::clamp(acc[3] * inv, 0.0f, 1.0f);
      label.at(x, y) = a;
      for (int c = 0; c < 3; ++c) {
        const float obj = std::clamp(acc[c] * inv * gain[static_cast<size_t>(c)], 0.0f, a);
        canvas.at(x, y, c) = obj + (1.0f - a) * bg.at(x, y, c);
      }
    }
  Letterbox g;
  out.image = letterbox(canvas, S, &g);
  out.label = letterbox(label, S);
  out.canvas_x0 = g.x0;
  out.canvas_y0 = g.y0;
  out.canvas_width = g.width;
  out.canvas_height = g.height;
  return out;
}

}  // namespace sdfkit
