#include "nets/loss.h"

#include "gradcheck.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;
using namespace sdfkit::test;

namespace {

using LossFn = double (*)(const TensorD&, const TensorD&, TensorD*);

void check_loss_gradient(const std::function<double(const TensorD&, TensorD*)>& f, TensorD pred) {
  TensorD g;
  f(pred, &g);
  std::vector<size_t> idx;
  for (size_t i = 0; i < static_cast<size_t>(pred.size()); ++i) idx.push_back(i);
  const auto num = numeric_gradient([&] { return f(pred, nullptr); }, pred.ptr(), idx);
  CHECK(relative_error(std::vector<double>(g.data.begin(), g.data.end()), num) < 1e-6);
}

}  // namespace

TEST_CASE("L1 and L2: values and finite-difference gradients") {
  const TensorD p = random_tensor({3, 5}, 1), t = random_tensor({3, 5}, 2);
  double l1 = 0, l2 = 0;
  for (int i = 0; i < 15; ++i) {
    l1 += std::abs(p[i] - t[i]);
    l2 += (p[i] - t[i]) * (p[i] - t[i]);
  }
  CHECK(l1_loss(p, t, nullptr) == doctest::Approx(l1 / 15));
  CHECK(l2_loss(p, t, nullptr) == doctest::Approx(l2 / 15));
  check_loss_gradient([&](const TensorD& x, TensorD* g) { return l1_loss(x, t, g); }, p);
  check_loss_gradient([&](const TensorD& x, TensorD* g) { return l2_loss(x, t, g); }, p);
  TensorD bad({4});
  CHECK_THROWS_AS(l1_loss(p, bad, nullptr), InvalidInput);
}

TEST_CASE("DISN weighted SDF L1: weights 4 near/inside, 1 outside, target 10 (sdf - 0.003)") {
  TensorD sdf({4}), pred({4}, 0.0);
  sdf.data = {-0.05, 0.0, 0.013, 0.08};  // shifted labels: -0.053, -0.003, 0.010 (<= 0.01: near), 0.077
  // |0 - 10 gt| * w
  const double expected = (4 * 0.53 + 4 * 0.03 + 4 * 0.10 + 1 * 0.77) / 4;
  CHECK(sdf_weighted_l1_loss(pred, sdf, nullptr) == doctest::Approx(expected));
  // A perfect prediction has zero loss.
  TensorD perfect({4});
  for (int i = 0; i < 4; ++i) perfect[i] = 10 * (sdf[i] - 0.003);
  CHECK(sdf_weighted_l1_loss(perfect, sdf, nullptr) == doctest::Approx(0.0).epsilon(1e-12));
  const TensorD s2 = random_tensor({2, 40}, 3, -0.1, 0.1), p2 = random_tensor({2, 40}, 4);
  check_loss_gradient([&](const TensorD& x, TensorD* g) { return sdf_weighted_l1_loss(x, s2, g); }, p2);
}

TEST_CASE("BCE with logits: value, stability at large logits, gradient") {
  TensorD z({3}), y({3});
  z.data = {0.0, 2.0, -1.0};
  y.data = {1.0, 0.0, 1.0};
  const double expected = (std::log(2.0) + (2.0 + std::log1p(std::exp(-2.0))) + std::log1p(std::exp(1.0))) / 3;
  CHECK(bce_with_logits_loss(z, y, nullptr) == doctest::Approx(expected));
  TensorD big({2}), yy({2});
  big.data = {1000.0, -1000.0};
  yy.data = {0.0, 1.0};
  TensorD g;
  const double v = bce_with_logits_loss(big, yy, &g);
  CHECK(v == doctest::Approx(1000.0));
  CHECK(std::isfinite(g[0]));
  CHECK(g[0] == doctest::Approx(0.5));
  CHECK(g[1] == doctest::Approx(-0.5));
  const TensorD logits = random_tensor({5, 4}, 5, -4, 4), targets = random_tensor({5, 4}, 6, 0, 1);
  check_loss_gradient([&](const TensorD& x, TensorD* gg) { return bce_with_logits_loss(x, targets, gg); }, logits);
}
