#include "models/patch_critic.h"

#include "core/error.h"
#include "models/critic.h"

#include "nets/gradcheck.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {

PatchCriticSettings small(int size) {
  PatchCriticSettings s;
  s.size = size;
  s.in_channels = 4;
  s.stem = 3;
  s.widths = {4, 4, 5, 5};
  s.lr = 2e-3;
  return s;
}

/// N inputs: white RGB with a dark square, and a fourth channel that is the square's coverage (consistent) or the
/// square moved by 4 pixels (inconsistent with the image).
Tensor pairs(int n, int size, bool consistent) {
  Tensor t({n, 4, size, size}, 1.0f);
  for (int i = 0; i < n; ++i) {
    float* x = t.item(i);
    const int o = 3 + i % 3;
    for (int y = o; y < o + size / 2; ++y)
      for (int c = 0; c < 3; ++c)
        for (int xx = o; xx < o + size / 2; ++xx) x[(c * size + y) * size + xx] = 0.2f;
    const int s = consistent ? o : o + 4;
    for (int y = 0; y < size; ++y)
      for (int xx = 0; xx < size; ++xx)
        x[(3 * size + y) * size + xx] = (y >= s && y < s + size / 2 && xx >= s && xx < s + size / 2) ? 1.f : 0.f;
  }
  return t;
}

}  // namespace

TEST_CASE("patch critic: the paper's 14 x 14 patch map for every input side 14 * 2^k, others refused") {
  for (const int size : {14, 28, 56, 112}) {
    PatchCritic d(small(size), 1);
    Tensor x({2, 4, size, size}, 0.5f), logits;
    d.forward(x, logits);
    CHECK(logits.shape == Shape{2, 1, 14, 14});
  }
  CHECK(small(56).pools() == 2);
  CHECK(small(224).pools() == 4);
  CHECK_THROWS_AS(PatchCritic(small(50), 1), InvalidInput);
  CHECK_THROWS_AS(PatchCritic(small(448), 1), InvalidInput);  // more pools than blocks
  PatchCritic d(small(28), 1);
  Tensor wrong({1, 3, 28, 28}, 0.5f), logits;
  CHECK_THROWS_AS(d.forward(wrong, logits), InvalidInput);
}

TEST_CASE("patch critic: input and parameter gradients match finite differences") {
  PatchCriticT<double> d(small(28), 5);
  const TensorD x = test::random_tensor({2, 4, 28, 28}, 3, 0.0, 1.0);
  TensorD logits, dx;
  d.forward(x, logits);
  const TensorD r = test::random_tensor(logits.shape, 4);
  d.zero_grad();
  d.backward(x, logits, r, &dx);
  TensorD xx = x;
  auto loss = [&] {
    TensorD y;
    d.forward(xx, y);
    return test::dot(r, y);
  };
  const auto xi = test::some_indices(static_cast<size_t>(x.size()), 40, 6);
  std::vector<double> ax;
  for (size_t i : xi) ax.push_back(dx[static_cast<int64_t>(i)]);
  CHECK(test::relative_error(ax, test::numeric_gradient(loss, xx.ptr(), xi)) < 1e-5);
  const auto wi = test::some_indices(d.n_params(), 60, 7);
  std::vector<double> aw;
  for (size_t i : wi) aw.push_back(d.params().grads[i]);
  CHECK(test::relative_error(aw, test::numeric_gradient(loss, d.params().values.data(), wi)) < 1e-5);
}

TEST_CASE("patch critic: learns whether the rendered channel matches the image, state round-trips") {
  PatchCritic d(small(28), 2);
  const Tensor real = pairs(6, 28, true), fake = pairs(6, 28, false);
  Tensor logits, grad;
  double first = 0, last = 0;
  for (int it = 0; it < 200; ++it) {
    d.forward(real, logits);
    double l = critic_loss(logits, 1.0f, &grad);
    d.backward(real, logits, grad, nullptr);
    d.forward(fake, logits);
    l += critic_loss(logits, 0.0f, &grad);
    d.backward(fake, logits, grad, nullptr);
    d.step();
    if (it == 0) first = l;
    last = l;
  }
  CHECK(first > 1.0);  // about 2 ln 2 at the start
  CHECK(last < 0.35);
  // Save and restore: same parameters and Adam state, so one more step gives the same parameters.
  Checkpoint ck;
  put_patch_critic(ck, d, "critic_");
  PatchCritic e(small(28), 99);
  get_patch_critic(ck, e, "critic_", "test.ckpt");
  CHECK(std::vector<float>(e.params().values.begin(), e.params().values.end()) ==
        std::vector<float>(d.params().values.begin(), d.params().values.end()));
  for (PatchCritic* c : {&d, &e}) {
    c->forward(real, logits);
    critic_loss(logits, 1.0f, &grad);
    c->backward(real, logits, grad, nullptr);
    c->step();
  }
  CHECK(std::vector<float>(e.params().values.begin(), e.params().values.end()) ==
        std::vector<float>(d.params().values.begin(), d.params().values.end()));
  PatchCritic other(small(56), 1);
  CHECK_THROWS_AS(get_patch_critic(ck, other, "critic_", "test.ckpt"), IoError);
  CHECK_THROWS_AS(get_patch_critic(Checkpoint{}, e, "critic_", "test.ckpt"), IoError);
}
