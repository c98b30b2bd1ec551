#include "train/dataset.h"

#include "core/error.h"
#include "core/json.h"
#include "core/parallel.h"
#include "core/random.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <numeric>
#include <sstream>
#include <unordered_map>

namespace fs = std::filesystem;

namespace sdfkit {

namespace {

std::string two_digits(int v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%02d", v);
  return buf;
}

int count_views(const fs::path& shape_dir) {
  int v = 0;
  while (fs::exists(shape_dir / "views" / (two_digits(v) + ".json")) &&
         fs::exists(shape_dir / "views" / (two_digits(v) + ".png")))
    ++v;
  return v;
}

/// Fisher-Yates permutation of [0, n) from our own generator (std::shuffle is implementation-defined).
std::vector<int> permutation(int n, Rng& rng) {
  std::vector<int> p(n);
  std::iota(p.begin(), p.end(), 0);
  for (int i = n - 1; i > 0; --i) std::swap(p[i], p[static_cast<int>(rng.below(static_cast<uint64_t>(i) + 1))]);
  return p;
}

}  // namespace

std::string resolve_split_file(const std::string& root, const std::string& split) {
  if (fs::is_regular_file(split)) return split;
  const bool is_name = split.find('/') == std::string::npos && split.find('.') == std::string::npos;
  if (is_name) {
    const fs::path a = fs::path(root) / (split + ".lst");
    const fs::path b = fs::path(root).parent_path() / (split + ".lst");
    if (fs::is_regular_file(a)) return a.string();
    if (fs::is_regular_file(b)) return b.string();
    throw IoError("split '" + split + "': neither " + a.string() + " nor " + b.string() + " exists");
  }
  throw IoError(split + ": split list file not found");
}

std::vector<std::string> read_split_file(const std::string& path) {
  std::istringstream in(read_file(path));
  std::vector<std::string> ids;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    size_t s = 0;
    while (s < line.size() && (line[s] == ' ' || line[s] == '\t')) ++s;
    line = line.substr(s);
    if (line.empty() || line[0] == '#') continue;
    if (line.find('/') == std::string::npos)
      throw IoError(path + ": line '" + line + "' is not of the form <category>/<shape>");
    ids.push_back(line);
  }
  return ids;
}

struct Dataset::Cache {
  std::mutex mutex;
  std::unordered_map<size_t, std::shared_ptr<const MatrixXfR>> samples;
};

Dataset::Dataset(const DatasetSettings& settings) : root_(settings.root), cache_(std::make_unique<Cache>()) {
  if (!fs::is_directory(root_)) throw IoError(root_ + ": dataset folder not found");
  std::vector<std::string> ids;
  if (!settings.split.empty()) {
    ids = read_split_file(resolve_split_file(root_, settings.split));
  } else {
    for (const auto& cat : fs::directory_iterator(root_)) {
      if (!cat.is_directory()) continue;
      for (const auto& shp : fs::directory_iterator(cat.path()))
        if (shp.is_directory() && fs::exists(shp.path() / "samples.npy"))
          ids.push_back(cat.path().filename().string() + "/" + shp.path().filename().string());
    }
    std::sort(ids.begin(), ids.end());
  }
  for (const auto& id : ids) {
    ShapeEntry e;
    e.id = id;
    e.category = id.substr(0, id.find('/'));
    if (!settings.categories.empty() &&
        std::find(settings.categories.begin(), settings.categories.end(), e.category) == settings.categories.end())
      continue;
    const fs::path dir = fs::path(root_) / id;
    e.dir = dir.string();
    if (!fs::exists(dir / "samples.npy")) throw IoError(e.dir + ": shape listed in the split has no samples.npy");
    e.num_views = count_views(dir);
    if (settings.require_views && e.num_views == 0)
      throw IoError(e.dir + ": no views (views/00.png + 00.json); prepare the dataset with --views");
    shapes_.push_back(std::move(e));
    if (settings.max_shapes > 0 && static_cast<int>(shapes_.size()) >= settings.max_shapes) break;
  }
  if (shapes_.empty()) throw IoError(root_ + ": no prepared shapes found" +
                                     (settings.split.empty() ? "" : " for split '" + settings.split + "'"));
}

