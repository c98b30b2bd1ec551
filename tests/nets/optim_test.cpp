#include "nets/optim.h"

#include "core/error.h"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using namespace sdfkit;

TEST_CASE("Adam: first step matches the closed form, minimises a quadratic") {
  OptimizerSettings s;  // beta1 0.5 (DISN)
  Optimizer opt(s, 2);
  std::vector<double> w = {1.0, -2.0}, g = {0.3, -4.0};
  opt.step(w.data(), g.data(), 0.1);
  // After one step mhat = g, vhat = g^2: w -= lr * g / (|g| + eps) = lr * sign(g).
  CHECK(w[0] == doctest::Approx(0.9));
  CHECK(w[1] == doctest::Approx(-1.9));
  // f(w) = sum c_i (w_i - t_i)^2
  const double c[2] = {1.0, 10.0}, t[2] = {3.0, -1.0};
  for (int k = 0; k < 2000; ++k) {
    for (int i = 0; i < 2; ++i) g[i] = 2 * c[i] * (w[i] - t[i]);
    opt.step(w.data(), g.data(), 0.02);
  }
  CHECK(w[0] == doctest::Approx(3.0).epsilon(1e-3));
  CHECK(w[1] == doctest::Approx(-1.0).epsilon(1e-3));
  CHECK(opt.steps() == 2001);
}

TEST_CASE("SGD with momentum and weight decay: closed forms") {
  OptimizerSettings s;
  s.kind = OptimizerSettings::Kind::kSgd;
  s.momentum = 0.9;
  s.weight_decay = 0.1;
  Optimizer opt(s, 1);
  double w = 2.0, g = 1.0;
  opt.step(&w, &g, 0.5);  // g' = 1 + 0.2 = 1.2, buf = 1.2, w = 2 - 0.6
  CHECK(w == doctest::Approx(1.4));
  opt.step(&w, &g, 0.5);  // g' = 1 + 0.14 = 1.14, buf = 1.08 + 1.14 = 2.22, w = 1.4 - 1.11
  CHECK(w == doctest::Approx(0.29));
  // Decoupled decay: w -= lr wd w, then the plain update.
  s.decoupled_weight_decay = true;
  s.momentum = 0;
  Optimizer d(s, 1);
  double w2 = 2.0, g2 = 0.0;
  d.step(&w2, &g2, 0.5);
  CHECK(w2 == doctest::Approx(2.0 - 0.5 * 0.1 * 2.0));
}

TEST_CASE("learning-rate schedules") {
  LrSchedule s;
  s.base = 1.0;
  CHECK(s.at(12345) == 1.0);
  s.kind = LrSchedule::Kind::kStep;
  s.gamma = 0.9;
  s.step_size = 10;
  CHECK(s.at(9) == doctest::Approx(1.0));
  CHECK(s.at(10) == doctest::Approx(0.9));
  CHECK(s.at(25) == doctest::Approx(0.81));
  s.kind = LrSchedule::Kind::kCosine;
  s.total_steps = 100;
  s.min_lr = 0.1;
  CHECK(s.at(0) == doctest::Approx(1.0));
  CHECK(s.at(50) == doctest::Approx(0.55));
  CHECK(s.at(100) == doctest::Approx(0.1));
  CHECK(s.at(500) == doctest::Approx(0.1));
  s.warmup_steps = 4;
  CHECK(s.at(0) == doctest::Approx(0.25));
  const LrSchedule r = LrSchedule::from_json(s.to_json());
  for (long k : {0L, 3L, 40L, 99L}) CHECK(r.at(k) == s.at(k));
  CHECK_THROWS_AS(LrSchedule::parse_kind("linear"), InvalidInput);
}

TEST_CASE("gradient clipping") {
  std::vector<float> g = {3.0f, 4.0f};
  CHECK(clip_grad_norm(g.data(), 2, 1.0) == doctest::Approx(5.0));
  CHECK(g[0] == doctest::Approx(0.6));
  CHECK(g[1] == doctest::Approx(0.8));
  CHECK(clip_grad_norm(g.data(), 2, 10.0) == doctest::Approx(1.0));
  CHECK(g[0] == doctest::Approx(0.6));  // unchanged below the threshold
  std::vector<float> bad = {1.0f, NAN};
  clip_grad_norm(bad.data(), 2, 1.0);
  CHECK(bad[0] == 0.0f);
  CHECK(bad[1] == 0.0f);
  std::vector<float> v = {-5, 0.5, 5};
  clip_grad_value(v.data(), 3, 1.0);
  CHECK(v == std::vector<float>{-1, 0.5, 1});
}

