#include "nets/layer.h"

#include "core/json.h"
#include "nets/denormals.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sdfkit {

std::string shape_string(const Shape& shape) {
  std::ostringstream s;
  s << '[';
  for (size_t i = 0; i < shape.size(); ++i) s << (i ? ", " : "") << shape[i];
  s << ']';
  return s.str();
}

int64_t shape_size(const Shape& shape) {
  int64_t n = 1;
  for (const int64_t d : shape) n *= d;
  return n;
}

template <typename T>
void Layer<T>::require_bound(bool need_grads) const {
  if (n_params() == 0) return;
  require(w_ != nullptr, type() + ": parameters are not bound (add the layer to a ParamStore and allocate it)");
  require(!need_grads || g_ != nullptr,
          type() + ": backward() needs a gradient buffer (ParamStore::allocate(true)); this one is inference-only");
}

template <typename T>
void xavier_uniform(T* w, size_t n, int64_t fan_in, int64_t fan_out, Rng& rng) {
  const double a = std::sqrt(6.0 / static_cast<double>(std::max<int64_t>(1, fan_in + fan_out)));
  for (size_t i = 0; i < n; ++i) w[i] = static_cast<T>(rng.uniform(-a, a));
}

template <typename T>
void ParamStore<T>::compute_offsets() {
  offsets_.clear();
  total_ = 0;
  for (auto* l : layers_) {
    offsets_.push_back(total_);
    total_ += l->n_params();
  }
}

template <typename T>
void ParamStore<T>::share_values(ParamStore& master) {
  compute_offsets();
  require(master.values.size() == total_ && master.layers_.size() == layers_.size(),
          "ParamStore::share_values: the replica's layout differs from the master's");
  AlignedVector<T>().swap(values);
  grads.assign(total_, T(0));
  for (size_t i = 0; i < layers_.size(); ++i) layers_[i]->bind(master.values.data() + offsets_[i], grads.data() + offsets_[i]);
}

template <typename T>
void ParamStore<T>::allocate(bool with_grads) {
  compute_offsets();
  const size_t total = total_;
  if (values.size() != total) values.assign(total, T(0));
  if (with_grads)
    grads.assign(total, T(0));
  else
    AlignedVector<T>().swap(grads);
  for (size_t i = 0; i < layers_.size(); ++i)
    layers_[i]->bind(values.data() + offsets_[i], with_grads ? grads.data() + offsets_[i] : nullptr);
}

template <typename T>
void ParamStore<T>::init(uint64_t seed) {
  require(offsets_.size() == layers_.size() && values.size() == total_,
          "ParamStore::init: call allocate() first (a replica made by share_values has no values of its own)");
  for (size_t i = 0; i < layers_.size(); ++i) {
    Rng rng = Rng::derived(seed, i);
    layers_[i]->init_params(values.data() + offsets_[i], rng);
  }
}

template <typename T>
void ParamStore<T>::zero_grad() {
  std::fill(grads.begin(), grads.end(), T(0));
}

template <typename T>
Json ParamStore<T>::architecture() const {
  Json a = Json::array();
  for (auto* l : layers_) a.push_back(l->hyperparams());
  return a;
}

std::vector<std::pair<int64_t, int64_t>> fixed_chunks(int64_t n, int64_t min_per_chunk, int64_t max_chunks) {
  std::vector<std::pair<int64_t, int64_t>> out;
  if (n <= 0) return out;
  const int64_t k = std::max<int64_t>(1, std::min(max_chunks, n / std::max<int64_t>(1, min_per_chunk)));
  for (int64_t c = 0; c < k; ++c) out.emplace_back(n * c / k, n * (c + 1) / k);
  return out;
}

void parallel_chunks(const std::vector<std::pair<int64_t, int64_t>>& chunks,
                     const std::function<void(size_t, int64_t, int64_t)>& fn) {
  flush_denormals_on_this_thread();
  if (chunks.size() == 1) {
    fn(0, chunks[0].first, chunks[0].second);
    return;
  }
  tbb::parallel_for(size_t(0), chunks.size(), [&](size_t c) {
    flush_denormals_on_this_thread();
    fn(c, chunks[c].first, chunks[c].second);
  });
}

void parallel_items(int64_t n, const std::function<void(int64_t)>& fn) {
  flush_denormals_on_this_thread();
  if (n == 1) {
    fn(0);
    return;
  }
  tbb::parallel_for(int64_t(0), n, [&](int64_t i) {
    flush_denormals_on_this_thread();
    fn(i);
  });
}

template class Layer<float>;
template class Layer<double>;
template class ParamStore<float>;
template class ParamStore<double>;
template void xavier_uniform<float>(float*, size_t, int64_t, int64_t, Rng&);
template void xavier_uniform<double>(double*, size_t, int64_t, int64_t, Rng&);

}  // namespace sdfkit
