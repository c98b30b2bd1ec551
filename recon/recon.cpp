#include "recon/recon.h"

#include "camera/render.h"
#include "camera/views.h"
#include "core/error.h"
#include "extract/adaptive.h"
#include "extract/cleanup.h"
#include "models/net_input.h"
#include "models/pose_net.h"
#include "models/sdf_net.h"
#include "sdf/normalize.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <sstream>

namespace sdfkit {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

bool power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }

/// Camera `c` re-targeted to a size x size image (intrinsics scaled).
Camera scaled_camera(const Camera& c, int size) {
  Camera out = c;
  const double sx = static_cast<double>(size) / c.width, sy = static_cast<double>(size) / c.height;
  out.K.row(0) *= sx;
  out.K.row(1) *= sy;
  out.width = out.height = size;
  return out;
}

void paste_rgb_on_white(const Image& rgba, Image& dst, int x0) {
  for (int y = 0; y < rgba.height && y < dst.height; ++y)
    for (int x = 0; x < rgba.width && x0 + x < dst.width; ++x) {
      const float a = rgba.channels >= 4 ? rgba.at(x, y, 3) : 1.f;
      for (int c = 0; c < 3; ++c) dst.at(x0 + x, y, c) = std::clamp(rgba.at(x, y, c) * a + (1.f - a), 0.f, 1.f);
    }
}

/// Pixel i of a 3 x 137 x 137 network input is foreground when it is ink (train/dataset.h).
bool is_foreground(const Eigen::VectorXf& input, int i) {
  const int n = kNetImageSize * kNetImageSize;
  return is_ink(input[i], input[n + i], input[2 * n + i]);
}

}  // namespace

Eigen::VectorXf flip_network_input(const Eigen::VectorXf& input, int size) {
  const Eigen::Index plane = static_cast<Eigen::Index>(size) * size;
  require(size > 0 && input.size() > 0 && input.size() % plane == 0,
          "flip_network_input: input is not C x " + std::to_string(size) + " x " + std::to_string(size));
  // One row of a batch, flipped as the pose network flips its batches (models/pose_net.h flip_images).
  const MatrixXfR flipped = flip_images(Eigen::Map<const MatrixXfR>(input.data(), 1, input.size()), size);
  return Eigen::Map<const Eigen::VectorXf>(flipped.data(), flipped.size());
}

Image input_foreground(const Eigen::VectorXf& input) {
  const int n = kNetImageSize * kNetImageSize;
  require(input.size() == 3 * n, "input_foreground: network input must be 3 x 137 x 137");
  Image out(kNetImageSize, kNetImageSize, 1);
  for (int i = 0; i < n; ++i) out.data[i] = is_foreground(input, i) ? 1.f : 0.f;
  return out;
}

Reconstructor::Reconstructor(std::unique_ptr<SdfNet> sdf, std::unique_ptr<PoseNet> pose,
                             std::unique_ptr<PoseNet> photo_pose, std::unique_ptr<SdfNet> photo_sdf)
    : sdf_(std::move(sdf)), photo_sdf_(std::move(photo_sdf)), pose_(std::move(pose)),
      photo_pose_(std::move(photo_pose)) {
  require(sdf_ != nullptr, "Reconstructor: an SDF network is required");
  require(sdf_->config().image_size == kNetImageSize, "Reconstructor: the SDF network must take 137 px inputs");
  if (photo_sdf_) {
    // One extraction rule for both: the same field (variant, scale) from the same input channels.
    const SdfNetConfig &a = sdf_->config(), &b = photo_sdf_->config();
    // An object-channel photo model reads its own input (the unmasked crop), whatever the main model's channels.
    if (b.image_size != a.image_size || b.variant != a.variant || b.sdf_scale != a.sdf_scale || b.sdf_offset != a.sdf_offset ||
        (b.input_channels != a.input_channels && !b.reads_context()))
      throw InvalidInput("the photo SDF model is a " + to_string(b.variant) + " model of " +
                         std::to_string(b.input_channels) + " input channels, the main one a " + to_string(a.variant) +
                         " model of " + std::to_string(a.input_channels) +
                         ": they must share the variant, the field's scale and the input channels");
  }
  if (sdf_->config().reads_context())
    throw InvalidInput("the main SDF model reads unmasked images with an object channel; it can only be the photo "
                       "model (--photo-model), which reads the crops recon makes");
}

