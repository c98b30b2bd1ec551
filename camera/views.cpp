#include "camera/views.h"

#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/parallel.h"
#include "core/random.h"

#include <cmath>
#include <cstdio>

namespace sdfkit {

void validate_view_set_settings(const ViewSetSettings& s) {
  require(s.views >= 1 && s.views <= 10000, "view set: views must be in 1..10000");
  require(s.size >= 8 && s.size <= 8192, "view set: size must be in 8..8192 pixels");
  auto range = [](double lo, double hi, const char* name) {
    require(std::isfinite(lo) && std::isfinite(hi) && lo <= hi,
            std::string("view set: ") + name + " range must be finite with min <= max");
  };
  range(s.azimuth_min, s.azimuth_max, "azimuth");
  range(s.elevation_min, s.elevation_max, "elevation");
  range(s.distance_min, s.distance_max, "distance");
  require(s.elevation_min >= -90 && s.elevation_max <= 90, "view set: elevation must lie in [-90, 90] degrees");
  require(s.distance_min > 0, "view set: distance must be positive");
}

std::vector<Camera> view_set_cameras(const ViewSetSettings& s, uint64_t seed) {
  validate_view_set_settings(s);
  std::vector<Camera> cams;
  cams.reserve(static_cast<size_t>(s.views));
  for (int k = 0; k < s.views; ++k) {
    Rng rng = Rng::derived(seed, static_cast<uint64_t>(k));
    const double az = rng.uniform(s.azimuth_min, s.azimuth_max);
    const double el = rng.uniform(s.elevation_min, s.elevation_max);
    const double d = rng.uniform(s.distance_min, s.distance_max);
    cams.push_back(look_at(az, el, d, s.size, s.size));
  }
  return cams;
}

std::string view_name(int index, int views) {
  const int digits = views > 100 ? static_cast<int>(std::to_string(views - 1).size()) : 2;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%0*d", digits, index);
  return buf;
}

std::vector<Camera> render_view_set(const Mesh& normalized_mesh, const std::string& views_dir,
                                    const ViewSetSettings& settings, uint64_t seed) {
  const std::vector<Camera> cams = view_set_cameras(settings, seed);
  const MeshRenderer renderer(normalized_mesh, settings.render);
  const bool occlude = settings.occlusion.mode != OcclusionMode::kNone;
  // A write error names the first failing view, whatever the scheduling.
  parallel_for_ordered_errors(0, settings.views, [&](int k) {
    const std::string base = views_dir + "/" + view_name(k, settings.views);
    RenderResult r = renderer.render(cams[static_cast<size_t>(k)]);
    Json cam_json = camera_to_json(cams[static_cast<size_t>(k)]);
    if (occlude) {
      // A stream of its own, independent of the camera draws.
      const uint64_t occ_seed = Rng::derived(seed ^ 0x6f63636c75646521ULL, static_cast<uint64_t>(k)).next();
      const Image mask = apply_occlusion(r.rgba, settings.occlusion, occ_seed);
      if (!r.depth.empty())
        for (size_t i = 0; i < mask.data.size(); ++i)
          if (mask.data[i] > 0) r.depth.data[i] = 0.0f;
      for (Image* img : {&r.normals, &r.albedo})
        if (!img->empty())
          for (size_t i = 0; i < mask.data.size(); ++i)
            if (mask.data[i] > 0) img->data[3 * i] = img->data[3 * i + 1] = img->data[3 * i + 2] = 0.0f;
      write_image(base + "_mask.png", mask);
      cam_json["occlusion"] = to_string(settings.occlusion.mode);
    }
    write_image(base + ".png", r.rgba);
    if (!r.depth.empty()) write_image(base + "_depth.exr", r.depth);
    if (!r.normals.empty()) write_image(base + "_normal.exr", r.normals);
    if (!r.albedo.empty()) write_image(base + "_albedo.png", r.albedo);
    write_json(base + ".json", cam_json);
  });
  return cams;
}

}  // namespace sdfkit
