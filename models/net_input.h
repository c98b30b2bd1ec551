// The networks' input format, shared by training (train/) and inference (recon/): what an image becomes before a
// network sees it, and the operations on such network images that both sides apply (zoom, framing by the object's
// box, the missing-data and object-mask channels).
//
// Network input convention (see network_image()):
//   RGB float in [0, 1], channels-first (C x H x W = 3 x 137 x 137, flattened row by row), alpha composited on a
//   white background (kNetBackground), resized to 137 x 137 by area averaging / bilinear interpolation.
#pragma once

#include "camera/image.h"

#include <Eigen/Core>
#include <algorithm>

namespace sdfkit {

/// Side of the square network input image (DISN's renders are 137 x 137).
inline constexpr int kNetImageSize = 137;
/// Background the network sees where the input is transparent (alpha 0): white.
inline constexpr float kNetBackground = 1.0f;
/// How far from the white background (in some channel) a pixel must be to count as the object's: the one rule
/// behind the zoom augmentation's limit, recon's foreground masks and its framing checks.
inline constexpr float kInkThreshold = 0.05f;
/// True when (r, g, b) differs from kNetBackground by more than kInkThreshold in some channel.
inline bool is_ink(float r, float g, float b) {
  return std::min({r, g, b}) < kNetBackground - kInkThreshold || std::max({r, g, b}) > kNetBackground + kInkThreshold;
}

/// Convert any image (1-4 channels, any size) to the network input: RGB in [0,1], alpha composited on
/// kNetBackground, resized to size x size, channels-first (3 * size * size floats). A grey image is replicated to
/// RGB; a grey+alpha image is composited. Throws InvalidInput on an empty image.
Eigen::VectorXf network_image(const Image& image, int size = kNetImageSize);

/// The input of a network with `channels` input channels (3 or 4) from a 3 * S * S RGB network image and its S * S
/// missing-data mask (null = nothing missing). channels 3 drops the mask (its pixels are already white); 4 appends it.
Eigen::VectorXf network_input(const Eigen::Ref<const Eigen::VectorXf>& rgb, const Eigen::VectorXf* mask, int channels);

/// One image (3 * S * S channels-first values, white background) magnified by k about its centre as
/// zoom_images does, without the limit that keeps the object inside.
Eigen::VectorXf zoom_image(const Eigen::Ref<const Eigen::VectorXf>& image, int size, double k);

/// Where a pixel coordinate `p` of an image lands when the image is magnified by k about `centre` (one axis):
/// k p + (1 - k) centre. zoom_images moves the principal point of a kFocal camera so; PoseNet's zoom TTA maps a
/// reading of the magnified image back with unmagnified_coordinate.
inline double magnified_coordinate(double p, double centre, double k) { return k * p + (1 - k) * centre; }
/// The inverse of magnified_coordinate: centre + (p - centre) / k.
inline double unmagnified_coordinate(double p, double centre, double k) { return centre + (p - centre) / k; }

/// The largest magnification that keeps the image's non-white pixels (any channel below 1 - 0.05) at least one
/// pixel inside its border; +infinity for an all-white image.
double max_zoom_inside(const Eigen::Ref<const Eigen::VectorXf>& image, int size);

/// Box of an image's object (its is_ink pixels) in pixel-edge coordinates (pixel x spans [x, x + 1)).
struct InkBox {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty = true;  ///< no object pixel (all-white image)
};
/// The box of the is_ink pixels of one image (3 * S * S channels-first values).
InkBox ink_box(const Eigen::Ref<const Eigen::VectorXf>& image, int size);

/// The object mask of one network image (3 * S * S channels-first, white background): 1 where is_ink, else 0 (S * S).
Eigen::VectorXf ink_mask(const Eigen::Ref<const Eigen::VectorXf>& image);

/// RGBA view of one network image (3 * S * S channels-first, white background): its colours, alpha 1 on its object
/// (the is_ink pixels) and 0 elsewhere.
Image ink_rgba(const Eigen::Ref<const Eigen::VectorXf>& image, int size);

/// Side S of B x (3 * S * S) channels-first rows; InvalidInput naming `what` otherwise.
int square_side(Eigen::Index values, const char* what);

/// One image (3 * S * S channels-first values, white background) mapped by the similarity q -> d + k (q - m)
/// (pixel-edge coordinates, image y down): source point m lands on d, magnified by k. Bilinear, 2 x 2 samples per
/// pixel when shrinking, white outside the source; zoom_image is the case m = d = the image centre.
Eigen::VectorXf resample_similarity(const Eigen::Ref<const Eigen::VectorXf>& image, int size, double k, double mx,
                                    double my, double dx, double dy);

/// The band of SdfNetConfig::context_band: every pixel of an S x S channels-first image (`channels` planes) farther
/// than `band` pixels (Euclidean, between pixel centres) from each pixel of `mask` (S x S) over 0.5 becomes
/// `background`. band 0 keeps the image as it is. InvalidInput when the sizes disagree.
void keep_band(Eigen::Ref<Eigen::VectorXf> image, int channels, const Eigen::Ref<const Eigen::VectorXf>& mask, int band,
               float background);


/// Object framing of the training renders (DISN's 137 px renders of objects in the unit sphere, camera 2.45-3.0
/// radii away, elevation 25-30 degrees), measured over the 24,960 views of the 1040 training shapes of
/// `scripts/build_benchmark --preset full` (docs/recon.md, "Input and framing"; recon/framing.h frames real inputs so): the object's box has a longer side
/// of 0.27 / 0.42 / 0.67 / 0.82 / 0.97 of the image (minimum / 5th / 50th / 95th percentile / maximum); its centre
/// lies dx = 0.00 (-0.14..0.15) and dy = +0.03 (-0.20..0.17) image sides from the image centre (median, range).
/// An image is "framed like the renders" (kept as it is by Reframing::kAuto) within these ranges plus a margin.
struct TrainingFraming {
  double extent = 0.67;            ///< median longer side of the object's box / image side
  double extent_min = 0.25;        ///< smallest object size kept as it is (the renders' minimum - 0.02)
  double extent_max = 1.0;         ///< largest
  double centre_dx = 0.0;          ///< median box centre - image centre, in image sides (x right)
  double centre_dy = 0.033;        ///< same, y down
  double centre_tolerance = 0.25;  ///< largest distance of the box centre from the median kept as it is
};

}  // namespace sdfkit
