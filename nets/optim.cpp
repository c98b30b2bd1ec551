#include "nets/optim.h"

#include "core/error.h"
#include "core/json.h"
#include "nets/denormals.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace sdfkit {

double LrSchedule::at(long step) const {
  double lr = base;
  switch (kind) {
    case Kind::kConstant: break;
    case Kind::kStep: {
      const long drops = step / std::max(1L, step_size);  // a staircase: whole steps of step_size
      lr = base * std::pow(gamma, static_cast<double>(drops));
      break;
    }
    case Kind::kCosine: {
      const double f = static_cast<double>(std::min(step, total_steps)) / static_cast<double>(std::max(1L, total_steps));
      lr = min_lr + (base - min_lr) * 0.5 * (1.0 + std::cos(M_PI * f));
      break;
    }
  }
  if (warmup_steps > 0 && step < warmup_steps) lr *= static_cast<double>(step + 1) / static_cast<double>(warmup_steps);
  return lr;
}

LrSchedule::Kind LrSchedule::parse_kind(const std::string& name) {
  if (name == "constant") return Kind::kConstant;
  if (name == "step") return Kind::kStep;
  if (name == "cosine") return Kind::kCosine;
  throw InvalidInput("unknown learning-rate schedule '" + name + "' (constant, step, cosine)");
}

Json LrSchedule::to_json() const {
  const char* names[] = {"constant", "step", "cosine"};
  return {{"kind", names[static_cast<int>(kind)]}, {"base", base},          {"gamma", gamma},
          {"step_size", step_size},                {"total_steps", total_steps}, {"min_lr", min_lr},
          {"warmup_steps", warmup_steps}};
}

LrSchedule LrSchedule::from_json(const Json& j) {
  LrSchedule s;
  s.kind = parse_kind(j.at("kind").get<std::string>());
  s.base = j.at("base").get<double>();
  s.gamma = j.at("gamma").get<double>();
  s.step_size = j.at("step_size").get<long>();
  s.total_steps = j.at("total_steps").get<long>();
  s.min_lr = j.at("min_lr").get<double>();
  s.warmup_steps = j.at("warmup_steps").get<long>();
  return s;
}

Json OptimizerSettings::to_json() const {
  return {{"kind", kind == Kind::kAdam ? "adam" : "sgd"},
          {"beta1", beta1},
          {"beta2", beta2},
          {"eps", eps},
          {"momentum", momentum},
          {"nesterov", nesterov},
          {"weight_decay", weight_decay},
          {"decoupled_weight_decay", decoupled_weight_decay}};
}

OptimizerSettings OptimizerSettings::adam(double beta1, double beta2) {
  OptimizerSettings o;
  o.kind = Kind::kAdam;
  o.beta1 = beta1;
  o.beta2 = beta2;
  return o;
}

OptimizerSettings OptimizerSettings::from_json(const Json& j) {
  OptimizerSettings s;
  const std::string k = j.at("kind").get<std::string>();
  if (k != "adam" && k != "sgd") throw IoError("optimizer kind '" + k + "' unknown");
  s.kind = k == "adam" ? Kind::kAdam : Kind::kSgd;
  s.beta1 = j.at("beta1").get<double>();
  s.beta2 = j.at("beta2").get<double>();
  s.eps = j.at("eps").get<double>();
  s.momentum = j.at("momentum").get<double>();
  s.nesterov = j.at("nesterov").get<bool>();
  s.weight_decay = j.at("weight_decay").get<double>();
  s.decoupled_weight_decay = j.at("decoupled_weight_decay").get<bool>();
  return s;
}

Optimizer::Optimizer(const OptimizerSettings& settings, size_t n_params) : s_(settings), n_(n_params) {
  require(s_.beta1 >= 0 && s_.beta1 < 1 && s_.beta2 >= 0 && s_.beta2 < 1 && s_.eps > 0,
          "optimizer: betas must lie in [0, 1) and eps must be positive");
  require(s_.weight_decay >= 0 && s_.momentum >= 0, "optimizer: weight decay and momentum must be >= 0");
  m_.assign(n_, 0.0f);
  if (s_.kind == OptimizerSettings::Kind::kAdam) v_.assign(n_, 0.0f);
}

template <typename T>
void Optimizer::step_impl(T* w, const T* g, double lr) {
  ++t_;
  const double wd = s_.weight_decay;
  const bool coupled = wd > 0 && !s_.decoupled_weight_decay;
  const bool adam = s_.kind == OptimizerSettings::Kind::kAdam;
  const double b1 = s_.beta1, b2 = s_.beta2;
  const double c1 = 1.0 - std::pow(b1, static_cast<double>(t_)), c2 = 1.0 - std::pow(b2, static_cast<double>(t_));
  const double step = lr / c1, sc2 = 1.0 / std::sqrt(c2);
  const double mu = s_.momentum;
  // Element-wise updates: each element's arithmetic is the same whichever thread runs its block, so the result does
  // not depend on the thread count. Blocks keep the update off the training step's serial path.
  constexpr size_t kBlock = size_t(1) << 14;
  const size_t blocks = (n_ + kBlock - 1) / kBlock;
  tbb::parallel_for(size_t(0), blocks, [&](size_t blk) {
    flush_denormals_on_this_thread();
    const size_t i0 = blk * kBlock, i1 = std::min(n_, i0 + kBlock);
    if (adam) {
      for (size_t i = i0; i < i1; ++i) {
        double gi = g[i];
        if (coupled) gi += wd * w[i];
        const float m = static_cast<float>(b1 * m_[i] + (1.0 - b1) * gi);
        const float v = static_cast<float>(b2 * v_[i] + (1.0 - b2) * gi * gi);
        m_[i] = m;
        v_[i] = v;
        double wi = w[i];
        if (wd > 0 && !coupled) wi -= lr * wd * wi;
        wi -= step * m / (std::sqrt(static_cast<double>(v)) * sc2 + s_.eps);
        w[i] = static_cast<T>(wi);
      }
    } else {
      for (size_t i = i0; i < i1; ++i) {
        double gi = g[i];
        if (coupled) gi += wd * w[i];
        const float b = static_cast<float>(mu * m_[i] + gi);
        m_[i] = b;
        const double d = s_.nesterov ? gi + mu * b : static_cast<double>(b);
        double wi = w[i];
        if (wd > 0 && !coupled) wi -= lr * wd * wi;
        w[i] = static_cast<T>(wi - lr * d);
      }
    }
  });
}

