#include "camera/texture.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

namespace sdfkit {

Eigen::Vector3f sample_texture(const Image& image, const Eigen::Vector2f& uv) {
  require(!image.empty() && image.channels >= 1, "sample_texture: empty image");
  const int W = image.width, H = image.height;
  if (!uv.allFinite()) return Eigen::Vector3f::Constant(0.7f);
  const double u = uv.x() - std::floor(uv.x()), v = uv.y() - std::floor(uv.y());
  // Pixel centres at (i + 0.5) / W; row 0 is the top of the image, v = 1.
  const double fx = u * W - 0.5, fy = (1.0 - v) * H - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
  Eigen::Vector3f out = Eigen::Vector3f::Zero();
  for (int dy = 0; dy <= 1; ++dy)
    for (int dx = 0; dx <= 1; ++dx) {
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      const int x = wrap(x0 + dx, W), y = wrap(y0 + dy, H);
      for (int c = 0; c < 3; ++c) {
        const int ch = image.channels >= 3 ? c : 0;
        out[c] += static_cast<float>(w * image.at(x, y, ch));
      }
    }
  return out.cwiseMax(0.f).cwiseMin(1.f);
}

TextureSampler image_texture_sampler() {
  struct Cache {
    std::mutex mutex;
    std::map<std::string, std::shared_ptr<const Image>> images;
  };
  auto cache = std::make_shared<Cache>();
  return [cache](const std::string& path, const std::vector<Eigen::Vector2f>& uv) {
    std::shared_ptr<const Image> image;
    {
      std::lock_guard<std::mutex> lock(cache->mutex);
      auto it = cache->images.find(path);
      // UV coordinates address the stored pixel grid: EXIF orientation is not applied.
      if (it == cache->images.end()) {
        auto stored = std::make_shared<const Image>(read_image(path, ImageOrientation::kAsStored));
        it = cache->images.emplace(path, std::move(stored)).first;
      }
      image = it->second;
    }
    std::vector<Eigen::Vector3f> out(uv.size());
    for (size_t i = 0; i < uv.size(); ++i) out[i] = sample_texture(*image, uv[i]);
    return out;
  };
}

}  // namespace sdfkit