Dataset::~Dataset() = default;
Dataset::Dataset(Dataset&&) noexcept = default;
Dataset& Dataset::operator=(Dataset&&) noexcept = default;

const MatrixXfR& Dataset::samples(size_t i) const {
  {
    std::lock_guard<std::mutex> lock(cache_->mutex);
    if (auto it = cache_->samples.find(i); it != cache_->samples.end()) return *it->second;
  }
  const std::string path = (fs::path(shape(i).dir) / "samples.npy").string();
  auto m = std::make_shared<const MatrixXfR>(read_npy(path));
  if (m->cols() < 4 || m->rows() == 0) throw IoError(path + ": expected an N x 4 array (x, y, z, sdf)");
  if (!m->allFinite()) throw IoError(path + ": contains non-finite values");
  std::lock_guard<std::mutex> lock(cache_->mutex);
  auto [it, inserted] = cache_->samples.emplace(i, std::move(m));
  return *it->second;
}

std::string Dataset::view_path(size_t i, int view, const char* ext) const {
  return (fs::path(shape(i).dir) / "views" / (two_digits(view) + "." + ext)).string();
}

std::string Dataset::gt_mesh_path(size_t i) const { return (fs::path(shape(i).dir) / "gt.obj").string(); }

Camera Dataset::camera(size_t i, int view) const {
  require(view >= 0 && view < shape(i).num_views, shape(i).dir + ": view " + std::to_string(view) + " out of range");
  const std::string path = view_path(i, view, "json");
  try {
    return read_camera(path);
  } catch (const IoError&) {
    throw;
  } catch (const std::exception& e) {
    throw IoError(path + ": bad camera (" + e.what() + ")");
  }
}

Image Dataset::image(size_t i, int view) const {
  require(view >= 0 && view < shape(i).num_views, shape(i).dir + ": view " + std::to_string(view) + " out of range");
  return read_image(view_path(i, view, "png"));
}

Eigen::VectorXf Dataset::input(size_t i, int view) const { return network_image(image(i, view)); }

void draw_samples(const MatrixXfR& samples, int n, uint64_t seed, PointsF& points, Eigen::VectorXf& sdf) {
  require(samples.rows() > 0 && samples.cols() >= 4, "draw_samples: need an N x 4 sample array");
  require(n > 0, "draw_samples: n must be positive");
  Rng rng(seed);
  const auto N = static_cast<uint64_t>(samples.rows());
  points.resize(n, 3);
  sdf.resize(n);
  if (static_cast<uint64_t>(n) <= N) {
    // Partial Fisher-Yates over an index array: n distinct rows.
    std::vector<int> idx(N);
    std::iota(idx.begin(), idx.end(), 0);
    for (int k = 0; k < n; ++k) {
      const uint64_t j = k + rng.below(N - k);
      std::swap(idx[k], idx[j]);
      points.row(k) = samples.row(idx[k]).head<3>();
      sdf[k] = samples(idx[k], 3);
    }
  } else {
    for (int k = 0; k < n; ++k) {
      const auto j = static_cast<Eigen::Index>(rng.below(N));
      points.row(k) = samples.row(j).head<3>();
      sdf[k] = samples(j, 3);
    }
  }
}

BatchSampler::BatchSampler(const Dataset& data, const BatchSettings& settings) : data_(&data), settings_(settings) {
  require(settings.batch_size > 0, "batch size must be positive");
  require(settings.points_per_shape > 0, "points per shape must be positive");
  for (size_t s = 0; s < data.size(); ++s) {
    const int views = std::max(1, data.shape(s).num_views);  // a shape without views still has its samples
    for (int v = 0; v < views; ++v) pairs_.emplace_back(static_cast<int>(s), data.shape(s).num_views > 0 ? v : -1);
  }
  require(!pairs_.empty(), "empty dataset");
}

