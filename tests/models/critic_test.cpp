#include "models/critic.h"

#include "core/error.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

namespace {

CriticSettings tiny() {
  CriticSettings s;
  s.size = 16;
  s.stem = 4;
  s.block_layers = 2;
  s.growth = 3;
  s.key1 = 2;
  s.key2 = 2;
  s.lr = 2e-3;
  return s;
}

/// N white images, with a dark centred square when `square`.
Tensor images(int n, bool square) {
  Tensor t({n, 3, 16, 16}, 1.0f);
  if (square)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        for (int y = 5; y < 11; ++y)
          for (int x = 5 + i % 2; x < 11 + i % 2; ++x) t.item(i)[(c * 16 + y) * 16 + x] = 0.2f;
  return t;
}

}  // namespace

TEST_CASE("critic: the paper's layout, a logit map, learns to tell two kinds of images apart") {
  Critic d(tiny(), 3);
  Tensor real = images(4, true), fake = images(4, false), logits, grad, dimg;
  d.forward(real, logits);
  // 16 px -> stem 8 x 8 -> head k4 p0 -> 5 x 5.
  REQUIRE(logits.shape == Shape{4, 1, 5, 5});
  double first = 0, last = 0;
  for (int it = 0; it < 60; ++it) {
    d.forward(real, logits);
    double l = critic_loss(logits, 1.0f, &grad);
    d.backward(real, logits, grad, nullptr);
    d.forward(fake, logits);
    l += critic_loss(logits, 0.0f, &grad);
    d.backward(fake, logits, grad, &dimg);
    d.step();
    if (it == 0) first = l;
    last = l;
  }
  CHECK(first > 1.2);  // about 2 ln 2 at the start
  CHECK(last < 0.3);
  // The gradient reaches the images.
  REQUIRE(dimg.shape == fake.shape);
  double norm = 0;
  for (const float g : dimg.data) norm += double(g) * g;
  CHECK(std::isfinite(norm));
  CHECK(norm > 0);
  // Seeded: the same seed gives the same critic.
  Critic a(tiny(), 9), b(tiny(), 9);
  Tensor la, lb;
  a.forward(real, la);
  b.forward(real, lb);
  CHECK(la.data == lb.data);
  const Tensor wrong({1, 3, 8, 8}, 1.0f);
  CHECK_THROWS_AS(a.forward(wrong, la), InvalidInput);
}