void Optimizer::step(float* w, const float* g, double lr) { step_impl(w, g, lr); }
void Optimizer::step(double* w, const double* g, double lr) { step_impl(w, g, lr); }

StateBlob Optimizer::serialize() const {
  StateBlob b;
  b.meta = {{"settings", s_.to_json()}, {"t", t_}, {"n", n_}};
  b.buffers.emplace_back("opt_m", m_);
  if (!v_.empty()) b.buffers.emplace_back("opt_v", v_);
  return b;
}

void Optimizer::deserialize(const StateBlob& blob) {
  try {
    const OptimizerSettings s = OptimizerSettings::from_json(blob.meta.at("settings"));
    if (s.kind != s_.kind) throw IoError("optimizer state is for a different optimizer kind");
    if (blob.meta.at("n").get<size_t>() != n_)
      throw IoError("optimizer state has " + std::to_string(blob.meta.at("n").get<size_t>()) +
                    " parameters, the model has " + std::to_string(n_));
    const auto* m = blob.find("opt_m");
    const auto* v = blob.find("opt_v");
    if (!m || m->size() != n_) throw IoError("optimizer state: first-moment buffer missing or of the wrong size");
    if (s_.kind == OptimizerSettings::Kind::kAdam && (!v || v->size() != n_))
      throw IoError("optimizer state: second-moment buffer missing or of the wrong size");
    t_ = blob.meta.at("t").get<long>();
    m_ = *m;
    if (v) v_ = *v;
  } catch (const Json::exception& e) {
    throw IoError(std::string("optimizer state: malformed (") + e.what() + ")");
  }
}

WeightAverage::WeightAverage(double decay, const float* w, size_t n) : decay_(decay), a_(w, w + n) {
  if (!(decay > 0 && decay < 1)) throw InvalidInput("weight average: the decay must be in (0, 1)");
}

double WeightAverage::decay_at(long k) const {
  return std::min(decay_, static_cast<double>(1 + k) / static_cast<double>(10 + k));
}

void WeightAverage::update(const float* w) {
  ++k_;
  const double d = decay_at(k_);
  const auto keep = static_cast<float>(d), take = static_cast<float>(1.0 - d);
  for (size_t i = 0; i < a_.size(); ++i) a_[i] = keep * a_[i] + take * w[i];
}

StateBlob WeightAverage::serialize() const {
  StateBlob b;
  b.meta = {{"decay", decay_}, {"updates", k_}, {"n", a_.size()}};
  b.buffers.emplace_back("ema", a_);
  return b;
}

void WeightAverage::deserialize(const StateBlob& blob) {
  try {
    if (blob.meta.at("decay").get<double>() != decay_)
      throw IoError("weight average state has decay " + std::to_string(blob.meta.at("decay").get<double>()) +
                    ", the run asks for " + std::to_string(decay_));
    const auto* a = blob.find("ema");
    if (!a || a->size() != a_.size()) throw IoError("weight average state: buffer missing or of the wrong size");
    k_ = blob.meta.at("updates").get<long>();
    a_ = *a;
  } catch (const Json::exception& e) {
    throw IoError(std::string("weight average state: malformed (") + e.what() + ")");
  }
}

template <typename T>
static double clip_norm_impl(T* g, size_t n, double max_norm) {
  double s = 0;
  for (size_t i = 0; i < n; ++i) s += static_cast<double>(g[i]) * static_cast<double>(g[i]);
  const double norm = std::sqrt(s);
  if (!std::isfinite(norm)) {
    std::fill(g, g + n, T(0));
    return norm;
  }
  if (max_norm > 0 && norm > max_norm) {
    const double f = max_norm / norm;
    for (size_t i = 0; i < n; ++i) g[i] = static_cast<T>(g[i] * f);
  }
  return norm;
}

double clip_grad_norm(float* g, size_t n, double max_norm) { return clip_norm_impl(g, n, max_norm); }
double clip_grad_norm(double* g, size_t n, double max_norm) { return clip_norm_impl(g, n, max_norm); }

void clip_grad_value(float* g, size_t n, double max_value) {
  if (max_value <= 0) return;
  const float m = static_cast<float>(max_value);
  for (size_t i = 0; i < n; ++i) g[i] = std::clamp(g[i], -m, m);
}

}  // namespace sdfkit