Reconstructor::~Reconstructor() = default;

std::unique_ptr<Reconstructor> Reconstructor::load(const std::string& sdf_path, const std::string& pose_path,
                                                   const std::string& photo_pose_path,
                                                   const std::string& photo_sdf_path) {
  auto sdf = load_sdf_model(sdf_path);
  if (sdf->config().reads_context())
    throw InvalidInput(sdf_path + ": this SDF model reads unmasked images with an object channel; it can only be "
                                  "the photo model (--photo-model), which reads the crops recon makes");
  std::unique_ptr<SdfNet> photo_sdf;
  if (!photo_sdf_path.empty()) photo_sdf = load_sdf_model(photo_sdf_path);
  std::unique_ptr<PoseNet> pose, photo_pose;
  if (!pose_path.empty()) pose = load_pose_model(pose_path);
  if (!photo_pose_path.empty()) photo_pose = load_pose_model(photo_pose_path);
  try {
    return std::make_unique<Reconstructor>(std::move(sdf), std::move(pose), std::move(photo_pose),
                                           std::move(photo_sdf));
  } catch (const InvalidInput& e) {
    throw InvalidInput(photo_sdf_path + ": " + e.what());
  }
}

Camera Reconstructor::estimate_camera(const Eigen::VectorXf& input, double flip_check, double* flip_turn_deg,
                                     bool mirror_tta, bool reframed, const std::vector<double>& zoom_tta) const {
  if (!pose_) throw InvalidInput("no pose model loaded: give the camera (--cam FILE) or a pose model");
  PoseNet& net = *pose_for(reframed);
  MatrixXfR images(1, input.size());
  images.row(0) = input.transpose();
  std::lock_guard<std::mutex> lock(pose_mutex_);
  net.set_flip_check(flip_check);
  net.set_mirror_tta(mirror_tta);
  net.set_zoom_tta(zoom_tta);
  const PosePrediction p = net.predict(images);
  if (flip_turn_deg) *flip_turn_deg = p.azimuth_shift.at(0);
  return p.cameras.at(0);
}

Camera Reconstructor::estimate_network_camera(const Eigen::VectorXf& input, const ReconSettings& settings,
                                              double* flip_turn_deg, bool reframed) const {
  const Camera c = estimate_camera(input, settings.flip_check, flip_turn_deg, settings.pose_mirror_tta, reframed,
                                   settings.pose_zoom_tta);
  return settings.pose_distance_max > 0 ? distance_as_focal(c, settings.pose_distance_min, settings.pose_distance_max)
                                        : c;
}

struct Reconstructor::MeshStats {
  long evaluations = 0;
  int components_removed = 0;
  double encode = 0, field = 0, extract = 0, cleanup = 0;
};

