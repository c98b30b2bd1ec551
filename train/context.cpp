#include "train/context.h"

#include "core/error.h"
#include "core/random.h"

#include <tbb/parallel_for.h>

#include <cmath>

namespace sdfkit {

Json ContextAugmentSettings::to_json() const {
  MaskErrorAugmentSettings m;  // the error's settings, as --aug-mask-error records them
  m.error = error;
  Json j = m.to_json();
  j["prob"] = prob;
  j["mask_error"] = mask_error;
  j["procedural"] = background.procedural;
  j["background_jitter"] = background.background_jitter;
  j["clutter"] = background.clutter;
  j["band"] = band;
  return j;
}

void ContextAugmentSettings::validate() const {
  require(prob >= 0 && prob <= 1, "context augmentation: the background probability must be in [0, 1]");
  require(mask_error >= 0 && mask_error <= 1, "context augmentation: the mask-error probability must be in [0, 1]");
  require(band >= 0 && band <= 1000, "context augmentation: the band must be 0..1000 pixels");
  error.validate();
  background.validate();
}

void context_images(MatrixXfR& images, MatrixXfR& masks, const ContextAugmentSettings& s,
                    const BackgroundSet* backgrounds, uint64_t seed, uint64_t stream, std::vector<char>* drawn) {
  s.validate();
  const Eigen::Index B = images.rows();
  if (drawn) drawn->assign(static_cast<size_t>(B), 0);
  const int S = B ? square_side(images.cols(), "context augmentation") : 0;
  const Eigen::Index plane = static_cast<Eigen::Index>(S) * S;
  masks.setZero(B, plane);
  // The drawn background of image b in place of its non-object pixels.
  const auto draw = [&](Eigen::Index b, const Eigen::VectorXf& object, Rng& rng) {
    std::array<float, 3> near{1, 1, 1};
    const double count = object.sum();
    if (count > 0)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (Eigen::Index i = 0; i < plane; ++i) sum += object[i] * images(b, c * plane + i);
        near[static_cast<size_t>(c)] = static_cast<float>(sum / count);
      }
    const Image back = draw_background(S, S, backgrounds, s.background, near, rng);
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const Eigen::Index i = static_cast<Eigen::Index>(y) * S + x;
        if (object[i] > 0) continue;
        for (int c = 0; c < 3; ++c) images(b, c * plane + i) = back.at(x, y, c);
      }
    if (drawn) (*drawn)[static_cast<size_t>(b)] = 1;
  };
  tbb::parallel_for(Eigen::Index(0), B, [&](Eigen::Index b) {
    Rng rng = Rng::derived(seed ^ 0xc0417e87ULL, stream + static_cast<uint64_t>(b));
    const bool err = rng.uniform() < s.mask_error;
    const bool bg = rng.uniform() < s.prob;
    const uint64_t error_seed = rng.next();
    const Eigen::VectorXf object = ink_mask(images.row(b).transpose());
    masks.row(b) = object.transpose();
    if (err) {
      Image rgba = ink_rgba(images.row(b).transpose(), S);  // its alpha is `object`
      apply_mask_error(rgba, s.error, error_seed, kNetBackground);
      for (int y = 0; y < S; ++y)
        for (int x = 0; x < S; ++x) masks(b, static_cast<Eigen::Index>(y) * S + x) = rgba.at(x, y, 3) > 0.5f ? 1.f : 0.f;
    }
    if (bg) draw(b, object, rng);
    if (s.band > 0) {
      Eigen::VectorXf rgb = images.row(b).transpose();
      keep_band(rgb, 3, masks.row(b).transpose(), s.band, kNetBackground);
      images.row(b) = rgb.transpose();
    }
  });
}

}  // namespace sdfkit
