// The layers: 2D convolution, dense (Linear = 1x1 shared point MLP layer), activations, pooling, bilinear resize,
// flatten, and a Sequential container; plus the multi-input operations concat and broadcast as free functions.
// Layouts: feature maps N x C x H x W; point features N x P x C; vectors N x C. See nets/layer.h for the contract
// (stateless layers, parameter slices, deterministic threading). Explicitly instantiated for float and double.
#pragma once

#include "nets/layer.h"

#include <memory>
#include <vector>

namespace sdfkit {

// ---------------------------------------------------------------------------------------------------------------
/// 2D convolution, N x Cin x H x W -> N x Cout x Ho x Wo, Ho = (H + 2 pad - k) / stride + 1 (floor), zero padding.
/// Parameters: weights Cout x (Cin * k * k) (row-major, input channel slowest, then kernel row, kernel column),
/// then Cout biases. Implemented as im2col + one Eigen GEMM per image (1x1 / stride 1 / pad 0 skips im2col).
struct Conv2dSettings {
  int in_channels = 1;
  int out_channels = 1;
  int kernel = 3;
  int stride = 1;
  int padding = 1;
  bool bias = true;
};

template <typename T>
class Conv2d : public Layer<T> {
 public:
  explicit Conv2d(const Conv2dSettings& s);
  [[nodiscard]] std::string type() const override { return "conv2d"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override;
  void init_params(T* w, Rng& rng) const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override;
  [[nodiscard]] const Conv2dSettings& settings() const { return s_; }

 private:
  Conv2dSettings s_;
};

// ---------------------------------------------------------------------------------------------------------------
/// Dense layer on the LAST dimension of any tensor: ... x in -> ... x out (y = x W^T + b). On N x P x C point
/// features this is the shared 1x1 point-MLP layer: one GEMM over all N*P rows (cut into fixed row chunks for
/// TBB). Parameters: W out x in (row-major), then out biases.
struct LinearSettings {
  int in_features = 1;
  int out_features = 1;
  bool bias = true;
};

template <typename T>
class Linear : public Layer<T> {
 public:
  explicit Linear(const LinearSettings& s);
  Linear(int in, int out, bool bias = true) : Linear(LinearSettings{in, out, bias}) {}
  [[nodiscard]] std::string type() const override { return "linear"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override;
  void init_params(T* w, Rng& rng) const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override;
  [[nodiscard]] const LinearSettings& settings() const { return s_; }

 private:
  LinearSettings s_;
};

// ---------------------------------------------------------------------------------------------------------------
/// Element-wise activation. ReLU'(0) = 0; LeakyReLU: x > 0 ? x : slope x; Sigmoid; Tanh.
enum class ActivationKind { kReLU, kLeakyReLU, kSigmoid, kTanh };

template <typename T>
class Activation : public Layer<T> {
 public:
  explicit Activation(ActivationKind kind, double slope = 0.2) : kind_(kind), slope_(slope) {}
  [[nodiscard]] std::string type() const override;
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override { return in; }
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;

 private:
  ActivationKind kind_;
  double slope_;
};

template <typename T>
std::unique_ptr<Layer<T>> relu() {
  return std::make_unique<Activation<T>>(ActivationKind::kReLU);
}
template <typename T>
std::unique_ptr<Layer<T>> leaky_relu(double slope = 0.2) {
  return std::make_unique<Activation<T>>(ActivationKind::kLeakyReLU, slope);
}

// ---------------------------------------------------------------------------------------------------------------
/// Max or average pooling over k x k windows with a stride, no padding, floor output size:
/// N x C x H x W -> N x C x ((H - k) / s + 1) x ((W - k) / s + 1). Max pooling routes the gradient to the first
/// maximum of each window (row-major order) on ties.
enum class PoolKind { kMax, kAverage };

template <typename T>
class Pool2d : public Layer<T> {
 public:
  Pool2d(PoolKind kind, int kernel, int stride) : kind_(kind), k_(kernel), s_(stride) {}
  [[nodiscard]] std::string type() const override { return kind_ == PoolKind::kMax ? "maxpool2d" : "avgpool2d"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;

 private:
  PoolKind kind_;
  int k_, s_;
};

/// Global pooling over the spatial dimensions: N x C x H x W -> N x C (average or max, first max on ties).
template <typename T>
class GlobalPool : public Layer<T> {
 public:
  explicit GlobalPool(PoolKind kind = PoolKind::kAverage) : kind_(kind) {}
  [[nodiscard]] std::string type() const override { return kind_ == PoolKind::kMax ? "globalmaxpool" : "globalavgpool"; }
  [[nodiscard]] Json hyperparams() const override { return {{"type", type()}}; }
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;