SdfBatch BatchSampler::batch(long step, int begin, int end) const {
  require(step >= 0, "batch step must be non-negative");
  require(0 <= begin && begin <= end && end <= settings_.batch_size, "batch item range out of bounds");
  const int B = end - begin, N = settings_.points_per_shape;
  SdfBatch out;
  out.points_per_item = N;
  out.shape_index.resize(B);
  out.view_index.resize(B);
  out.cameras.resize(B);
  out.points.resize(static_cast<Eigen::Index>(B) * N, 3);
  out.sdf.resize(static_cast<Eigen::Index>(B) * N);
  if (settings_.load_images) out.images.resize(B, 3 * kNetImageSize * kNetImageSize);
  // Resolve the items of this batch (one permutation per epoch touched).
  const long n = items_per_epoch();
  const long first = step * settings_.batch_size + begin;
  std::vector<int> perm;
  long perm_epoch = -1;
  for (int b = 0; b < B; ++b) {
    const long g = first + b, epoch = g / n;
    if (epoch != perm_epoch) {
      Rng rng = Rng::derived(settings_.seed ^ 0x5eedba7c4ULL, static_cast<uint64_t>(epoch));
      perm = permutation(static_cast<int>(n), rng);
      perm_epoch = epoch;
    }
    const auto& [s, v] = pairs_[perm[g % n]];
    out.shape_index[b] = s;
    out.view_index[b] = v;
  }
  // A bad file's error is the first failing item's, whatever the scheduling.
  parallel_for_ordered_errors(0, B, [&](int b) {
    const int s = out.shape_index[b], v = out.view_index[b];
    PointsF pts;
    Eigen::VectorXf d;
    draw_samples(data_->samples(s), N, Rng::mix(settings_.seed + 0x9e37ULL * static_cast<uint64_t>(first + b + 1)),
                 pts, d);
    out.points.middleRows(static_cast<Eigen::Index>(b) * N, N) = pts;
    out.sdf.segment(static_cast<Eigen::Index>(b) * N, N) = d;
    if (v >= 0) {
      out.cameras[b] = data_->camera(s, v);
      if (settings_.load_images) out.images.row(b) = data_->input(s, v).transpose();
    } else if (settings_.load_images) {
      throw IoError(data_->shape(s).dir + ": no views to load");
    }
  });
  return out;
}

Json ImageAugmentSettings::to_json() const {
  return {{"colour", colour}, {"channel_swap", channel_swap}, {"noise", noise}};
}

void augment_images(MatrixXfR& images, const ImageAugmentSettings& a, uint64_t seed, uint64_t stream) {
  require(a.colour >= 0 && a.colour < 1, "augmentation: colour strength must be in [0, 1)");
  require(a.channel_swap >= 0 && a.channel_swap <= 1, "augmentation: channel-swap probability must be in [0, 1]");
  require(a.noise >= 0 && std::isfinite(a.noise), "augmentation: noise must be a finite value >= 0");
  if (!a.enabled() || images.rows() == 0) return;
  const Eigen::Index side = square_side(images.cols(), "augmentation");
  const Eigen::Index plane = side * side;
  static constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  tbb::parallel_for(Eigen::Index(0), images.rows(), [&](Eigen::Index b) {
    // Fixed draw order: colour (4 uniforms), swap (2), then noise, each only when enabled.
    Rng rng = Rng::derived(seed ^ 0xa06e47a11ULL, stream + static_cast<uint64_t>(b));
    float gain[3] = {1.f, 1.f, 1.f};
    if (a.colour > 0) {
      const double bright = rng.uniform(1.0 - a.colour, 1.0 + a.colour);
      for (float& g : gain) g = static_cast<float>(bright * rng.uniform(1.0 - 0.5 * a.colour, 1.0 + 0.5 * a.colour));
    }
    int order = 0;
    if (a.channel_swap > 0) {
      const bool swap = rng.uniform() < a.channel_swap;
      const auto pick = static_cast<int>(rng.below(6));
      if (swap) order = pick;
    }
    float* row = images.row(b).data();
    if (a.colour > 0 || order != 0) {
      std::vector<float> src(row, row + 3 * plane);
      for (int c = 0; c < 3; ++c) {
        const float* in = src.data() + kOrders[order][c] * plane;
        float* out = row + c * plane;
        const float g = gain[c];
        for (Eigen::Index i = 0; i < plane; ++i) out[i] = std::clamp(1.f - g * (1.f - in[i]), 0.f, 1.f);
      }
    }
    if (a.noise > 0)
      for (Eigen::Index i = 0; i < 3 * plane; ++i)
        row[i] = std::clamp(row[i] + static_cast<float>(a.noise * rng.normal()), 0.f, 1.f);
  });
}