namespace {

/// A given camera of `image` (a camera of another image size is scaled to the image's size first) as a camera of
/// the network image `framed` made of it.
Camera given_network_camera(const Camera& camera, const Image& image, const FramedInput& framed,
                            const std::string& what) {
  validate_camera(camera, what + ": camera");
  Camera in = camera;
  if (in.width != image.width || in.height != image.height) {
    in.K.row(0) *= static_cast<double>(image.width) / in.width;
    in.K.row(1) *= static_cast<double>(image.height) / in.height;
    in.width = image.width;
    in.height = image.height;
  }
  return camera_in_network(in, framed);
}

/// The settings' checks every reconstruction makes before any work.
void check_settings(const ReconSettings& settings, const std::string& what) {
  require(settings.refine_rounds >= 0, what + ": refinement rounds must be >= 0");
  require(settings.framing_fit_rounds >= 0, what + ": framing fit rounds must be >= 0");
  const int refine_res = std::min(settings.refine_resolution, settings.resolution);
  const int fit_res = std::min(settings.framing_fit_resolution, settings.resolution);
  for (const int res : {settings.resolution, settings.refine_rounds > 0 ? refine_res : settings.resolution,
                        settings.framing_fit_rounds > 0 ? fit_res : settings.resolution}) {
    require(res >= 3 && settings.coarse_resolution >= 2, what + ": resolution too small");
    require(settings.dense || ((res - 1) % (settings.coarse_resolution - 1) == 0 &&
                               power_of_two((res - 1) / (settings.coarse_resolution - 1))),
            what + ": (resolution - 1) / (coarse resolution - 1) must be a power of two, e.g. 65, 129, 257 with 17");
  }
  require(settings.safety == 0 || settings.safety >= 1.0, what + ": safety factor must be >= 1 (or 0: the model's default)");
  require((settings.pose_distance_min == 0 && settings.pose_distance_max == 0) ||
              (settings.pose_distance_min > 0 && settings.pose_distance_min <= settings.pose_distance_max &&
               std::isfinite(settings.pose_distance_max)),
          what + ": the pose distance range must be 0 < min <= max (or both 0: off)");
}

}  // namespace

ReconResult Reconstructor::run(const Image& image, const Image* mask, const Camera* camera,
                               const ReconSettings& settings, const std::string& what, const Image* missing) const {
  const auto t0 = Clock::now();
  if (missing != nullptr && (missing->width != image.width || missing->height != image.height))
    throw InvalidInput(what + ": the missing-data mask is " + std::to_string(missing->width) + " x " +
                       std::to_string(missing->height) + ", the image " + std::to_string(image.width) + " x " +
                       std::to_string(image.height));
  check_settings(settings, what);
  FramedInput framed = frame_input(image, mask, settings.framing, what);
  Image missing_channel;  // the missing-data mask's alpha, else its first channel
  if (missing != nullptr && missing->channels == 1) {
    missing_channel = *missing;
  } else if (missing != nullptr) {
    missing_channel = Image(missing->width, missing->height, 1);
    const int src = missing->channels == 2 || missing->channels == 4 ? missing->channels - 1 : 0;
    for (int y = 0; y < missing->height; ++y)
      for (int x = 0; x < missing->width; ++x) missing_channel.at(x, y) = missing->at(x, y, src);
  }
  // The network input of the framing (run_input's layout).
  const auto make_input = [&](const FramedInput& f) {
    return framed_input(image, f, missing != nullptr ? &missing_channel : nullptr);
  };
  Eigen::VectorXf input = make_input(framed);
  const int fits = framed.reframed ? fit_framing(image, framed, input, camera, settings, what, make_input) : 0;
  Image silhouette;
  if (settings.refine_rounds > 0) {
    if (framed.mask_source == "none") {
      silhouette = input_foreground(input.head(3 * kNetImageSize * kNetImageSize));
    } else {
      silhouette = Image(kNetImageSize, kNetImageSize, 1);
      for (int y = 0; y < kNetImageSize; ++y)
        for (int x = 0; x < kNetImageSize; ++x) silhouette.at(x, y) = framed.image.at(x, y, 3);
    }
  }
  Camera network_camera;
  if (camera != nullptr) network_camera = given_network_camera(*camera, image, framed, what);
  const double prep = since(t0);
  ReconResult r = run_input(input, camera != nullptr ? &network_camera : nullptr, settings, what,
                            settings.refine_rounds > 0 ? &silhouette : nullptr, framed.reframed);
  r.input_camera = camera_in_input(r.camera, framed, image.width, image.height);
  r.framing = std::move(framed);
  r.framing_fits = fits;
  r.timings.prepare = prep;
  r.timings.total += prep;
  return r;
}