TEST_CASE("optimizer state round trip continues identically") {
  OptimizerSettings s;
  Optimizer a(s, 3);
  std::vector<float> w = {0.1f, 0.2f, -0.3f}, g = {0.5f, -0.25f, 1.0f};
  for (int k = 0; k < 5; ++k) a.step(w.data(), g.data(), 1e-2);
  Optimizer b(s, 3);
  b.deserialize(a.serialize());
  std::vector<float> wa = w, wb = w;
  for (int k = 0; k < 5; ++k) {
    g[0] = 0.1f * k;
    a.step(wa.data(), g.data(), 1e-2);
    b.step(wb.data(), g.data(), 1e-2);
  }
  CHECK(wa == wb);
  CHECK(b.steps() == 10);
  Optimizer wrong(s, 4);
  CHECK_THROWS_AS(wrong.deserialize(a.serialize()), IoError);
  OptimizerSettings sgd;
  sgd.kind = OptimizerSettings::Kind::kSgd;
  Optimizer other(sgd, 3);
  CHECK_THROWS_AS(other.deserialize(a.serialize()), IoError);
}

#include "nets/layers.h"
#include "nets/loss.h"

TEST_CASE("weight average: warm-up decay, the closed form of a step input, state round trip") {
  // The warm-up: d_k = min(decay, (1 + k) / (10 + k)).
  const std::vector<float> zero = {0.f, 0.f}, one = {1.f, 1.f};
  WeightAverage a(0.5, zero.data(), 2);
  CHECK(a.decay_at(1) == doctest::Approx(2.0 / 11.0));
  CHECK(a.decay_at(7) == doctest::Approx(8.0 / 17.0));
  CHECK(a.decay_at(8) == doctest::Approx(0.5));  // 9 / 18 reaches the decay
  CHECK(a.decay_at(1000) == doctest::Approx(0.5));
  // From 0, the input held at 1: a_k = 1 - prod_{j <= k} d_j.
  double prod = 1;
  for (long k = 1; k <= 20; ++k) {
    a.update(one.data());
    prod *= a.decay_at(k);
    CHECK(a.values()[0] == doctest::Approx(1.0 - prod).epsilon(1e-6));
    CHECK(a.values()[1] == a.values()[0]);
  }
  CHECK(a.updates() == 20);
  // A constant input stays where it is.
  const std::vector<float> c = {0.25f, -3.f};
  WeightAverage b(0.999, c.data(), 2);
  for (int k = 0; k < 50; ++k) b.update(c.data());
  CHECK(b.values()[0] == doctest::Approx(0.25));
  CHECK(b.values()[1] == doctest::Approx(-3.0));
  // State round trip continues identically; another decay or size is refused.
  WeightAverage r(0.5, zero.data(), 2);
  r.deserialize(a.serialize());
  a.update(c.data());
  r.update(c.data());
  CHECK(r.values() == a.values());
  CHECK(r.updates() == 21);
  WeightAverage other(0.9, zero.data(), 2);
  CHECK_THROWS_AS(other.deserialize(a.serialize()), IoError);
  const std::vector<float> three = {0.f, 0.f, 0.f};
  WeightAverage bigger(0.5, three.data(), 3);
  CHECK_THROWS_AS(bigger.deserialize(a.serialize()), IoError);
  CHECK_THROWS_AS(WeightAverage(1.0, zero.data(), 2), InvalidInput);
  CHECK_THROWS_AS(WeightAverage(0.0, zero.data(), 2), InvalidInput);
}

TEST_CASE("a tiny conv + point-MLP network overfits a tiny batch to near-zero loss") {
  Rng rng(3);
  Sequential<float> net;
  net.emplace<Conv2d<float>>(Conv2dSettings{2, 8, 3, 2, 1, true});
  net.add(relu<float>());
  net.emplace<Conv2d<float>>(Conv2dSettings{8, 8, 3, 1, 1, true});
  net.add(leaky_relu<float>(0.1));
  net.emplace<GlobalPool<float>>(PoolKind::kAverage);
  net.emplace<Linear<float>>(8, 16);
  net.add(relu<float>());
  net.emplace<Linear<float>>(16, 3);
  net.training(true);
  ParamStore<float> store;
  store.add(net);
  store.allocate(true);
  store.init(1);
  Tensor x({4, 2, 8, 8}), target({4, 3});
  for (auto& v : x.data) v = static_cast<float>(rng.uniform(-1, 1));
  for (auto& v : target.data) v = static_cast<float>(rng.uniform(-1, 1));
  OptimizerSettings s;
  s.beta1 = 0.9;
  Optimizer opt(s, store.size());
  Tensor y, dy;
  double first = 0, last = 0;
  for (int step = 0; step < 1500; ++step) {
    net.forward(x, y);
    const double loss = l2_loss(y, target, &dy);
    if (step == 0) first = loss;
    last = loss;
    store.zero_grad();
    net.backward(x, y, dy, nullptr);
    opt.step(store.values.data(), store.grads.data(), 3e-3);
  }
  INFO("first loss ", first, " last loss ", last);
  CHECK(first > 0.1);
  CHECK(last < 1e-4);
}
