// Layers of the adversarial critics (the refinement paper's discriminator: SAGAN-style dense blocks): batch
// normalisation, spectrally normalised convolution, and self-attention over the positions of a feature map.
// Same contract as nets/layers.h (parameters in the flat buffer, forward/backward, deterministic threading), with
// one exception stated per layer: SpectralConv2d keeps its power-iteration vector between calls.
#pragma once

#include "nets/layers.h"

#include <memory>
#include <vector>

namespace sdfkit {

// ---------------------------------------------------------------------------------------------------------------
/// Batch normalisation of N x C x H x W maps with the batch's own statistics (training mode, as a critic always
/// runs): y = gamma (x - mean_c) / sqrt(var_c + eps) + beta, mean and (biased) variance over N, H, W per channel.
/// Parameters: gamma (C, initialised to 1), then beta (C, 0).
template <typename T>
class BatchNorm2d : public Layer<T> {
 public:
  explicit BatchNorm2d(int channels, double eps = 1e-5) : channels_(channels), eps_(eps) {}
  [[nodiscard]] std::string type() const override { return "batch_norm2d"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override { return 2 * static_cast<size_t>(channels_); }
  void init_params(T* w, Rng& rng) const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;

 private:
  int channels_;
  double eps_;
};

// ---------------------------------------------------------------------------------------------------------------
/// A Conv2d whose weight matrix W (out x in*k*k) is divided by its largest singular value, estimated by one power
/// iteration per forward call (Miyato et al.; PyTorch's spectral_norm): v = W^T u / |W^T u|, u = W v / |W v|,
/// sigma = u^T W v. The gradient treats u and v as constants (d sigma / d W = u v^T). The bias is not normalised.
/// State: u persists between forward calls (seeded at init_params); freeze(true) stops its updates (evaluation, and
/// gradient checks). Not re-entrant: one forward/backward pair at a time.
template <typename T>
class SpectralConv2d : public Layer<T> {
 public:
  explicit SpectralConv2d(const Conv2dSettings& s);
  [[nodiscard]] std::string type() const override { return "spectral_conv2d"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override { return conv_.n_params(); }
  void init_params(T* w, Rng& rng) const override;
  void bind(T* w, T* g) override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override { return conv_.output_shape(in); }
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override { return conv_.forward_flops(in); }
  void freeze(bool on) { frozen_ = on; }
  /// The last forward's sigma.
  [[nodiscard]] double sigma() const { return sigma_; }

 private:
  Conv2dSettings s_;
  mutable Conv2d<T> conv_;             // bound to the normalised weights below
  mutable AlignedVector<T> w_sn_, g_sn_;
  mutable std::vector<double> u_, v_;  // power-iteration vectors (out, in*k*k)
  mutable double sigma_ = 1;
  bool frozen_ = false;
};

// ---------------------------------------------------------------------------------------------------------------
/// Self-attention over the H*W positions of N x C x H x W maps (SAGAN): queries Q = Wq x + bq and keys
/// K = Wk x + bk (key_channels each), values V = Wv x + bv (C); A = softmax over positions i of q_j . k_i;
/// o_j = sum_i A_ji v_i; y = gamma o + x. Parameters: Wq, bq, Wk, bk, Wv, bv (row-major, out x in), then gamma
/// (initialised to 0: the layer starts as the identity). Memory: one (H W)^2 attention matrix per image.
template <typename T>
class SelfAttention2d : public Layer<T> {
 public:
  SelfAttention2d(int channels, int key_channels) : c_(channels), ck_(key_channels) {}
  [[nodiscard]] std::string type() const override { return "self_attention2d"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override;
  void init_params(T* w, Rng& rng) const override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override;

 private:
  int c_, ck_;
};

// ---------------------------------------------------------------------------------------------------------------
/// A dense block (DenseNet; the refinement paper's critic): `layers` layers, each SpectralConv2d 3x3 (padding 1) +
/// BatchNorm2d + ReLU of all the features so far, adding `growth` channels: N x C x H x W -> N x (C + layers *
/// growth) x H x W, the input's channels first. Parameters: the layers' (conv, then batch norm) in order.
/// Keeps its intermediate activations between forward and backward: one forward/backward pair at a time.
template <typename T>
class DenseBlock : public Layer<T> {
 public:
  DenseBlock(int in_channels, int layers, int growth);
  [[nodiscard]] std::string type() const override { return "dense_block"; }
  [[nodiscard]] Json hyperparams() const override;
  [[nodiscard]] size_t n_params() const override;
  void init_params(T* w, Rng& rng) const override;
  void bind(T* w, T* g) override;
  [[nodiscard]] Shape output_shape(const Shape& in) const override;
  void forward(const TensorT<T>& x, TensorT<T>& y) const override;
  void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const override;
  [[nodiscard]] double forward_flops(const Shape& in) const override;
  /// freeze() of every spectral convolution (gradient checks, evaluation).
  void freeze(bool on);

 private:
  int in_, layers_, growth_;
  std::vector<std::unique_ptr<SpectralConv2d<T>>> convs_;
  std::vector<std::unique_ptr<BatchNorm2d<T>>> norms_;
  mutable std::vector<TensorT<T>> inputs_, convolved_, normed_;  // per layer, from the last forward
};

}  // namespace sdfkit