Eigen::VectorXf Reconstructor::framed_input(const Image& image, const FramedInput& f, const Image* missing) const {
  const Eigen::VectorXf rgb = network_image(f.image);
  const bool context = f.reframed && photo_sdf_ != nullptr && photo_sdf_->config().reads_context();
  if (missing == nullptr && !context) return rgb;
  const Eigen::Index n = kNetImageSize * kNetImageSize;
  Image m;
  if (missing != nullptr) m = frame_channel(*missing, f);
  const auto missing_at = [&](Eigen::Index i) {
    return missing != nullptr ? std::clamp(m.data[static_cast<size_t>(i)], 0.f, 1.f) : 0.f;
  };
  Eigen::VectorXf full((context ? 8 : 4) * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const float w = missing_at(i);
    for (int c = 0; c < 3; ++c) full[c * n + i] = (1 - w) * rgb[c * n + i] + w * kNetBackground;
    full[3 * n + i] = w;
  }
  if (context) {
    Eigen::VectorXf ctx = context_input(image, f);
    keep_band(ctx.head(3 * n), 3, ctx.tail(n), photo_sdf_->config().context_band, kNetBackground);
    for (Eigen::Index i = 0; i < n; ++i) {
      const float w = missing_at(i);
      for (int c = 0; c < 3; ++c) full[(4 + c) * n + i] = (1 - w) * ctx[c * n + i] + w * kNetBackground;
      full[7 * n + i] = (1 - w) * ctx[3 * n + i];
    }
  }
  return full;
}

int Reconstructor::fit_framing(const Image& image, FramedInput& framed, Eigen::VectorXf& input, const Camera* camera,
                               const ReconSettings& settings, const std::string& what,
                               const std::function<Eigen::VectorXf(const FramedInput&)>& make_input) const {
  const ViewSetSettings renders;  // the training renders' camera distances
  const int rounds = camera != nullptr ? std::min(1, settings.framing_fit_rounds) : settings.framing_fit_rounds;
  const int res = std::min(settings.framing_fit_resolution, settings.resolution);
  const PoseNet* reader = pose_for(true);
  const bool fit_to_shape =
      settings.framing_fit_centre == ReconSettings::FitCentre::kShape ||
      (settings.framing_fit_centre == ReconSettings::FitCentre::kAuto && !(reader && reader->settings().centre_head));
  int done = 0;
  for (int round = 0; round < rounds; ++round) {
    SquareCrop crop;
    if (camera != nullptr) {  // exact: the given camera says where the origin is and how far
      crop = training_crop(given_network_camera(*camera, image, framed, what), framed, Vec3::Zero(), 1.0,
                           renders.distance_min, renders.distance_max, settings.framing.training);
    } else {
      const Camera c = estimate_network_camera(input.head(3 * kNetImageSize * kNetImageSize), settings, nullptr, true);
      Normalization shape;  // the object's unit-sphere frame in the camera's object frame: the camera's own, or ...
      if (fit_to_shape) {   // ... the coarse mesh's
        try {
          MeshStats st;
          shape = unit_sphere_normalization(reconstruct(input, c, settings, res, what, st, true));
        } catch (const Error&) {
          break;  // no surface (or a degenerate one) through this camera: keep the crop
        }
      }
      crop = training_crop(c, framed, shape.center, shape.radius, renders.distance_min, renders.distance_max,
                           settings.framing.training);
    }
    recrop(framed, image, crop);
    input = make_input(framed);
    ++done;
  }
  return done;
}

double Reconstructor::extraction_safety(const ReconSettings& settings) const {
  return settings.safety > 0 ? settings.safety : default_extraction_safety(sdf_->config().variant);
}

