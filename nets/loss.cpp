#include "nets/loss.h"

#include <cmath>

namespace sdfkit {
namespace {

template <typename T>
void check_pair(const TensorT<T>& a, const TensorT<T>& b, const char* what) {
  require(a.size() == b.size() && a.size() > 0, std::string(what) + ": prediction " + shape_string(a.shape) +
                                                     " and target " + shape_string(b.shape) +
                                                     " must be non-empty and of equal size");
}

template <typename T>
void prepare_grad(const TensorT<T>& pred, TensorOut<T> grad) {
  if (grad) grad->resize(pred.shape);
}

}  // namespace

template <typename T>
double l1_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad) {
  check_pair(pred, target, "l1_loss");
  prepare_grad(pred, grad);
  const double inv = 1.0 / static_cast<double>(pred.size());
  double s = 0;
  for (int64_t i = 0; i < pred.size(); ++i) {
    const double d = static_cast<double>(pred[i]) - static_cast<double>(target[i]);
    s += std::abs(d);
    if (grad) (*grad)[i] = static_cast<T>((d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0) * inv);
  }
  return s * inv;
}

template <typename T>
double l2_loss(const TensorT<T>& pred, const TensorT<T>& target, TensorOut<T> grad) {
  check_pair(pred, target, "l2_loss");
  prepare_grad(pred, grad);
  const double inv = 1.0 / static_cast<double>(pred.size());
  double s = 0;
  for (int64_t i = 0; i < pred.size(); ++i) {
    const double d = static_cast<double>(pred[i]) - static_cast<double>(target[i]);
    s += d * d;
    if (grad) (*grad)[i] = static_cast<T>(2.0 * d * inv);
  }
  return s * inv;
}

template <typename T>
double sdf_weighted_l1_loss(const TensorT<T>& pred, const TensorT<T>& sdf, TensorOut<T> grad,
                            const SdfLossSettings& st) {
  check_pair(pred, sdf, "sdf_weighted_l1_loss");
  prepare_grad(pred, grad);
  const double inv = 1.0 / static_cast<double>(pred.size());
  double s = 0;
  for (int64_t i = 0; i < pred.size(); ++i) {
    const double gt = static_cast<double>(sdf[i]) - st.offset;
    const double w = gt <= st.threshold ? st.near_weight : 1.0;
    const double d = static_cast<double>(pred[i]) - st.scale * gt;
    s += w * std::abs(d);
    if (grad) (*grad)[i] = static_cast<T>(w * (d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0) * inv);
  }
  return s * inv;
}

template <typename T>
double bce_with_logits_loss(const TensorT<T>& logits, const TensorT<T>& target, TensorOut<T> grad) {
  check_pair(logits, target, "bce_with_logits_loss");
  prepare_grad(logits, grad);
  const double inv = 1.0 / static_cast<double>(logits.size());
  double s = 0;
  for (int64_t i = 0; i < logits.size(); ++i) {
    const double z = logits[i], y = target[i];
    require(y >= 0.0 && y <= 1.0, "bce_with_logits_loss: targets must lie in [0, 1]");
    s += std::max(z, 0.0) - z * y + std::log1p(std::exp(-std::abs(z)));
    const double sig = z >= 0 ? 1.0 / (1.0 + std::exp(-z)) : std::exp(z) / (1.0 + std::exp(z));
    if (grad) (*grad)[i] = static_cast<T>((sig - y) * inv);
  }
  return s * inv;
}

#define SDFKIT_LOSS_INSTANTIATE(T)                                                                         \
  template double l1_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);                           \
  template double l2_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);                           \
  template double sdf_weighted_l1_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>,               \
                                          const SdfLossSettings&);                                         \
  template double bce_with_logits_loss<T>(const TensorT<T>&, const TensorT<T>&, TensorOut<T>);
SDFKIT_LOSS_INSTANTIATE(float)
SDFKIT_LOSS_INSTANTIATE(double)

}  // namespace sdfkit
