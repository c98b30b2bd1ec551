// Bilinear sampling of feature maps at continuous pixel positions: DISN's local-feature operator.
//
//   maps N x C x H x W, positions N x P x 2 (x = column, y = row, in pixels) -> features N x P x C.
//
// Coordinates: pixel centres are at integer positions; (0, 0) is the centre of the top-left pixel. With
// `reference_width/height` set (e.g. 137 for DISN's image), positions are given in that reference image and are
// mapped onto the map by x_map = x * (W - 1) / (ref_w - 1) (corner-aligned, like resizing the map to the
// reference size with align_corners and sampling there).
//
// Border handling (as DISN: projected points are clamped to [0, 136] before sampling): a coordinate outside
// [0, W - 1] is clamped onto it; the gradient with respect to a clamped coordinate is 0.
//
// Cells: x0 = min(floor(x), W - 2), fx = x - x0 in [0, 1] (W = 1: fx = 0). So at an exactly integer position the
// result is exactly the pixel value, and the position gradient there is the one-sided derivative of the cell to
// the right (the left cell at the last pixel, x = W - 1). The map gradient is exact everywhere (the output is
// linear in the maps).
#pragma once

#include "nets/tensor.h"

namespace sdfkit {

struct BilinearSampleSettings {
  int reference_width = 0;   ///< 0: positions are in map pixels
  int reference_height = 0;  ///< 0: positions are in map pixels
};

/// features = N x P x C.
template <typename T>
void bilinear_sample(const TensorT<T>& maps, const TensorT<T>& positions, TensorT<T>& features,
                     const BilinearSampleSettings& settings = {});

/// Backward: ADDS dL/dmaps into *dmaps (resized and zeroed first when its shape differs from maps'), so several
/// samplings of the same maps accumulate; WRITES dL/dpositions into *dpositions. Either pointer may be null.
template <typename T>
void bilinear_sample_backward(const TensorT<T>& maps, const TensorT<T>& positions, const TensorT<T>& dfeatures,
                              TensorT<T>* dmaps, TensorT<T>* dpositions, const BilinearSampleSettings& settings = {});

/// Inference helper with the same cell, clamping and weights as bilinear_sample: one position (x, y) in a
/// CHANNEL-LAST map (H x W x C, C contiguous values per pixel, so the C channels of a tap are one contiguous read);
/// ADDS the sampled C values into `acc`.
template <typename T>
void bilinear_accumulate_hwc(const T* map_hwc, int64_t H, int64_t W, int64_t C, T x, T y,
                             const BilinearSampleSettings& settings, T* acc);

}  // namespace sdfkit