Json ZoomAugmentSettings::to_json() const {
  Json j = {{"prob", prob}, {"min", min}, {"max", max}};
  // Only the newer mode is named, so that the pose models' stored settings (distance) still match on --resume.
  if (camera == CameraFollow::kFocal) j["camera"] = "focal";
  return j;
}

void zoom_images(MatrixXfR& images, std::vector<Camera>& cameras, const ZoomAugmentSettings& z, uint64_t seed,
                 uint64_t stream, std::vector<double>* applied) {
  require(z.prob >= 0 && z.prob <= 1, "zoom augmentation: the probability must be in [0, 1]");
  require(std::isfinite(z.min) && std::isfinite(z.max) && z.min > 0 && z.min <= z.max,
          "zoom augmentation: need 0 < min <= max");
  require(cameras.size() == static_cast<size_t>(images.rows()),
          "zoom augmentation: " + std::to_string(cameras.size()) + " cameras for " + std::to_string(images.rows()) +
              " images");
  if (applied) applied->assign(cameras.size(), 1.0);
  if (!z.enabled() || images.rows() == 0) return;
  const int S = square_side(images.cols(), "zoom augmentation");
  tbb::parallel_for(Eigen::Index(0), images.rows(), [&](Eigen::Index b) {
    Rng rng = Rng::derived(seed ^ 0x200a06e47ULL, stream + static_cast<uint64_t>(b));
    double k = std::exp(rng.uniform(std::log(z.min), std::log(z.max)));
    const bool zoom = rng.uniform() < z.prob;
    if (!zoom) return;
    const Eigen::VectorXf row = images.row(b).transpose();
    k = std::min(k, max_zoom_inside(row, S));
    images.row(b) = zoom_image(row, S, k).transpose();
    Camera& cam = cameras[static_cast<size_t>(b)];
    if (z.camera == ZoomAugmentSettings::CameraFollow::kDistance) {
      cam.t.z() /= k;
    } else {
      // The zoom maps image point q to c + k (q - c); the image spans the camera's pixel grid.
      const double cx = 0.5 * cam.width, cy = 0.5 * cam.height;
      cam.K(0, 0) *= k;
      cam.K(1, 1) *= k;
      cam.K(0, 1) *= k;
      cam.K(0, 2) = magnified_coordinate(cam.K(0, 2), cx, k);
      cam.K(1, 2) = magnified_coordinate(cam.K(1, 2), cy, k);
    }
    if (applied) (*applied)[static_cast<size_t>(b)] = k;
  });
}

Json ReframeAugmentSettings::to_json() const {
  Json j = {{"prob", prob}, {"extent", extent}, {"centre_dx", centre_dx}, {"centre_dy", centre_dy}};
  if (camera == ZoomAugmentSettings::CameraFollow::kDistance) j["camera"] = "distance";
  return j;
}

void ReframeAugmentSettings::validate() const {
  require(prob >= 0 && prob <= 1, "reframe augmentation: the probability must be in [0, 1]");
  require(std::isfinite(extent) && extent > 0 && extent <= 1, "reframe augmentation: the extent must be in (0, 1]");
  require(std::abs(centre_dx) <= 0.5 && std::abs(centre_dy) <= 0.5,
          "reframe augmentation: the centre offsets must be in [-0.5, 0.5]");
}

void frame_like_recon(ReframeAugmentSettings& r, const TrainingFraming& tf) {
  r.extent = tf.extent;
  r.centre_dx = tf.centre_dx;
  r.centre_dy = tf.centre_dy;
}

