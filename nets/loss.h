// Losses: value + gradient with respect to the prediction, in one call. Every loss is a MEAN over the elements
// (so its gradient is (per-element derivative) / count); `grad` (may be null) is resized and overwritten.
#pragma once

#include "nets/tensor.h"

namespace sdfkit {

/// mean |pred - target|; d/dpred = sign(pred - target) / n (0 at equality).
template <typename T>
double l1_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad);

/// mean (pred - target)^2; d/dpred = 2 (pred - target) / n.
template <typename T>
double l2_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad);

/// DISN's SDF loss. The network predicts scale * (sdf - offset); the label is gt = sdf - offset (DISN subtracts
/// the 0.003 iso offset from the stored SDF); loss = mean( w * |scale * gt - pred| ) with w = near_weight where
/// gt <= threshold (inside and a thin band outside the surface), 1 elsewhere.
struct SdfLossSettings {
  double scale = 10.0;
  double offset = 0.003;
  double threshold = 0.01;
  double near_weight = 4.0;
};
/// `sdf` holds the raw SDF values (same size as pred).
template <typename T>
double sdf_weighted_l1_loss(const TensorT<T>& pred, const TensorT<T>& sdf, TensorOut<T> grad,
                            const SdfLossSettings& settings = {});

/// Binary cross-entropy on logits, numerically stable: mean( max(z, 0) - z y + log(1 + exp(-|z|)) ),
/// d/dz = (sigmoid(z) - y) / n. Targets in [0, 1].
template <typename T>
double bce_with_logits_loss(const TensorT<T>& logits, const TensorT<T>& target, TensorOut<T> grad);

/// The same cross-entropy with a weight per element: mean( w (max(z, 0) - z y + log(1 + exp(-|z|))) ),
/// d/dz = w (sigmoid(z) - y) / n. Weights finite and >= 0, of the logits' size (w = 1 everywhere gives
/// bce_with_logits_loss).
template <typename T>
double weighted_bce_with_logits_loss(const TensorT<T>& logits, const TensorT<T>& target, const TensorT<T>& weight,
                                     TensorOut<T> grad);

}  // namespace sdfkit