namespace {
std::string threshold_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

double Reconstructor::occupancy_threshold(const ReconSettings& settings) const {
  if (sdf_->config().variant != SdfVariant::kBinary) return 0;
  if (!(settings.threshold > 0 && settings.threshold < 1))
    throw InvalidInput("occupancy threshold " + threshold_text(settings.threshold) + " is outside (0, 1)");
  return settings.threshold;
}

double Reconstructor::surface_level(const ReconSettings& settings) const {
  const double tau = occupancy_threshold(settings);
  if (tau == 0) return 0;
  return -std::log(tau / (1 - tau)) / sdf_->config().sdf_scale;
}

Mesh Reconstructor::reconstruct(const Eigen::VectorXf& input, const Camera& camera, const ReconSettings& settings,
                                int resolution, const std::string& what, MeshStats& stats, bool reframed) const {
  return reconstruct({{&input, camera, &sdf_for(reframed)}}, settings, resolution, what, stats);
}

Mesh Reconstructor::reconstruct(const std::vector<ViewRef>& views, const ReconSettings& settings, int resolution,
                                const std::string& what, MeshStats& stats) const {
  require(!views.empty(), what + ": no views to reconstruct from");
  auto t = Clock::now();
  // Per view: RGB (3 x 137 x 137) or RGB + missing-data mask (4 x ...), as the SDF network reads it
  // (train/dataset.h), encoded once; with the mirror TTA also the flipped input through the mirrored camera.
  const Eigen::Index n = kNetImageSize * kNetImageSize;
  std::vector<SdfNet::ShapeCode> codes, mirrored;
  for (const ViewRef& v : views) {
    const Eigen::VectorXf& input = *v.input;
    Eigen::VectorXf net_input;
    if (v.net->config().reads_context()) {
      if (input.size() != 8 * n)
        throw InvalidInput(what + ": the photo SDF model reads unmasked crops with the object's mask; this input has "
                                  "none (it was not reframed)");
      net_input = input.tail(4 * n);
    } else {
      Eigen::VectorXf mask;
      if (input.size() >= 4 * n) mask = input.segment(3 * n, n);
      net_input = network_input(input.head(3 * n), mask.size() ? &mask : nullptr, v.net->config().input_channels);
    }
    codes.push_back(v.net->encode(net_input.data(), v.camera));
    if (settings.mirror_tta) {
      const Eigen::VectorXf flipped = flip_network_input(net_input, kNetImageSize);
      mirrored.push_back(v.net->encode(flipped.data(), mirror_camera(v.camera)));
    }
  }
  stats.encode = since(t);

  double field_seconds = 0;
  // The mean of the views' fields (for a binary model, of their logits: the occupancy whose odds are the geometric
  // mean of the views' odds). The mirrored input describes the mirrored object: its field at (-x, y, z) is the
  // object's at (x, y, z).
  const BatchField field = [&](const Points& p, Eigen::VectorXd& values) {
    const auto tf = Clock::now();
    Points q;
    if (!mirrored.empty()) {
      q = p;
      q.col(0) = -q.col(0);
    }
    Eigen::VectorXd one;
    values.setZero(p.rows());
    for (size_t v = 0; v < codes.size(); ++v) {
      views[v].net->field(codes[v], p, one);
      values += one;
      if (!mirrored.empty()) {
        views[v].net->field(mirrored[v], q, one);
        values += one;
      }
    }
    values /= static_cast<double>(codes.size() * (mirrored.empty() ? 1 : 2));
    field_seconds += since(tf);
  };
  ExtractSettings es;
  es.resolution = resolution;
  es.coarse_resolution = settings.coarse_resolution;
  es.box_min = Vec3::Constant(-settings.box_half);
  es.box_size = 2 * settings.box_half;
  es.iso = surface_level(settings);
  es.safety = extraction_safety(settings);
  es.close_boundary = true;
  es.follow_surface = settings.follow_surface;
  const ExtractResult ex = settings.dense ? dense_extract(field, es) : adaptive_extract(field, es);
  stats.evaluations = ex.evaluations;
  stats.field = field_seconds;
  stats.extract = std::max(0.0, ex.seconds - field_seconds);
  if (ex.mesh.empty())
    throw Error(what + ": no surface found (the network predicts no inside region in the box)");

  t = Clock::now();
  CleanupSettings cs;
  cs.min_component_fraction = settings.min_component_fraction;
  CleanupReport rep;
  Mesh mesh = cleanup(ex.mesh, cs, &rep);
  stats.components_removed = rep.components - rep.kept_components;
  stats.cleanup = since(t);
  return mesh;
}

ReconResult Reconstructor::run_input(const Eigen::VectorXf& full_input, const Camera* camera,
                                     const ReconSettings& settings, const std::string& what,
                                     const Image* silhouette, bool reframed) const {
  constexpr Eigen::Index kPixels = kNetImageSize * kNetImageSize;
  require(full_input.size() == 3 * kPixels || full_input.size() == 4 * kPixels || full_input.size() == 8 * kPixels,
          what + ": network input must be 3 x 137 x 137 (RGB), 4 x 137 x 137 (RGB + missing-data mask) or 8 x 137 x "
                 "137 (those and the unmasked crop with the object's mask)");
  // The pose network, the silhouette and the preview read the RGB channels; the SDF network reads the mask too when it
  // has the channel (reconstruct()).
  const Eigen::VectorXf input = full_input.head(3 * kPixels);
  check_settings(settings, what);
  const int refine_res = std::min(settings.refine_resolution, settings.resolution);
  ReconResult r;
  const auto t_all = Clock::now();
  auto t = Clock::now();
  if (camera != nullptr) {
    validate_camera(*camera, what + ": camera");
    r.camera = *camera;
    r.camera_estimated = false;
  } else {
    r.camera = estimate_network_camera(input, settings, &r.flip_turn_deg, reframed);
    r.camera_estimated = true;
    r.pose_mirror_tta = settings.pose_mirror_tta;
    r.pose_zoom_tta = settings.pose_zoom_tta;
    r.photo_pose = reframed && photo_pose_ != nullptr;
    r.timings.pose = since(t);
  }
  r.initial_camera = r.camera;
  r.input_camera = r.camera;

  if (settings.refine_rounds > 0) {
    t = Clock::now();
    Image fg;
    if (silhouette == nullptr) {
      fg = input_foreground(input);
      silhouette = &fg;
    }
    if (silhouette->width != r.camera.width || silhouette->height != r.camera.height)
      throw InvalidInput(what + ": the silhouette for camera refinement must have the camera's image size");
    for (int round = 0; round < settings.refine_rounds; ++round) {
      CameraRefineResult rr;
      if (settings.refine_joint) {
        const MeshForCamera mesh_for = [&](const Camera& c) {
          MeshStats st;
          try {
            Mesh m = reconstruct(full_input, c, settings, refine_res, what, st, reframed);
            r.evaluations += st.evaluations;
            return m;
          } catch (const Error&) {  // no surface through this camera: an empty silhouette
            r.evaluations += st.evaluations;
            return Mesh{};
          }
        };
        rr = refine_camera(mesh_for, *silhouette, r.camera, settings.refine);
      } else {
        MeshStats st;
        const Mesh m = reconstruct(full_input, r.camera, settings, refine_res, what, st, reframed);
        r.evaluations += st.evaluations;
        rr = refine_camera(m, *silhouette, r.camera, settings.refine);
      }
      r.camera = rr.camera;
      r.refinements.push_back(std::move(rr));
    }
    r.timings.refine = since(t);
  }

  MeshStats st;
  r.mesh = reconstruct(full_input, r.camera, settings, settings.resolution, what, st, reframed);
  r.photo_model = reframed && photo_sdf_ != nullptr;
  finish_result(r, st, settings, input);
  r.timings.total = since(t_all);
  return r;
}

void Reconstructor::finish_result(ReconResult& r, const MeshStats& st, const ReconSettings& settings,
                                  const Eigen::VectorXf& preview_input) const {
  r.evaluations += st.evaluations;
  r.components_removed = st.components_removed;
  r.dense = settings.dense;
  r.threshold = occupancy_threshold(settings);
  r.mirror_tta = settings.mirror_tta;
  r.timings.encode = st.encode;
  r.timings.field = st.field;
  r.timings.extract = st.extract;
  r.timings.cleanup = st.cleanup;
  if (settings.preview) {
    const auto t = Clock::now();
    r.preview = recon_preview(preview_input, r.mesh, r.camera, settings.preview_size);
    r.timings.preview = since(t);
  }
}

ReconResult Reconstructor::run_views(const std::vector<Image>& images, const std::vector<const Camera*>& cameras,
                                     const ReconSettings& settings, const std::vector<std::string>& what) const {
  require(!images.empty() && cameras.size() == images.size() && what.size() == images.size(),
          "run_views: one camera (or null) and one name per image");
  check_settings(settings, what[0]);
  if (settings.refine_rounds > 0)
    throw InvalidInput(what[0] + ": camera refinement aligns one view; it does not apply to a multi-view "
                                 "reconstruction");
  const auto t_all = Clock::now();
  ReconResult r;
  std::vector<Eigen::VectorXf> inputs(images.size());
  std::vector<FramedInput> framed(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    auto t = Clock::now();
    framed[i] = frame_input(images[i], nullptr, settings.framing, what[i]);
    inputs[i] = framed_input(images[i], framed[i], nullptr);
    if (framed[i].reframed) {
      const int fits = fit_framing(images[i], framed[i], inputs[i], cameras[i], settings, what[i],
                                   [&](const FramedInput& f) { return framed_input(images[i], f, nullptr); });
      if (i == 0) r.framing_fits = fits;  // the result's framing is the first view's
    }
    Camera cam;
    if (cameras[i] != nullptr) {
      cam = given_network_camera(*cameras[i], images[i], framed[i], what[i]);
      r.timings.prepare += since(t);
    } else {
      r.timings.prepare += since(t);
      t = Clock::now();
      double turn = 0;
      cam = estimate_network_camera(inputs[i].head(3 * kNetImageSize * kNetImageSize), settings, &turn, framed[i].reframed);
      r.timings.pose += since(t);
      if (i == 0) r.flip_turn_deg = turn;
    }
    r.view_cameras.push_back(cam);
    r.view_input_cameras.push_back(camera_in_input(cam, framed[i], images[i].width, images[i].height));
    r.view_estimated.push_back(cameras[i] == nullptr);
    r.view_photo_pose.push_back(cameras[i] == nullptr && framed[i].reframed && photo_pose_ != nullptr);
    r.view_photo_model.push_back(framed[i].reframed && photo_sdf_ != nullptr);
  }
  std::vector<ViewRef> views;
  for (size_t i = 0; i < images.size(); ++i)
    views.push_back({&inputs[i], r.view_cameras[i], &sdf_for(framed[i].reframed)});
  MeshStats st;
  r.mesh = reconstruct(views, settings, settings.resolution, what[0], st);
  r.camera = r.initial_camera = r.view_cameras[0];
  r.input_camera = r.view_input_cameras[0];
  r.camera_estimated = r.view_estimated[0];
  r.pose_mirror_tta = r.camera_estimated && settings.pose_mirror_tta;
  if (r.camera_estimated) r.pose_zoom_tta = settings.pose_zoom_tta;
  r.photo_pose = r.view_photo_pose[0];
  r.photo_model = r.view_photo_model[0];
  finish_result(r, st, settings, inputs[0]);
  r.framing = std::move(framed[0]);
  r.timings.total = since(t_all);
  return r;
}

Image recon_preview(const Eigen::VectorXf& input, const Mesh& mesh, const Camera& camera, int size) {
  require(size >= 16, "preview size must be >= 16");
  const int S = kNetImageSize, n = S * S;
  Image out(4 * size, size, 3, 1.f);
  // Panel 0: the network input (nearest-neighbour scaled).
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const int sx = std::min(S - 1, x * S / size), sy = std::min(S - 1, y * S / size);
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = std::clamp(input[c * n + sy * S + sx], 0.f, 1.f);
    }
  const MeshRenderer renderer(mesh);
  paste_rgb_on_white(renderer.render(scaled_camera(camera, size)).rgba, out, size);
  const LookAtParams la = look_at_params(camera);
  const double dist = std::clamp(la.distance, 2.0, 4.0);
  const double el = std::clamp(la.elevation_deg + 10.0, -80.0, 80.0);
  paste_rgb_on_white(renderer.render(look_at(la.azimuth_deg + 120.0, el, dist, size, size)).rgba, out, 2 * size);
  paste_rgb_on_white(renderer.render(look_at(la.azimuth_deg + 240.0, el, dist, size, size)).rgba, out, 3 * size);
  return out;
}

}  // namespace sdfkit