void reframe_images(MatrixXfR& images, std::vector<Camera>& cameras, const ReframeAugmentSettings& r, uint64_t seed,
                    uint64_t stream, std::vector<double>* applied, std::vector<char>* reframed) {
  r.validate();
  require(cameras.size() == static_cast<size_t>(images.rows()),
          "reframe augmentation: " + std::to_string(cameras.size()) + " cameras for " + std::to_string(images.rows()) +
              " images");
  if (applied) applied->assign(cameras.size(), 1.0);
  if (reframed) reframed->assign(cameras.size(), 0);
  if (!r.enabled() || images.rows() == 0) return;
  const int S = square_side(images.cols(), "reframe augmentation");
  tbb::parallel_for(Eigen::Index(0), images.rows(), [&](Eigen::Index b) {
    Rng rng = Rng::derived(seed ^ 0x7ef7a3e0ULL, stream + static_cast<uint64_t>(b));
    if (!(rng.uniform() < r.prob)) return;
    const Eigen::VectorXf row = images.row(b).transpose();
    const InkBox box = ink_box(row, S);
    if (box.empty) return;
    // The object's box centre m goes to d, its longer side L to extent * S.
    const double mx = 0.5 * (box.x0 + box.x1), my = 0.5 * (box.y0 + box.y1);
    const double k = r.extent * S / std::max(box.x1 - box.x0, box.y1 - box.y0);
    const double dx = (0.5 + r.centre_dx) * S, dy = (0.5 + r.centre_dy) * S;
    images.row(b) = resample_similarity(row, S, k, mx, my, dx, dy).transpose();
    // In the camera's pixels (the image spans its grid): p' = d + k (p - m), so f and skew scale by k (or the
    // distance by 1 / k) and the principal point moves through the same map.
    Camera& cam = cameras[static_cast<size_t>(b)];
    const double sx = static_cast<double>(cam.width) / S, sy = static_cast<double>(cam.height) / S;
    if (r.camera == ZoomAugmentSettings::CameraFollow::kDistance) {
      cam.t.z() /= k;
    } else {
      cam.K(0, 0) *= k;
      cam.K(1, 1) *= k;
      cam.K(0, 1) *= k;
    }
    cam.K(0, 2) = dx * sx + k * (cam.K(0, 2) - mx * sx);
    cam.K(1, 2) = dy * sy + k * (cam.K(1, 2) - my * sy);
    if (applied) (*applied)[static_cast<size_t>(b)] = k;
    if (reframed) (*reframed)[static_cast<size_t>(b)] = 1;
  });
}

Json OcclusionAugmentSettings::to_json() const { return {{"kind", to_string(kind)}, {"prob", prob}}; }

OcclusionAugmentSettings::Kind parse_occlusion_kind(const std::string& name) {
  using Kind = OcclusionAugmentSettings::Kind;
  if (name == "none") return Kind::kNone;
  if (name == "half") return Kind::kHalf;
  if (name == "rect") return Kind::kRect;
  if (name == "mixed") return Kind::kMixed;
  throw InvalidInput("unknown occlusion '" + name + "' (use none, half, rect or mixed)");
}

std::string to_string(OcclusionAugmentSettings::Kind kind) {
  using Kind = OcclusionAugmentSettings::Kind;
  switch (kind) {
    case Kind::kNone: return "none";
    case Kind::kHalf: return "half";
    case Kind::kRect: return "rect";
    case Kind::kMixed: return "mixed";
  }
  return "none";
}

Eigen::VectorXf occlude_network_image(Eigen::Ref<Eigen::VectorXf> image, int size, const OcclusionSettings& settings,
                                      uint64_t seed) {
  const int64_t n = static_cast<int64_t>(size) * size;
  require(size > 0 && image.size() == 3 * n, "occlusion: the image is not 3 square channels of the given size");
  Image rgba = ink_rgba(image, size);
  const Image removed = apply_occlusion(rgba, settings, seed);
  Eigen::VectorXf mask(n);
  for (int64_t i = 0; i < n; ++i) {
    mask[i] = removed.data[static_cast<size_t>(i)];
    if (mask[i] > 0) image[i] = image[n + i] = image[2 * n + i] = kNetBackground;
  }
  return mask;
}

