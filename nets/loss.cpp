#include "nets/loss.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace sdfkit {
namespace {

/// Mean over the elements of f(pred[i], target[i]) = {value, d value / d pred[i]}, and its gradient (the
/// derivatives divided by the element count) in `grad` when given. Sizes must match and not be zero.
template <typename T, typename F>
double mean_elementwise(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad, const char* what, F f) {
  require(pred.size() == target.size() && pred.size() > 0,
          std::string(what) + ": prediction " + shape_string(pred.shape) + " and target " +
              shape_string(target.shape) + " must be non-empty and of equal size");
  if (grad) grad->resize(pred.shape);
  const double inv = 1.0 / static_cast<double>(pred.size());
  double s = 0;
  for (int64_t i = 0; i < pred.size(); ++i) {
    const auto [value, derivative] = f(static_cast<double>(pred[i]), static_cast<double>(target[i]));
    s += value;
    if (grad) (*grad)[i] = static_cast<T>(derivative * inv);
  }
  return s * inv;
}

double sign_of(double d) { return d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0; }

}  // namespace

template <typename T>
double l1_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad) {
  return mean_elementwise(pred, target, grad, "l1_loss", [](double p, double t) {
    const double d = p - t;
    return std::pair(std::abs(d), sign_of(d));
  });
}

template <typename T>
double l2_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad) {
  return mean_elementwise(pred, target, grad, "l2_loss", [](double p, double t) {
    const double d = p - t;
    return std::pair(d * d, 2.0 * d);
  });
}

template <typename T>
double sdf_weighted_l1_loss(const TensorT<T>& pred, const TensorT<T>& sdf, TensorOut<T> grad,
                            const SdfLossSettings& st) {
  return mean_elementwise(pred, sdf, grad, "sdf_weighted_l1_loss", [&](double p, double sdf_value) {
    const double gt = sdf_value - st.offset;
    const double w = gt <= st.threshold ? st.near_weight : 1.0;
    const double d = p - st.scale * gt;
    return std::pair(w * std::abs(d), w * sign_of(d));
  });
}

template <typename T>
double bce_with_logits_loss(const TensorT<T>& logits, const TensorT<T>& target, TensorOut<T> grad) {
  return mean_elementwise(logits, target, grad, "bce_with_logits_loss", [](double z, double y) {
    require(y >= 0.0 && y <= 1.0, "bce_with_logits_loss: targets must lie in [0, 1]");
    const double sig = z >= 0 ? 1.0 / (1.0 + std::exp(-z)) : std::exp(z) / (1.0 + std::exp(z));
    return std::pair(std::max(z, 0.0) - z * y + std::log1p(std::exp(-std::abs(z))), sig - y);
  });
}

template <typename T>
double weighted_bce_with_logits_loss(const TensorT<T>& logits, const TensorT<T>& target, const TensorT<T>& weight,
                                     TensorOut<T> grad) {
  require(logits.size() == target.size() && logits.size() == weight.size() && logits.size() > 0,
          "weighted_bce_with_logits_loss: logits " + shape_string(logits.shape) + ", targets " +
              shape_string(target.shape) + " and weights " + shape_string(weight.shape) +
              " must be non-empty and of equal size");
  if (grad) grad->resize(logits.shape);
  const double inv = 1.0 / static_cast<double>(logits.size());
  double s = 0;
  for (int64_t i = 0; i < logits.size(); ++i) {
    const double z = static_cast<double>(logits[i]), y = static_cast<double>(target[i]);
    const double w = static_cast<double>(weight[i]);
    require(y >= 0.0 && y <= 1.0, "weighted_bce_with_logits_loss: targets must lie in [0, 1]");
    require(w >= 0.0 && std::isfinite(w), "weighted_bce_with_logits_loss: weights must be finite and >= 0");
    const double sig = z >= 0 ? 1.0 / (1.0 + std::exp(-z)) : std::exp(z) / (1.0 + std::exp(z));
    s += w * (std::max(z, 0.0) - z * y + std::log1p(std::exp(-std::abs(z))));
    if (grad) (*grad)[i] = static_cast<T>(w * (sig - y) * inv);
  }
  return s * inv;
}

#define SDFKIT_LOSS_INSTANTIATE(T)                                                                         \
  template double l1_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);                           \
  template double l2_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);                           \
  template double sdf_weighted_l1_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>,               \
                                          const SdfLossSettings&);                                         \
  template double bce_with_logits_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);             \
  template double weighted_bce_with_logits_loss<T>(const TensorT<T>&, const TensorT<T>&, const TensorT<T>&, \
                                                   TensorOut<T>);
SDFKIT_LOSS_INSTANTIATE(float)
SDFKIT_LOSS_INSTANTIATE(double)

}  // namespace sdfkit
