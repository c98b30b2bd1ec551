// Occlusion masks (the occlusion paper's protocol): remove the left or right half of the object's image, or
// random rectangles. An image transform that returns the mask it applied, so evaluation can tell occluded from
// clean inputs.
#pragma once

#include "camera/image.h"

#include <cstdint>
#include <string>

namespace sdfkit {

enum class OcclusionMode { kNone, kLeft, kRight, kRect };

/// "none" | "left" | "right" | "rect"; InvalidInput otherwise.
OcclusionMode parse_occlusion_mode(const std::string& name);
std::string to_string(OcclusionMode mode);

struct OcclusionSettings {
  OcclusionMode mode = OcclusionMode::kNone;
  /// left/right: split at the centre column of the object's alpha bounding box (true) or at the image centre
  /// (false: the occlusion paper zeroes an image half; with look-at renders both are close).
  bool split_at_object = true;
  /// rect: number of rectangles and their side range as fractions of the image side.
  int rectangles = 1;
  double min_size = 0.25, max_size = 0.5;
  /// rect: centre the rectangles on the object's alpha bounding box (true) or anywhere in the image (false).
  bool rects_on_object = true;
};

/// Applies the occlusion to `image` in place (every channel, RGB and alpha, set to 0 where removed) and
/// returns the mask: 1 channel, 1 = removed, 0 = kept. `seed` drives the random rectangles only. Without an
/// alpha channel (1 or 3 channels) the "object" is the whole image. mode none returns an all-zero mask.
Image apply_occlusion(Image& image, const OcclusionSettings& settings, uint64_t seed);

}  // namespace sdfkit
