#include "models/critic.h"

#include "nets/loss.h"

namespace sdfkit {

Critic::Critic(const CriticSettings& s, uint64_t seed) : s_(s), opt_(OptimizerSettings::adam(s.beta1, s.beta2), 0) {
  require(s.size >= 16, "critic: the input must be at least 16 px");
  Conv2dSettings stem;
  stem.in_channels = 3;
  stem.out_channels = s.stem;
  stem.kernel = 4;
  stem.stride = 2;
  stem.padding = 1;
  net_.emplace<Conv2d<float>>(stem);
  net_.add(leaky_relu<float>(0.2));
  const int c1 = s.stem + s.block_layers * s.growth, c2 = c1 + s.block_layers * s.growth;
  auto b1 = std::make_unique<DenseBlock<float>>(s.stem, s.block_layers, s.growth);
  blocks_.push_back(b1.get());
  net_.add(std::move(b1));
  net_.emplace<SelfAttention2d<float>>(c1, s.key1);
  auto b2 = std::make_unique<DenseBlock<float>>(c1, s.block_layers, s.growth);
  blocks_.push_back(b2.get());
  net_.add(std::move(b2));
  net_.emplace<SelfAttention2d<float>>(c2, s.key2);
  Conv2dSettings head;
  head.in_channels = c2;
  head.out_channels = 1;
  head.kernel = 4;
  head.padding = 0;
  net_.emplace<Conv2d<float>>(head);
  net_.training(true);
  net_.add_children_to(params_);
  params_.allocate(true);
  params_.init(seed);
  opt_ = Optimizer(OptimizerSettings::adam(s.beta1, s.beta2), params_.size());
}

void Critic::forward(const Tensor& images, Tensor& logits) {
  require(images.rank() == 4 && images.dim(1) == 3 && images.dim(2) == s_.size && images.dim(3) == s_.size,
          "critic: expected N x 3 x " + std::to_string(s_.size) + " x " + std::to_string(s_.size) + " images, got " +
              shape_string(images.shape));
  net_.forward(images, logits);
}

void Critic::backward(const Tensor& images, const Tensor& logits, const Tensor& dlogits, Tensor* dimages) {
  net_.backward(images, logits, dlogits, dimages);
}

void Critic::step() {
  opt_.step(params_.values.data(), params_.grads.data(), s_.lr);
  params_.zero_grad();
}

void Critic::freeze(bool on) {
  for (DenseBlock<float>* b : blocks_) b->freeze(on);
}

double critic_loss(const Tensor& logits, float label, Tensor* grad) {
  const Tensor target(logits.shape, label);
  return bce_with_logits_loss(logits, target, grad);
}

}  // namespace sdfkit
