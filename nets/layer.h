// The layer interface and the flat parameter buffer (docs/nets.md, "Conventions"): a network's parameters live in
// ONE flat buffer (and its gradients in a second one of the same size); every layer is bound to a slice of it.
// Checkpoints and optimisers then see a single float vector.
//
// forward(x, y) computes y; backward(x, y, dy, dx) receives the same x and y again (the caller keeps activations),
// ADDS its parameter gradients into its gradient slice and writes dx (skipped when dx is null). The inference path
// binds no gradient buffer at all (bind(w, nullptr)). Most layers keep nothing between calls; three keep what their
// backward needs from the last forward, so each of them runs one forward/backward pair at a time:
//   - Sequential (layers.h) keeps its layers' activations in training(true) mode; forward_into / backward_from and
//     run keep nothing (the caller owns the activations);
//   - SpectralConv2d (gan_layers.h) keeps its power-iteration vectors and normalised weights (freeze(true) holds
//     them);
//   - DenseBlock (gan_layers.h) keeps its inner activations.
//
// Threading: layers parallelise over the batch (or rows) with TBB. Work is cut into chunks that depend only on
// the tensor sizes, never on the number of threads, and per-chunk parameter gradients are summed in chunk order,
// so results are bit-identical for any thread count.
#pragma once

#include "core/files.h"
#include "core/json.h"
#include "core/random.h"
#include "nets/tensor.h"

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace sdfkit {

template <typename T>
class Layer {
 public:
  virtual ~Layer() = default;
  /// Short type name ("conv2d", "linear", ...).
  [[nodiscard]] virtual std::string type() const = 0;
  /// Hyper-parameters (architecture) as JSON; includes "type".
  [[nodiscard]] virtual Json hyperparams() const = 0;
  /// Number of scalars this layer owns in the flat buffer.
  [[nodiscard]] virtual size_t n_params() const { return 0; }
  /// Fill `w` (n_params() values) with the initial parameters (Xavier/Glorot uniform weights, zero biases).
  virtual void init_params(T* w, Rng& rng) const { (void)w, (void)rng; }
  /// Point the layer at its parameter slice and gradient slice (grads may be null: inference only).
  virtual void bind(T* w, T* g) {
    w_ = w;
    g_ = g;
  }
  /// Shape of the output for an input of shape `in` (InvalidInput when the input does not fit).
  [[nodiscard]] virtual Shape output_shape(const Shape& in) const = 0;
  virtual void forward(const TensorT<T>& x, TensorT<T>& y) const = 0;
  /// Floating-point operations of forward() on an input of shape `in`, counting a multiply-add as 2 (the
  /// multiply-adds of convolutions and dense layers; element-wise work is not counted). A backward pass costs
  /// this twice when it computes dx, once when it does not. For benchmarks (`sdfkit bench train`).
  [[nodiscard]] virtual double forward_flops(const Shape& in) const {
    (void)in;
    return 0;
  }
  /// Accumulate parameter gradients (+=) and write dx = dL/dx when dx != nullptr. Requires bound gradients
  /// when the layer has parameters.
  virtual void backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const = 0;

  [[nodiscard]] const T* params() const { return w_; }
  [[nodiscard]] T* grads() const { return g_; }

 protected:
  void require_bound(bool need_grads) const;
  T* w_ = nullptr;
  T* g_ = nullptr;
};

/// Glorot/Xavier uniform: U(-a, a), a = sqrt(6 / (fan_in + fan_out)) (TensorFlow's xavier_initializer, which
/// DISN uses).
template <typename T>
void xavier_uniform(T* w, size_t n, int64_t fan_in, int64_t fan_out, Rng& rng);

/// One flat parameter buffer (and optionally a gradient buffer) shared by a set of layers, bound in the order
/// they were added. Layers must outlive the store's use; do not add layers after allocate().
template <typename T>
class ParamStore {
 public:
  /// Register a layer (its slice is placed after the previously added ones).
  void add(Layer<T>& layer) { layers_.push_back(&layer); }
  /// Allocate values (zero) and, when with_grads, gradients; bind every layer. Can be called again
  /// (e.g. to drop the gradient buffer for inference); values are kept when the size did not change.
  void allocate(bool with_grads);
  /// Initialise every layer's parameters: layer i draws from Rng::derived(seed, i).
  void init(uint64_t seed);
  void zero_grad();
  /// Make this store a replica of `master` for data-parallel training: every layer reads master's values (forward
  /// and backward never write parameters) and writes this store's own gradient buffer. `values` stays empty; the
  /// master must have the same layout and must not reallocate while the replica is in use.
  void share_values(ParamStore& master);

  [[nodiscard]] size_t size() const { return total_; }
  [[nodiscard]] bool has_grads() const { return !grads.empty(); }
  [[nodiscard]] const std::vector<Layer<T>*>& layers() const { return layers_; }
  /// Offset of layer i's slice in the buffer.
  [[nodiscard]] size_t offset(size_t i) const { return offsets_.at(i); }
  /// Architecture as a JSON array of the layers' hyperparams().
  [[nodiscard]] Json architecture() const;

  AlignedVector<T> values;
  AlignedVector<T> grads;

 private:
  void compute_offsets();
  std::vector<Layer<T>*> layers_;
  std::vector<size_t> offsets_;
  size_t total_ = 0;
};

/// [begin, end) ranges cutting n items into at most max_chunks pieces of at least min_per_chunk items; depends
/// only on its arguments (never on the thread count), which is what makes reductions deterministic.
std::vector<std::pair<int64_t, int64_t>> fixed_chunks(int64_t n, int64_t min_per_chunk, int64_t max_chunks);

/// Run fn(chunk_index, begin, end) over fixed_chunks(...) in parallel (TBB).
void parallel_chunks(const std::vector<std::pair<int64_t, int64_t>>& chunks,
                     const std::function<void(size_t, int64_t, int64_t)>& fn);
/// Run fn(i) for i in [0, n) in parallel (TBB), one task per index.
void parallel_items(int64_t n, const std::function<void(int64_t)>& fn);

}  // namespace sdfkit
