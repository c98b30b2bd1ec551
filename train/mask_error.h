// Segmentation-error simulation: what an imperfect object mask does to the composite recon makes of a photograph
// (the object's pixels inside the mask on the training background). On the test composites of
// docs/results/framing.md the masks of 0.5-0.9 IoU mostly lose thin parts (chair and table legs, lamp arms, rifle
// barrels) and sometimes take in a blob of the photo beside the object; both move the object's box, which recon
// frames, and show the networks an object that is not the shape's. An image transform on an RGBA render, so that
// training (`train sdf|pose --aug-mask-error`) can show the networks such composites with the true camera and shape.
#pragma once

#include "camera/image.h"
#include "camera/mask_morphology.h"

#include <cstdint>

namespace sdfkit {

struct MaskErrorSettings {
  /// Thin parts: the object pixels (alpha > 0.5) that a morphological opening by a disc of radius r removes, r drawn
  /// uniformly in [1, thin_radius_max] (pixels); each 8-connected thin part is dropped with probability thin_drop.
  int thin_radius_max = 3;
  double thin_drop = 0.7;
  /// With probability blob_prob, one elliptic blob of textured colour is added outside the object, centred on a
  /// pixel of its outline; its semi-axes are blob_size_min-blob_size_max times the object's box's longer side.
  double blob_prob = 0.3;
  double blob_size_min = 0.05, blob_size_max = 0.2;
  /// The thin parts are kept when dropping them would leave fewer than this share of the object's pixels.
  double keep_min = 0.4;
  /// The outline (after the thin parts): with probability edge_prob it moves by one disc of radius 1 or 2 px, outward
  /// (a halo of textured colour, as a mask that takes in the photo around the object) with probability
  /// edge_halo, else inward (the outline's pixels dropped). Half of a 0.5-0.9 IoU mask's wrong pixels lie within
  /// 2 px of the true outline.
  double edge_prob = 0.5;
  double edge_halo = 0.6;
  /// An end cut off (before the thin parts): with probability cut_prob the object pixels beyond a line across one
  /// end of the object are dropped; the end (left, top, right or bottom) is drawn uniformly, the line is tilted by up
  /// to cut_tilt_deg degrees, and it lies cut_depth_min-cut_depth_max of the object's extent across it from that
  /// end. A mask that misses more of the object than it adds mostly loses a whole end of it (chair legs, a lamp's
  /// base, a barrel): on the validation busy-photo composites of docs/results/framing.md, 55-77% of such masks'
  /// missed pixels (0.5-0.9 IoU) lie outside the mask's own box, which is then 17-21% short (medians). Off (0) by
  /// default; its draws come after every other, so the other choices do not depend on it.
  double cut_prob = 0;
  double cut_depth_min = 0.05, cut_depth_max = 0.3;
  double cut_tilt_deg = 15;

  /// Throws InvalidInput naming the setting out of range.
  void validate() const;
};

struct MaskErrorResult {
  int thin_parts = 0;       ///< thin parts found (8-connected components of the opening's residue)
  int dropped_parts = 0;    ///< of them, dropped
  long dropped_pixels = 0;  ///< object pixels set to the background
  long blob_pixels = 0;     ///< background pixels that became blob
  long halo_pixels = 0;     ///< background pixels that became halo
  long eroded_pixels = 0;   ///< object pixels of the outline dropped
  long cut_pixels = 0;      ///< object pixels of the end cut off
};

/// Applies a seeded segmentation error to an RGBA image in place (4 channels; the object is alpha > 0.5): an end cut
/// off (when cut_prob > 0), thin parts, then the outline, then a blob. Dropped pixels get alpha 0 and RGB
/// `background`, halo and blob pixels alpha 1 and a colour of a random base, gradient and noise, every channel in
/// [0.02, 0.9] (never the white background). The same seed gives the same result; an image without object pixels is
/// left as it is. Throws InvalidInput on settings out of range or an image without 4 channels.
MaskErrorResult apply_mask_error(Image& rgba, const MaskErrorSettings& settings, uint64_t seed,
                                 float background = 1.0f);

}  // namespace sdfkit