void occlude_images(MatrixXfR& images, MatrixXfR& masks, const OcclusionAugmentSettings& o, uint64_t seed,
                    uint64_t stream) {
  require(o.prob >= 0 && o.prob <= 1, "occlusion augmentation: the probability must be in [0, 1]");
  const int S = images.rows() ? square_side(images.cols(), "occlusion augmentation") : 0;
  masks.setZero(images.rows(), static_cast<Eigen::Index>(S) * S);
  if (!o.enabled()) return;
  using Kind = OcclusionAugmentSettings::Kind;
  tbb::parallel_for(Eigen::Index(0), images.rows(), [&](Eigen::Index b) {
    Rng rng = Rng::derived(seed ^ 0x0cc1d0e5ULL, stream + static_cast<uint64_t>(b));
    // Every draw is made whatever the outcome, so image b's choices never depend on earlier coins.
    const bool occlude = rng.uniform() < o.prob;
    const bool rect = o.kind == Kind::kRect || (o.kind == Kind::kMixed && rng.uniform() < 0.5);
    const bool left = rng.uniform() < 0.5;
    const uint64_t rect_seed = rng.next();
    if (!occlude) return;
    OcclusionSettings st;
    st.mode = rect ? OcclusionMode::kRect : (left ? OcclusionMode::kLeft : OcclusionMode::kRight);
    Eigen::VectorXf row = images.row(b).transpose();
    masks.row(b) = occlude_network_image(row, S, st, rect_seed).transpose();
    images.row(b) = row.transpose();
  });
}

Json MaskErrorAugmentSettings::to_json() const {
  Json j = {{"prob", prob},
            {"thin_radius_max", error.thin_radius_max},
            {"thin_drop", error.thin_drop},
            {"blob_prob", error.blob_prob},
            {"blob_size", {error.blob_size_min, error.blob_size_max}},
            {"keep_min", error.keep_min},
            {"edge_prob", error.edge_prob},
            {"edge_halo", error.edge_halo}};
  // Recorded only when on, so that the states of runs made before the end cut existed still resume.
  if (error.cut_prob > 0)
    j["cut"] = {{"prob", error.cut_prob},
                {"depth", {error.cut_depth_min, error.cut_depth_max}},
                {"tilt_deg", error.cut_tilt_deg}};
  return j;
}

void MaskErrorAugmentSettings::validate() const {
  require(prob >= 0 && prob <= 1, "mask-error augmentation: the probability must be in [0, 1]");
  error.validate();
}

void mask_error_images(MatrixXfR& images, const MaskErrorAugmentSettings& m, uint64_t seed, uint64_t stream,
                       std::vector<char>* applied) {
  m.validate();
  if (applied) applied->assign(static_cast<size_t>(images.rows()), 0);
  if (!m.enabled() || images.rows() == 0) return;
  const int S = square_side(images.cols(), "mask-error augmentation");
  const int64_t n = static_cast<int64_t>(S) * S;
  tbb::parallel_for(Eigen::Index(0), images.rows(), [&](Eigen::Index b) {
    Rng rng = Rng::derived(seed ^ 0x3a5e7e55ULL, stream + static_cast<uint64_t>(b));
    const bool apply = rng.uniform() < m.prob;
    const uint64_t error_seed = rng.next();
    if (!apply) return;
    Image rgba = ink_rgba(images.row(b).transpose(), S);
    apply_mask_error(rgba, m.error, error_seed, kNetBackground);
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const int64_t i = static_cast<int64_t>(y) * S + x;
        for (int c = 0; c < 3; ++c) images(b, c * n + i) = rgba.at(x, y, c);
      }
    if (applied) (*applied)[static_cast<size_t>(b)] = 1;
  });
}

}  // namespace sdfkit
