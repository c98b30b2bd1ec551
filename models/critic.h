// The refinement paper's adversarial critic (`sdfkit refine --adversarial`): a discriminator of real against
// rendered images. Architecture (the paper's section 4.5): conv 64 k4 s2 p1 + LeakyReLU 0.2; dense block (4 layers,
// growth 32: 64 -> 192 channels); self-attention (query/key 8); dense block (192 -> 320); self-attention
// (query/key 24); conv 1 k4 p0. The last conv leaves a map of logits (one per 4 x 4 window; the paper's "single
// scalar" holds only for a 4 x 4 input): the loss is the mean binary cross-entropy over that map, as PyTorch's
// BCELoss over the map would be. Images are N x 3 x S x S in [0, 1]; the critic runs at S = settings.size.
#pragma once

#include "nets/gan_layers.h"
#include "nets/optim.h"

#include <cstdint>

namespace sdfkit {

struct CriticSettings {
  int size = 64;         ///< input side in pixels (images are resized to it)
  int stem = 64;         ///< channels of the first convolution
  int block_layers = 4;  ///< layers per dense block
  int growth = 32;       ///< channels added per dense-block layer
  int key1 = 8, key2 = 24;  ///< query/key sizes of the two self-attention layers
  double lr = 2e-4, beta1 = 0.5, beta2 = 0.999;  ///< Adam, as the paper
};

class Critic {
 public:
  Critic(const CriticSettings& settings, uint64_t seed);
  /// Logits (N x 1 x h x w) of images N x 3 x S x S (S = settings().size).
  void forward(const Tensor& images, Tensor& logits);
  /// Accumulates parameter gradients for d loss / d logits of the last forward; writes d loss / d images when
  /// dimages is not null.
  void backward(const Tensor& images, const Tensor& logits, const Tensor& dlogits, Tensor* dimages);
  /// One Adam step on the accumulated gradients, which are then cleared.
  void step();
  void zero_grad() { params_.zero_grad(); }
  [[nodiscard]] size_t n_params() const { return params_.size(); }
  [[nodiscard]] const CriticSettings& settings() const { return s_; }
  /// freeze() of every spectral convolution (gradient checks).
  void freeze(bool on);

 private:
  CriticSettings s_;
  Sequential<float> net_;
  std::vector<DenseBlock<float>*> blocks_;
  ParamStore<float> params_;
  Optimizer opt_;
};

/// Mean binary cross-entropy of all logits against one label (1 = real, 0 = rendered); its gradient in `grad`.
double critic_loss(const Tensor& logits, float label, Tensor* grad);

}  // namespace sdfkit
