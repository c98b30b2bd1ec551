// The occlusion paper's patch discriminator (its Table 2), conditioned on the input image: one logit per patch of a
// 14 x 14 map, judging a render of a reconstruction stacked on the image it was reconstructed from
// (`train sdf --adversarial`). Layout for an input of C x S x S:
//   conv 1x1 C -> stem, then four blocks of [conv 3x3 p1 + LeakyReLU 0.2] x 2 with widths 16, 32, 64, 128 (batch
//   normalisation after the second convolution of blocks 2-4), each of the first log2(S / 14) blocks ending in a
//   2 x 2 max pool; conv 3x3 p1 -> 1 logit channel.
// The paper feeds 224 px (four pools). sdfkit's renders are 56 px by default (two pools) so that a soft silhouette
// of the SDF network costs a few thousand rays per image; the map stays 14 x 14. The paper names no activation: the
// LeakyReLU is PatchGAN's (pix2pix). Loss: binary cross-entropy of every logit against one label (critic_loss).
#pragma once

#include "core/json.h"
#include "nets/checkpoint.h"
#include "nets/layers.h"
#include "nets/optim.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct PatchCriticSettings {
  int size = 56;         ///< input side: 14 * 2^k, k = 0..4 (k pooling blocks)
  int in_channels = 4;   ///< RGB image + one rendered channel (the paper: RGB + RGB render = 6)
  int stem = 8;          ///< channels of the 1x1 input convolution
  std::vector<int> widths{16, 32, 64, 128};  ///< the four blocks
  double lr = 2e-4, beta1 = 0.5, beta2 = 0.999;  ///< Adam (PatchGAN's settings)

  [[nodiscard]] Json to_json() const;
  /// Number of pooling blocks (log2(size / 14)); InvalidInput when size is not 14 * 2^k with k <= widths.size().
  [[nodiscard]] int pools() const;
};

template <typename T>
class PatchCriticT {
 public:
  PatchCriticT(const PatchCriticSettings& settings, uint64_t seed);
  /// Logits N x 1 x 14 x 14 of inputs N x C x S x S.
  void forward(const TensorT<T>& x, TensorT<T>& logits);
  /// Adds parameter gradients for d loss / d logits of the last forward; writes d loss / d x when dx is not null.
  /// May be called several times after one forward (e.g. once for the generator's label, once for the critic's).
  void backward(const TensorT<T>& x, const TensorT<T>& logits, const TensorT<T>& dlogits, TensorT<T>* dx);
  /// One Adam step on the accumulated gradients, which are then cleared.
  void step();
  void zero_grad() { params_.zero_grad(); }
  [[nodiscard]] ParamStore<T>& params() { return params_; }
  [[nodiscard]] const ParamStore<T>& params() const { return params_; }
  [[nodiscard]] size_t n_params() const { return params_.size(); }
  [[nodiscard]] const PatchCriticSettings& settings() const { return s_; }
  [[nodiscard]] const Optimizer& optimizer() const { return opt_; }
  [[nodiscard]] Optimizer& optimizer() { return opt_; }

 private:
  PatchCriticSettings s_;
  Sequential<T> net_;
  ParamStore<T> params_;
  Optimizer opt_;
};

using PatchCritic = PatchCriticT<float>;

/// Store / restore a critic (settings, parameters, Adam state) in a checkpoint under blocks named prefix + "...".
/// restore: IoError naming `path` when the blocks are missing or the settings differ.
void put_patch_critic(Checkpoint& checkpoint, const PatchCritic& critic, const std::string& prefix);
void get_patch_critic(const Checkpoint& checkpoint, PatchCritic& critic, const std::string& prefix,
                      const std::string& path);

}  // namespace sdfkit