 private:
  PoolKind kind_;
};

// ---------------------------------------------------------------------------------------------------------------
/// Bilinear resize of feature maps N x C x H x W -> N x C x out_h x out_w.
///  align_corners = true: source = dst * (in - 1) / (out - 1): corner pixels map onto corner pixels, so every
///    source pixel value is reproduced exactly when upsampling by an integer factor of (in-1).
///  align_corners = false: half-pixel centres, source = (dst + 0.5) * in / out - 0.5, clamped to [0, in - 1]
///    (OpenCV INTER_LINEAR, PyTorch align_corners=False).
template <typename T>
class BilinearResize : public Layer<T> {
 public:
  BilinearResize(int out_h, int out_w, bool align_corners = true) : h_(out_h), w_out_(out_w), align_(align_corners) {}
  [[nodiscard]] std::string type() const override { return "resize_bilinear"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;

 private:
  int h_, w_out_;
  bool align_;
};

/// N x ... -> N x prod(...).
template <typename T>
class Flatten : public Layer<T> {
 public:
  [[nodiscard]] std::string type() const override { return "flatten"; }
  [[nodiscard]] Json hyperparams() const override { return {{"type", type()}}; }
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
};

// ---------------------------------------------------------------------------------------------------------------
/// A chain of layers, itself a layer (its parameters are the concatenation of its children's slices).
/// Two ways to run it:
///   - as a Layer: with training(true) forward() keeps every intermediate activation inside the object for
///     backward(); with training(false) (the default) it ping-pongs between two buffers and backward() is an error.
///     Not re-entrant: one forward/backward at a time per object (layers inside parallelise over the batch).
///   - with caller-owned activations (forward_into / backward_from / run): the object holds no state, so several
///     threads can run one chain at once, each with its own activations (the SDF network's replicas).
template <typename T>
class Sequential : public Layer<T> {
 public:
  Sequential() = default;
  Sequential& add(std::unique_ptr<Layer<T>> layer) {
    layers_.push_back(std::move(layer));
    return *this;
  }
  template <typename L, typename... Args>
  Sequential& emplace(Args&&... args) {
    return add(std::make_unique<L>(std::forward<Args>(args)...));
  }
  void training(bool on) { training_ = on; }
  [[nodiscard]] bool is_training() const { return training_; }

  [[nodiscard]] std::string type() const override { return "sequential"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override;
  void init_params(T* w, Rng& rng) const override;
  void bind(T* w, T* g) override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override;

  [[nodiscard]] size_t size() const { return layers_.size(); }
  [[nodiscard]] Layer<T>& operator[](size_t i) { return *layers_.at(i); }
  [[nodiscard]] const Layer<T>& operator[](size_t i) const { return *layers_.at(i); }
  /// Activation after layer i of the last training forward (i = size()-1 is the output).
  [[nodiscard]] const TensorT<T>& activation(size_t i) const { return acts_.at(i); }

  /// Forward keeping every activation in `acts` (acts[i] = output of layer i; resized to size()).
  void forward_into(const TensorT<T>& x, std::vector<TensorT<T>>& acts) const;
  /// The chain's output after forward_into: the last activation, or x for an empty chain.
  static const TensorT<T>& output(const TensorT<T>& x, const std::vector<TensorT<T>>& acts) {
    return acts.empty() ? x : acts.back();
  }
  /// Backward through the activations forward_into(x, acts) left (parameter gradients accumulate; dx written when
  /// not null; the first layer skips its input gradient otherwise).
  void backward_from(const TensorT<T>& x, const std::vector<TensorT<T>>& acts, const TensorT<T>& dy,
                     TensorT<T>* dx) const;
  /// Inference with local buffers: only the output is kept.
  void run(const TensorT<T>& x, TensorT<T>& y) const;
  /// The same with the caller's buffers for the inner activations (a caller that runs the chain on many blocks,
  /// e.g. the SDF network's point streams, allocates them once).
  void run(const TensorT<T>& x, TensorT<T>& y, TensorT<T>& a, TensorT<T>& b) const;
  /// Forward FLOPs on an input of shape `in`; the first layer's share in *first and the output shape in *out when
  /// not null.
  double flops(Shape in, double* first = nullptr, Shape* out = nullptr) const;
  /// Add each child (not the chain as one layer) to `store`, so that the parameter layout and the architecture
  /// list the children one by one.
  template <typename Store>
  void add_children_to(Store& store) {
    for (auto& l : layers_) store.add(*l);
  }

 private:
  std::vector<std::unique_ptr<Layer<T>>> layers_;
  bool training_ = false;
  mutable std::vector<TensorT<T>> acts_;
  mutable TensorT<T> ping_, pong_, grad_a_, grad_b_;
};

/// A shared point MLP: Linear(c0 -> c1), act, Linear(c1 -> c2), act, ...; the activation after the last layer
/// only when last_activation is true. DISN: {3, 64, 256, 512} with ReLU.
template <typename T>
std::unique_ptr<Sequential<T>> make_point_mlp(const std::vector<int>& channels, ActivationKind act = ActivationKind::kReLU,
                                              bool last_activation = true);

// ---------------------------------------------------------------------------------------------------------------
// Multi-input operations (free functions, no parameters).

/// Concatenate along `axis` (negative counts from the end); all other dimensions must match.
template <typename T>
void concat(const std::vector<const TensorT<T>*>& inputs, int axis, TensorT<T>& y);
/// Split dy back into the inputs' gradients (dxs[i] is resized to the i-th shape and overwritten; null skips).
template <typename T>
void concat_backward(const TensorT<T>& dy, const std::vector<Shape>& input_shapes, int axis,
                     const std::vector<TensorT<T>*>& dxs);

/// Repeat a per-item vector for every point: N x C -> N x P x C (DISN concatenates the global image feature to
/// every point's feature). Backward sums over the points (in point order).
template <typename T>
void broadcast_points(const TensorT<T>& x, int64_t points, TensorT<T>& y);
template <typename T>
void broadcast_points_backward(const TensorT<T>& dy, TensorT<T>& dx);

}  // namespace sdfkit
