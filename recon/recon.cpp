#include "recon/recon.h"

#include "camera/render.h"
#include "core/error.h"
#include "extract/adaptive.h"
#include "extract/cleanup.h"
#include "nets/dataset.h"
#include "nets/pose_net.h"
#include "nets/pose_train.h"
#include "nets/sdf_train.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

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

}  // namespace

Eigen::VectorXf prepare_recon_input(const Image& image, const Image* mask, const ReconSettings& settings,
                                    const std::string& what) {
  if (image.empty() || image.width <= 0 || image.height <= 0 || image.channels <= 0)
    throw InvalidInput(what + ": empty image");
  Eigen::VectorXf v;
  if (mask != nullptr) {
    if (mask->empty()) throw InvalidInput(what + ": empty mask");
    if (mask->width != image.width || mask->height != image.height)
      throw InvalidInput(what + ": mask is " + std::to_string(mask->width) + "x" + std::to_string(mask->height) +
                         " but the image is " + std::to_string(image.width) + "x" + std::to_string(image.height));
    Image rgba(image.width, image.height, 4);
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        for (int c = 0; c < 3; ++c) rgba.at(x, y, c) = image.at(x, y, image.channels >= 3 ? c : 0);
        float m = 0;  // mask luminance (or its alpha when it has one)
        if (mask->channels == 2 || mask->channels == 4)
          m = mask->at(x, y, mask->channels - 1);
        else
          m = mask->channels >= 3 ? (mask->at(x, y, 0) + mask->at(x, y, 1) + mask->at(x, y, 2)) / 3.f : mask->at(x, y, 0);
        rgba.at(x, y, 3) = std::clamp(m, 0.f, 1.f);
      }
    v = network_image(rgba);
  } else {
    v = network_image(image);
  }
  const int n = kNetImageSize * kNetImageSize;
  long foreground = 0;
  for (int i = 0; i < n; ++i) {
    float d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(v[c * n + i] - kNetBackground));
    foreground += d > 0.05f;
  }
  if (foreground < settings.min_foreground_fraction * n)
    throw InvalidInput(what + ": the image shows only background (" + std::to_string(foreground) +
                       " of " + std::to_string(n) +
                       " pixels differ from the white background after compositing the alpha/mask)");
  return v;
}

Reconstructor::Reconstructor(std::unique_ptr<SdfNet> sdf, std::unique_ptr<PoseNet> pose)
    : sdf_(std::move(sdf)), pose_(std::move(pose)) {
  require(sdf_ != nullptr, "Reconstructor: an SDF network is required");
  require(sdf_->config().image_size == kNetImageSize, "Reconstructor: the SDF network must take 137 px inputs");
}

Reconstructor::~Reconstructor() = default;

std::unique_ptr<Reconstructor> Reconstructor::load(const std::string& sdf_path, const std::string& pose_path) {
  auto sdf = load_sdf_model(sdf_path);
  std::unique_ptr<PoseNet> pose;
  if (!pose_path.empty()) pose = load_pose_model(pose_path);
  return std::make_unique<Reconstructor>(std::move(sdf), std::move(pose));
}

Camera Reconstructor::estimate_camera(const Eigen::VectorXf& input) const {
  if (!pose_) throw InvalidInput("no pose model loaded: give the camera (--cam FILE) or a pose model");
  MatrixXfR images(1, input.size());
  images.row(0) = input.transpose();
  std::lock_guard<std::mutex> lock(pose_mutex_);
  return pose_->predict(images).cameras.at(0);
}

ReconResult Reconstructor::run(const Image& image, const Image* mask, const Camera* camera,
                               const ReconSettings& settings, const std::string& what) const {
  const auto t0 = Clock::now();
  const Eigen::VectorXf input = prepare_recon_input(image, mask, settings, what);
  const double prep = since(t0);
  ReconResult r = run_input(input, camera, settings, what);
  r.timings.prepare = prep;
  r.timings.total += prep;
  return r;
}

ReconResult Reconstructor::run_input(const Eigen::VectorXf& input, const Camera* camera, const ReconSettings& settings,
                                     const std::string& what) const {
  require(input.size() == 3 * kNetImageSize * kNetImageSize, what + ": network input must be 3 x 137 x 137");
  require(settings.resolution >= 3 && settings.coarse_resolution >= 2, what + ": resolution too small");
  require(settings.dense || ((settings.resolution - 1) % (settings.coarse_resolution - 1) == 0 &&
                             power_of_two((settings.resolution - 1) / (settings.coarse_resolution - 1))),
          what + ": (resolution - 1) / (coarse resolution - 1) must be a power of two, e.g. 65, 129, 257 with 17");
  require(settings.safety >= 1.0, what + ": safety factor must be >= 1");
  ReconResult r;
  const auto t_all = Clock::now();
  auto t = Clock::now();
  if (camera != nullptr) {
    validate_camera(*camera, what + ": camera");
    r.camera = *camera;
    r.camera_estimated = false;
  } else {
    r.camera = estimate_camera(input);
    r.camera_estimated = true;
    r.timings.pose = since(t);
  }
  t = Clock::now();
  const SdfNet::ShapeCode code = sdf_->encode(input.data(), r.camera);
  r.timings.encode = since(t);

  double field_seconds = 0;
  const BatchField field = [&](const Points& p, Eigen::VectorXd& values) {
    const auto tf = Clock::now();
    sdf_->field(code, p, values);
    field_seconds += since(tf);
  };
  ExtractSettings es;
  es.resolution = settings.resolution;
  es.coarse_resolution = settings.coarse_resolution;
  es.box_min = Vec3::Constant(-settings.box_half);
  es.box_size = 2 * settings.box_half;
  es.iso = 0.0;
  es.safety = settings.safety;
  es.close_boundary = true;
  const ExtractResult ex = settings.dense ? dense_extract(field, es) : adaptive_extract(field, es);
  r.evaluations = ex.evaluations;
  r.timings.field = field_seconds;
  r.timings.extract = std::max(0.0, ex.seconds - field_seconds);
  if (ex.mesh.empty())
    throw Error(what + ": no surface found (the network predicts no inside region in the box)");

  t = Clock::now();
  CleanupSettings cs;
  cs.min_component_fraction = settings.min_component_fraction;
  CleanupReport rep;
  r.mesh = cleanup(ex.mesh, cs, &rep);
  r.components_removed = rep.components - rep.kept_components;
  r.timings.cleanup = since(t);

  if (settings.preview) {
    t = Clock::now();
    r.preview = recon_preview(input, r.mesh, r.camera, settings.preview_size);
    r.timings.preview = since(t);
  }
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
