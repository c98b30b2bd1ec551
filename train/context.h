// Unmasked network inputs ("context"): the object's pixels among the photograph's, with the object's mask as a
// fourth input channel (SdfNetConfig::MaskChannel::kObject), instead of the object composited on white.
//
// recon composites a photo's object on the training background through the mask it finds, so a part the mask drops
// (a chair leg, a lamp's arm) is gone from the network's input and a blob the mask takes in becomes object. Given the
// unmasked crop and the mask as a separate channel, the network can still see what the mask lost. Training shows
// it such inputs: a render's object on a drawn background (a photo crop or a procedural one, train/seg_data.h
// draw_background), the mask channel the object's pixels, made wrong as recon's masks are wrong
// (train/mask_error.h) while the pixels stay the true ones.
#pragma once

#include "core/files.h"
#include "core/json.h"
#include "models/net_input.h"
#include "train/dataset.h"
#include "train/mask_error.h"
#include "train/seg_data.h"

#include <Eigen/Core>
#include <cstdint>

namespace sdfkit {

/// `train sdf --object-channel` with `--aug-context P --context-mask-error Q`. Every image's mask channel is its
/// object's mask (its non-white pixels, train/dataset.h ink_mask); then, each drawn from Rng::derived(seed, stream + b) only:
///   - with probability `mask_error` the mask gets a segmentation error (train/mask_error.h on the mask alone:
///     thin parts dropped, the outline moved, a blob added; the pixels keep the object and the background);
///   - with probability `prob` the image's white background (every non-object pixel) becomes a background drawn as
///     the segmenter's composites draw theirs (train/seg_data.h: a jittered crop of a photo of the background set,
///     or a procedural background, with clutter when background.clutter > 0); otherwise it stays white;
///   - with band > 0, the pixels farther than `band` from the mask channel's object become white (keep_band), as
///     recon shows such a network the photo (recon/framing.h context_input).
struct ContextAugmentSettings {
  double prob = 0;        ///< probability of a drawn background, [0, 1]
  double mask_error = 0;  ///< probability of a segmentation error in the mask channel, [0, 1]
  MaskErrorSettings error;
  SegCompositeSettings background;  ///< procedural share, jitters and clutter of the drawn backgrounds (size unused)
  /// Last, the pixels farther than `band` pixels from the mask channel's object become white (keep_band); 0 = none.
  int band = 0;

  [[nodiscard]] Json to_json() const;
  /// Throws InvalidInput naming the setting out of range.
  void validate() const;
};


/// Apply ContextAugmentSettings to B x (3 * S * S) rows in place (white backgrounds, the object being the non-white
/// pixels); `masks` becomes B x (S * S), the mask channel of each image. `backgrounds` may be null or empty
/// (procedural backgrounds only). `drawn` (optional) marks the images whose background was drawn. Throws
/// InvalidInput on settings out of range or rows that are not 3 square channels.
void context_images(MatrixXfR& images, MatrixXfR& masks, const ContextAugmentSettings& settings,
                    const BackgroundSet* backgrounds, uint64_t seed, uint64_t stream,
                    std::vector<char>* drawn = nullptr);

}  // namespace sdfkit
