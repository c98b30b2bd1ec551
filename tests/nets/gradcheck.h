// Finite-difference gradient checking shared by the nets tests (double precision, central differences).
#pragma once

#include "core/random.h"
#include "nets/layer.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace sdfkit::test {

inline TensorD random_tensor(const Shape& shape, uint64_t seed, double lo = -1.0, double hi = 1.0) {
  TensorD t(shape);
  Rng rng(seed);
  for (auto& v : t.data) v = rng.uniform(lo, hi);
  return t;
}

inline double dot(const TensorD& a, const TensorD& b) {
  double s = 0;
  for (int64_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

/// Relative error ||a - n|| / max(||a||, ||n||, floor).
inline double relative_error(const std::vector<double>& a, const std::vector<double>& n, double floor = 1e-8) {
  double d = 0, na = 0, nn = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    d += (a[i] - n[i]) * (a[i] - n[i]);
    na += a[i] * a[i];
    nn += n[i] * n[i];
  }
  return std::sqrt(d) / std::max({std::sqrt(na), std::sqrt(nn), floor});
}

/// Central difference of scalar f with respect to the entries `idx` of the buffer v (restored afterwards); the step
/// h is taken in v's precision (a float buffer moves by float(h)).
template <typename T>
std::vector<double> numeric_gradient(const std::function<double()>& f, T* v, const std::vector<size_t>& idx,
                                     double h = 1e-6) {
  const T step = static_cast<T>(h);
  std::vector<double> g;
  for (size_t i : idx) {
    const T old = v[i];
    v[i] = old + step;
    const double fp = f();
    v[i] = old - step;
    const double fm = f();
    v[i] = old;
    g.push_back((fp - fm) / (2 * static_cast<double>(step)));
  }
  return g;
}

/// Up to `count` indices spread over [0, n).
inline std::vector<size_t> some_indices(size_t n, size_t count, uint64_t seed) {
  std::vector<size_t> idx;
  if (n <= count) {
    for (size_t i = 0; i < n; ++i) idx.push_back(i);
    return idx;
  }
  Rng rng(seed);
  for (size_t i = 0; i < count; ++i) idx.push_back(static_cast<size_t>(rng.below(n)));
  return idx;
}

/// Checks dL/dx and dL/dparams of `layer` for L = <r, layer(x)> with a random r. Returns the worst relative error.
inline double check_layer_gradients(Layer<double>& layer, const TensorD& x0, uint64_t seed = 7, size_t samples = 60) {
  ParamStore<double> store;
  store.add(layer);
  store.allocate(true);
  store.init(seed);
  // Non-zero biases so that they matter.
  Rng rng(seed + 1);
  for (auto& v : store.values) v += 0.1 * rng.uniform(-1, 1);
  TensorD x = x0, y;
  layer.forward(x, y);
  const TensorD r = random_tensor(y.shape, seed + 2);
  TensorD dx;
  store.zero_grad();
  layer.backward(x, y, r, &dx);
  auto loss = [&] {
    TensorD yy;
    layer.forward(x, yy);
    return dot(r, yy);
  };
  const auto xi = some_indices(static_cast<size_t>(x.size()), samples, seed + 3);
  std::vector<double> ax;
  for (size_t i : xi) ax.push_back(dx[static_cast<int64_t>(i)]);
  const double ex = relative_error(ax, numeric_gradient(loss, x.ptr(), xi));
  double ew = 0;
  if (store.size() > 0) {
    const auto wi = some_indices(store.size(), samples, seed + 4);
    std::vector<double> aw;
    for (size_t i : wi) aw.push_back(store.grads[i]);
    ew = relative_error(aw, numeric_gradient(loss, store.values.data(), wi));
  }
  INFO(layer.type(), " input error ", ex, " param error ", ew);
  CHECK(ex < 1e-6);
  CHECK(ew < 1e-6);
  return std::max(ex, ew);
}

}  // namespace sdfkit::test
