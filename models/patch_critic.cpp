#include "models/patch_critic.h"

#include "core/error.h"
#include "nets/gan_layers.h"

namespace sdfkit {

Json PatchCriticSettings::to_json() const {
  return {{"size", size}, {"in_channels", in_channels}, {"stem", stem}, {"widths", widths},
          {"lr", lr},     {"beta1", beta1},             {"beta2", beta2}};
}

int PatchCriticSettings::pools() const {
  int k = 0, s = size;
  while (s > 14 && s % 2 == 0) {
    s /= 2;
    ++k;
  }
  require(s == 14 && k <= static_cast<int>(widths.size()),
          "patch critic: the input side must be 14 * 2^k with k <= " + std::to_string(widths.size()) + " (got " +
              std::to_string(size) + ")");
  return k;
}

template <typename T>
PatchCriticT<T>::PatchCriticT(const PatchCriticSettings& s, uint64_t seed)
    : s_(s), opt_(OptimizerSettings::adam(s.beta1, s.beta2), 0) {
  const int pools = s.pools();
  require(s.in_channels >= 1 && s.stem >= 1 && !s.widths.empty(), "patch critic: channels must be positive");
  for (const int w : s.widths) require(w >= 1, "patch critic: channels must be positive");
  net_.template emplace<Conv2d<T>>(Conv2dSettings{s.in_channels, s.stem, 1, 1, 0, true});
  int c = s.stem;
  for (size_t b = 0; b < s.widths.size(); ++b) {
    const int w = s.widths[b];
    net_.template emplace<Conv2d<T>>(Conv2dSettings{c, w, 3, 1, 1, true});
    net_.add(leaky_relu<T>(0.2));
    net_.template emplace<Conv2d<T>>(Conv2dSettings{w, w, 3, 1, 1, true});
    if (b > 0) net_.template emplace<BatchNorm2d<T>>(w);
    net_.add(leaky_relu<T>(0.2));
    if (static_cast<int>(b) < pools) net_.template emplace<Pool2d<T>>(PoolKind::kMax, 2, 2);
    c = w;
  }
  net_.template emplace<Conv2d<T>>(Conv2dSettings{c, 1, 3, 1, 1, true});
  net_.training(true);
  net_.add_children_to(params_);
  params_.allocate(true);
  params_.init(seed);
  opt_ = Optimizer(OptimizerSettings::adam(s.beta1, s.beta2), params_.size());
}

template <typename T>
void PatchCriticT<T>::forward(const TensorT<T>& x, TensorT<T>& logits) {
  require(x.rank() == 4 && x.dim(1) == s_.in_channels && x.dim(2) == s_.size && x.dim(3) == s_.size,
          "patch critic: expected N x " + std::to_string(s_.in_channels) + " x " + std::to_string(s_.size) + " x " +
              std::to_string(s_.size) + " inputs, got " + shape_string(x.shape));
  net_.forward(x, logits);
}

template <typename T>
void PatchCriticT<T>::backward(const TensorT<T>& x, const TensorT<T>& logits, const TensorT<T>& dlogits,
                               TensorT<T>* dx) {
  net_.backward(x, logits, dlogits, dx);
}

template <typename T>
void PatchCriticT<T>::step() {
  opt_.step(params_.values.data(), params_.grads.data(), s_.lr);
  params_.zero_grad();
}

template class PatchCriticT<float>;
template class PatchCriticT<double>;

void put_patch_critic(Checkpoint& ck, const PatchCritic& critic, const std::string& prefix) {
  ck.header[prefix + "settings"] = critic.settings().to_json();
  ck.set_block(prefix + "params", std::vector<float>(critic.params().values.begin(), critic.params().values.end()));
  StateBlob s = critic.optimizer().serialize();
  ck.header[prefix + "optimizer"] = s.meta;
  for (auto& b : s.buffers) ck.set_block(prefix + b.first, std::move(b.second));
}

void get_patch_critic(const Checkpoint& ck, PatchCritic& critic, const std::string& prefix, const std::string& path) {
  if (!ck.header.contains(prefix + "settings") || !ck.header.contains(prefix + "optimizer"))
    throw IoError(path + ": no critic state (" + prefix + "*) in the checkpoint");
  if (ck.header.at(prefix + "settings") != critic.settings().to_json())
    throw IoError(path + ": the checkpoint's critic has other settings (" + ck.header.at(prefix + "settings").dump() +
                  ")");
  const auto& p = ck.block(prefix + "params", static_cast<long>(critic.n_params()));
  std::copy(p.begin(), p.end(), critic.params().values.begin());
  StateBlob s;
  s.meta = ck.header.at(prefix + "optimizer");
  for (const auto& b : ck.blocks)
    if (b.first.rfind(prefix + "opt_", 0) == 0) s.buffers.emplace_back(b.first.substr(prefix.size()), b.second);
  critic.optimizer().deserialize(s);
}

}  // namespace sdfkit
