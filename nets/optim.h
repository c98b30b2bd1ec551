// Optimisers over the flat parameter buffer (Adam, SGD with momentum), weight decay, learning-rate schedules,
// gradient clipping, the weights' moving average, and the (de)serialisation of optimiser state for checkpoints.
#pragma once

#include "core/files.h"
#include "core/json.h"

#include <string>
#include <utility>
#include <vector>

namespace sdfkit {

/// Learning rate as a function of the step (0-based).
///  constant: base
///  step:     base * gamma^floor(step / step_size)       (DISN: x0.9 every 200k samples = every 10k steps at 20)
///  cosine:   min + (base - min) * (1 + cos(pi * min(step, total) / total)) / 2
/// with an optional linear warm-up from 0 over the first warmup_steps steps.
struct LrSchedule {
  enum class Kind { kConstant, kStep, kCosine };
  Kind kind = Kind::kConstant;
  double base = 1e-4;
  double gamma = 0.9;
  long step_size = 10000;
  long total_steps = 100000;
  double min_lr = 0.0;
  long warmup_steps = 0;

  [[nodiscard]] double at(long step) const;
  [[nodiscard]] Json to_json() const;
  static LrSchedule from_json(const Json& j);
  /// "constant", "step", "cosine" (InvalidInput otherwise).
  static Kind parse_kind(const std::string& name);
};

struct OptimizerSettings {
  enum class Kind { kAdam, kSgd };
  Kind kind = Kind::kAdam;
  double beta1 = 0.5;  ///< Adam first-moment decay (DISN uses 0.5)
  double beta2 = 0.999;
  double eps = 1e-8;
  double momentum = 0.9;  ///< SGD
  bool nesterov = false;  ///< SGD
  /// L2 weight decay. Coupled (default, as TensorFlow's regulariser in DISN): g += wd * w before the update.
  /// Decoupled (AdamW): w -= lr * wd * w after it.
  double weight_decay = 0.0;
  bool decoupled_weight_decay = false;

  [[nodiscard]] Json to_json() const;
  static OptimizerSettings from_json(const Json& j);
  /// Adam with the given moment decays, everything else at its default (the critics' optimiser).
  static OptimizerSettings adam(double beta1, double beta2);
};

/// Named float buffers plus JSON metadata: what an optimiser (or a model) saves into a checkpoint.
struct StateBlob {
  Json meta = Json::object();
  std::vector<std::pair<std::string, std::vector<float>>> buffers;
  [[nodiscard]] const std::vector<float>* find(const std::string& name) const {
    for (const auto& b : buffers)
      if (b.first == name) return &b.second;
    return nullptr;
  }
};

/// Adam or SGD over n parameters. Element-wise updates in a fixed order: deterministic.
class Optimizer {
 public:
  Optimizer(const OptimizerSettings& settings, size_t n_params);
  /// One update of w (n values) with gradient g at learning rate lr. Increments step().
  void step(float* w, const float* g, double lr);
  void step(double* w, const double* g, double lr);
  [[nodiscard]] long steps() const { return t_; }
  [[nodiscard]] const OptimizerSettings& settings() const { return s_; }
  [[nodiscard]] size_t size() const { return n_; }

  /// Settings, step count and moment buffers (exactly; float32 state round-trips bit for bit).
  [[nodiscard]] StateBlob serialize() const;
  /// Restore from serialize(); IoError when the kind or size does not match.
  void deserialize(const StateBlob& blob);

 private:
  template <typename T>
  void step_impl(T* w, const T* g, double lr);
  OptimizerSettings s_;
  size_t n_;
  long t_ = 0;
  std::vector<float> m_, v_;  // Adam moments / SGD momentum buffer (m_)
};

/// Exponential moving average of a parameter buffer (Polyak averaging; `train pose --ema DECAY`). It starts as the
/// weights it is constructed with; update k (k = 1, 2, ...) sets a = d_k a + (1 - d_k) w with
/// d_k = min(decay, (1 + k) / (10 + k)), the warm-up of TensorFlow's ExponentialMovingAverage, so that the first
/// updates of a run from random weights are not dominated by them. Element-wise in index order: deterministic.
class WeightAverage {
 public:
  /// decay in (0, 1) (InvalidInput otherwise); w: the n starting weights.
  WeightAverage(double decay, const float* w, size_t n);
  void update(const float* w);
  /// The decay update k uses (k >= 1).
  [[nodiscard]] double decay_at(long k) const;
  [[nodiscard]] const std::vector<float>& values() const { return a_; }
  [[nodiscard]] long updates() const { return k_; }
  [[nodiscard]] double decay() const { return decay_; }
  /// Decay, update count and the average ("ema" buffer), exactly.
  [[nodiscard]] StateBlob serialize() const;
  /// Restore from serialize(); IoError when the size or the decay differs.
  void deserialize(const StateBlob& blob);

 private:
  double decay_;
  long k_ = 0;
  std::vector<float> a_;
};

/// Scale g so that its L2 norm is at most max_norm (no-op when max_norm <= 0 or the norm is smaller).
/// Returns the norm before clipping (accumulated in double, in index order). Non-finite norms zero the gradient.
double clip_grad_norm(float* g, size_t n, double max_norm);
double clip_grad_norm(double* g, size_t n, double max_norm);
/// Clamp every component into [-max_value, max_value] (no-op when max_value <= 0).
void clip_grad_value(float* g, size_t n, double max_value);

}  // namespace sdfkit
