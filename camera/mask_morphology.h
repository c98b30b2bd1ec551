// Binary morphology of object masks by discs: erosion, dilation, opening, and what they tell about an object (its
// thin parts, the band around it). recon keeps a band of the photograph around the object (models/net_input.h
// keep_band), the segmenter's training stresses the thin parts (models/seg_net.h thin_part_weights), and the
// segmentation-error augmentation (train/mask_error.h) drops and grows them.
#pragma once

#include "camera/image.h"

#include <utility>
#include <vector>

namespace sdfkit {

/// A binary mask, row by row, 1 = inside.
using BinaryMask = std::vector<unsigned char>;

/// The offsets (dx, dy) of a disc of radius r: dx^2 + dy^2 <= r^2.
std::vector<std::pair<int, int>> disc_offsets(int r);
/// Erosion (every offset's pixel inside `m`; outside the image counts as background) or dilation (any offset's pixel
/// inside) of a W x H mask by the offsets `d`.
BinaryMask morph_mask(const BinaryMask& m, int W, int H, const std::vector<std::pair<int, int>>& d, bool erode);
/// The opening by the disc of radius r: what erosion keeps, dilated back.
BinaryMask open_mask(const BinaryMask& m, int W, int H, int r);
/// A 1-channel mask image's pixels over 0.5.
BinaryMask mask_over_half(const Image& mask);

/// The thin parts of an object mask (1 channel): its pixels over 0.5 that a morphological opening by a disc of
/// radius `radius` px removes (outside the image counts as background), as 1, every other pixel 0; the mask's size.
/// The parts apply_mask_error drops, and those `train seg --thin-weight` stresses. InvalidInput for another channel
/// count or radius < 1.
Image thin_parts(const Image& mask, int radius);

/// The pixels within `radius` px (Euclidean, between pixel centres) of a pixel of `mask` (1 channel) over 0.5, as 1,
/// every other pixel 0: the dilation by a disc of that radius; radius 0 gives the mask's pixels over 0.5. InvalidInput
/// for another channel count or a negative radius.
Image dilate_mask(const Image& mask, int radius);

}  // namespace sdfkit
