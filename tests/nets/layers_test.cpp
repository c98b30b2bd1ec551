#include "nets/layers.h"

#include "gradcheck.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <tuple>

using namespace sdfkit;
using namespace sdfkit::test;

TEST_CASE("conv2d gradients: stride, padding, 1x1 fast path") {
  for (const auto& ksp : {std::tuple{3, 1, 1}, std::tuple{3, 2, 1}, std::tuple{4, 2, 0}, std::tuple{1, 1, 0},
                          std::tuple{5, 3, 2}}) {
    const int k = std::get<0>(ksp), s = std::get<1>(ksp), p = std::get<2>(ksp);
    CAPTURE(k);
    CAPTURE(s);
    CAPTURE(p);
    Conv2d<double> conv({3, 4, k, s, p, true});
    check_layer_gradients(conv, random_tensor({2, 3, 9, 8}, 11));
  }
}

TEST_CASE("conv2d forward and input gradient equal direct convolution loops") {
  // im2col / col2im copy the rows' inner columns in one run and pad the edges: cover kernels reaching past both
  // edges, strides that skip the last column, padding wider than the kernel's reach (columns of padding only)
  // and 1-pixel-wide inputs.
  for (const auto& c : {std::tuple{3, 2, 1, 7, 6}, std::tuple{5, 2, 2, 9, 11}, std::tuple{3, 1, 1, 5, 4},
                        std::tuple{2, 3, 3, 6, 5}, std::tuple{1, 2, 0, 5, 7}, std::tuple{3, 1, 2, 4, 1},
                        std::tuple{4, 2, 0, 8, 9}}) {
    // Plain variables, not structured bindings: clang 14 cannot capture those in CAPTURE's lambda.
    const int k = std::get<0>(c), st = std::get<1>(c), p = std::get<2>(c), H = std::get<3>(c), W = std::get<4>(c);
    CAPTURE(k);
    CAPTURE(st);
    CAPTURE(p);
    CAPTURE(W);
    const int C = 2, O = 3, N = 2;
    Conv2d<double> conv({C, O, k, st, p, true});
    ParamStore<double> store;
    store.add(conv);
    store.allocate(true);
    store.init(5);
    const int CKK = C * k * k;
    for (int o = 0; o < O; ++o) store.values[static_cast<size_t>(O * CKK + o)] = 0.5 * o;  // biases
    const TensorD x = random_tensor({N, C, H, W}, 3);
    TensorD y;
    conv.forward(x, y);
    const int Ho = (H + 2 * p - k) / st + 1, Wo = (W + 2 * p - k) / st + 1;
    REQUIRE(y.shape == Shape({N, O, Ho, Wo}));
    const TensorD dy = random_tensor({N, O, Ho, Wo}, 4);
    TensorD dx;
    conv.backward(x, y, dy, &dx);
    REQUIRE(dx.shape == x.shape);
    std::vector<double> dx_ref(static_cast<size_t>(x.size()), 0.0);
    const double* w = store.values.data();
    for (int n = 0; n < N; ++n)
      for (int o = 0; o < O; ++o)
        for (int oy = 0; oy < Ho; ++oy)
          for (int ox = 0; ox < Wo; ++ox) {
            double acc = 0.5 * o;
            const double g = dy[((n * O + o) * Ho + oy) * Wo + ox];
            for (int c = 0; c < C; ++c)
              for (int ki = 0; ki < k; ++ki)
                for (int kj = 0; kj < k; ++kj) {
                  const int iy = oy * st - p + ki, ix = ox * st - p + kj;
                  if (iy < 0 || iy >= H || ix < 0 || ix >= W) continue;
                  const double wv = w[((o * C + c) * k + ki) * k + kj];
                  const int xi = ((n * C + c) * H + iy) * W + ix;
                  acc += wv * x[xi];
                  dx_ref[static_cast<size_t>(xi)] += wv * g;
                }
            CHECK(y[((n * O + o) * Ho + oy) * Wo + ox] == doctest::Approx(acc).epsilon(1e-12));
          }
    for (int64_t i = 0; i < x.size(); ++i) CHECK(dx[i] == doctest::Approx(dx_ref[static_cast<size_t>(i)]).epsilon(1e-12));
  }
}

TEST_CASE("conv2d and linear backward add to the gradient already there, one chunk or several") {
  // A batch of one item (a linear layer: up to 256 rows) is reduced in place, with no partial buffer; larger ones
  // through per-chunk buffers (here 3 chunks each).
  for (const int batch : {1, 3}) {
    CAPTURE(batch);
    Conv2d<double> conv({2, 3, 3, 2, 1, true});
    Linear<double> lin(5, 4);
    for (int which = 0; which < 2; ++which) {
      Layer<double>& layer = which == 0 ? static_cast<Layer<double>&>(conv) : static_cast<Layer<double>&>(lin);
      ParamStore<double> store;
      store.add(layer);
      store.allocate(true);
      store.init(7);
      const TensorD x = which == 0 ? random_tensor({batch, 2, 7, 6}, 8) : random_tensor({batch, 300, 5}, 8);
      TensorD y;
      layer.forward(x, y);
      const TensorD dy = random_tensor(y.shape, 9);
      layer.backward(x, y, dy, nullptr);
      const std::vector<double> once(store.grads.begin(), store.grads.end());
      layer.backward(x, y, dy, nullptr);
      for (size_t i = 0; i < once.size(); ++i) CHECK(store.grads[i] == doctest::Approx(2 * once[i]).epsilon(1e-12));
    }
  }
}

TEST_CASE("linear / point MLP gradients on N x P x C") {
  Linear<double> lin(5, 7);
  check_layer_gradients(lin, random_tensor({3, 11, 5}, 2));
  // Many rows: several reduction chunks.
  Linear<double> big(4, 3);
  check_layer_gradients(big, random_tensor({2, 700, 4}, 3));
  auto mlp = make_point_mlp<double>({3, 8, 16, 4}, ActivationKind::kReLU, false);
  mlp->training(true);
  check_layer_gradients(*mlp, random_tensor({2, 50, 3}, 4));
}

TEST_CASE("activations gradients") {
  for (auto kind : {ActivationKind::kReLU, ActivationKind::kLeakyReLU, ActivationKind::kSigmoid, ActivationKind::kTanh}) {
    Activation<double> a(kind, 0.1);
    check_layer_gradients(a, random_tensor({2, 3, 5}, 9, -3, 3));
  }
  // LeakyReLU values
  Activation<double> lr(ActivationKind::kLeakyReLU, 0.2);
  TensorD x({1, 2}), y;
  x[0] = -2;
  x[1] = 3;
  lr.forward(x, y);
  CHECK(y[0] == doctest::Approx(-0.4));
  CHECK(y[1] == 3);
}

TEST_CASE("pooling gradients and values") {
  Pool2d<double> mp(PoolKind::kMax, 2, 2), ap(PoolKind::kAverage, 3, 2);
  check_layer_gradients(mp, random_tensor({2, 3, 7, 6}, 21));
  check_layer_gradients(ap, random_tensor({2, 3, 7, 6}, 22));
  GlobalPool<double> gap(PoolKind::kAverage), gmp(PoolKind::kMax);
  check_layer_gradients(gap, random_tensor({2, 3, 4, 5}, 23));
  check_layer_gradients(gmp, random_tensor({2, 3, 4, 5}, 24));
  TensorD x({1, 1, 2, 2}), y;
  x.data = {1, 5, -2, 3};
  mp.forward(x, y);
  CHECK(y[0] == 5);
  gap.forward(x, y);
  CHECK(y[0] == doctest::Approx(7.0 / 4));
}

TEST_CASE("bilinear resize: gradients, exact corners, constant field preserved") {
  for (bool align : {true, false}) {
    BilinearResize<double> up(13, 9, align), down(3, 4, align);
    check_layer_gradients(up, random_tensor({2, 2, 5, 4}, 31));
    check_layer_gradients(down, random_tensor({2, 2, 5, 7}, 32));
    TensorD c({1, 2, 5, 4}, 2.5), y;
    up.forward(c, y);
    for (double v : y.data) CHECK(v == doctest::Approx(2.5));
  }
  // align_corners, upsampling 5 -> 9 (factor 2 on (in-1)): every source pixel appears exactly.
  BilinearResize<double> up(9, 9, true);
  const TensorD x = random_tensor({1, 1, 5, 5}, 33);
  TensorD y;
  up.forward(x, y);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) CHECK(y[(2 * i) * 9 + 2 * j] == x[i * 5 + j]);
  // A linear ramp stays a linear ramp (bilinear reproduces affine functions).
  TensorD ramp({1, 1, 5, 5});
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) ramp[i * 5 + j] = 2.0 * i - j;
  up.forward(ramp, y);
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j < 9; ++j) CHECK(y[i * 9 + j] == doctest::Approx(2.0 * i / 2 - j / 2.0));
}

TEST_CASE("sequential conv net gradients (conv, relu, pool, flatten, linear)") {
  Sequential<double> net;
  net.emplace<Conv2d<double>>(Conv2dSettings{2, 4, 3, 2, 1, true});
  net.add(leaky_relu<double>(0.1));
  net.emplace<Conv2d<double>>(Conv2dSettings{4, 3, 3, 1, 1, true});
  net.add(relu<double>());
  net.emplace<Pool2d<double>>(PoolKind::kAverage, 2, 2);
  net.emplace<Flatten<double>>();
  net.emplace<Linear<double>>(3 * 2 * 2, 5);
  net.training(true);
  check_layer_gradients(net, random_tensor({3, 2, 9, 9}, 41));
}

TEST_CASE("sequential with caller-owned activations: the same output and gradients as the stateful path") {
  Sequential<double> net;
  net.emplace<Conv2d<double>>(Conv2dSettings{2, 3, 3, 2, 1, true});
  net.add(relu<double>());
  net.emplace<Flatten<double>>();
  net.emplace<Linear<double>>(3 * 4 * 4, 5);
  ParamStore<double> store;
  store.add(net);
  store.allocate(true);
  store.init(8);
  const TensorD x = random_tensor({2, 2, 7, 7}, 9), dy = random_tensor({2, 5}, 10);
  net.training(true);
  TensorD y, dx;
  store.zero_grad();
  net.forward(x, y);
  net.backward(x, y, dy, &dx);
  const std::vector<double> grads(store.grads.begin(), store.grads.end());
  std::vector<TensorD> acts;
  TensorD dx2, y_run;
  store.zero_grad();
  net.forward_into(x, acts);
  REQUIRE(acts.size() == net.size());
  CHECK(Sequential<double>::output(x, acts).data == y.data);
  net.backward_from(x, acts, dy, &dx2);
  CHECK(dx2.data == dx.data);
  CHECK(std::equal(grads.begin(), grads.end(), store.grads.begin()));
  net.run(x, y_run);
  CHECK(y_run.data == y.data);
  double first = 0;
  Shape out;
  CHECK(net.flops(x.shape, &first, &out) == doctest::Approx(net.forward_flops(x.shape)));
  CHECK(first == doctest::Approx(net[0].forward_flops(x.shape)));
  CHECK(out == y.shape);
  std::vector<TensorD> wrong(1);
  CHECK_THROWS_AS(net.backward_from(x, wrong, dy, nullptr), InvalidInput);
}

TEST_CASE("concat and broadcast: values and adjoint identity") {
  const TensorD a = random_tensor({2, 3, 4}, 1), b = random_tensor({2, 3, 2}, 2);
  TensorD y;
  concat<double>({&a, &b}, -1, y);
  REQUIRE(y.shape == Shape({2, 3, 6}));
  CHECK(y[(1 * 3 + 2) * 6 + 5] == b[(1 * 3 + 2) * 2 + 1]);
  CHECK(y[(1 * 3 + 2) * 6 + 3] == a[(1 * 3 + 2) * 4 + 3]);
  // <dy, concat(a, b)> == <da, a> + <db, b> for da, db = concat_backward(dy).
  const TensorD dy = random_tensor(y.shape, 3);
  TensorD da, db;
  concat_backward<double>(dy, {a.shape, b.shape}, 2, {&da, &db});
  CHECK(dot(dy, y) == doctest::Approx(dot(da, a) + dot(db, b)));
  // Concat along channels of feature maps.
  const TensorD m1 = random_tensor({2, 3, 2, 2}, 4), m2 = random_tensor({2, 1, 2, 2}, 5);
  concat<double>({&m1, &m2}, 1, y);
  CHECK(y[(1 * 4 + 3) * 4 + 2] == m2[(1 * 1 + 0) * 4 + 2]);
  // Broadcast: adjoint identity.
  const TensorD g = random_tensor({2, 5}, 6);
  broadcast_points(g, 7, y);
  REQUIRE(y.shape == Shape({2, 7, 5}));
  const TensorD r = random_tensor(y.shape, 7);
  TensorD dg;
  broadcast_points_backward(r, dg);
  CHECK(dot(r, y) == doctest::Approx(dot(dg, g)));
}

TEST_CASE("results are identical for 1 and 2 threads") {
  Sequential<float> net;
  net.emplace<Conv2d<float>>(Conv2dSettings{3, 8, 3, 2, 1, true});
  net.add(relu<float>());
  net.emplace<GlobalPool<float>>();
  net.emplace<Linear<float>>(8, 4);
  net.training(true);
  ParamStore<float> store;
  store.add(net);
  store.allocate(true);
  store.init(3);
  Linear<float> lin(16, 32);
  ParamStore<float> s2;
  s2.add(lin);
  s2.allocate(true);
  s2.init(4);
  const Tensor x = random_tensor({16, 3, 21, 21}, 1).cast<float>();
  const Tensor pts = random_tensor({4, 1000, 16}, 2).cast<float>();
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Tensor y, dx, yp, dp;
    store.zero_grad();
    s2.zero_grad();
    net.forward(x, y);
    net.backward(x, y, y, &dx);
    lin.forward(pts, yp);
    lin.backward(pts, yp, yp, &dp);
    std::vector<float> all(y.data.begin(), y.data.end());
    all.insert(all.end(), dx.data.begin(), dx.data.end());
    all.insert(all.end(), store.grads.begin(), store.grads.end());
    all.insert(all.end(), s2.grads.begin(), s2.grads.end());
    return all;
  };
  const auto a = run(1), b = run(2);
  REQUIRE(a.size() == b.size());
  CHECK(std::equal(a.begin(), a.end(), b.begin()));
}

TEST_CASE("inference-only store: forward works, backward is a clear error") {
  Linear<float> lin(3, 2);
  ParamStore<float> store;
  store.add(lin);
  store.allocate(false);
  store.init(1);
  CHECK(store.grads.empty());
  Tensor x({4, 3}, 1.0f), y, dx;
  lin.forward(x, y);
  CHECK(y.shape == Shape({4, 2}));
  CHECK_THROWS_AS(lin.backward(x, y, y, &dx), InvalidInput);
  Tensor bad({4, 5});
  CHECK_THROWS_AS(lin.forward(bad, y), InvalidInput);
}

TEST_CASE("xavier init: range and seed determinism") {
  Linear<float> a(100, 50), b(100, 50);
  ParamStore<float> sa, sb;
  sa.add(a);
  sb.add(b);
  sa.allocate(false);
  sb.allocate(false);
  sa.init(9);
  sb.init(9);
  CHECK(sa.values == sb.values);
  const double bound = std::sqrt(6.0 / 150);
  double mx = 0;
  for (size_t i = 0; i < 5000; ++i) mx = std::max(mx, double(std::abs(sa.values[i])));
  CHECK(mx <= bound);
  CHECK(mx > 0.9 * bound);
  for (size_t i = 5000; i < 5050; ++i) CHECK(sa.values[i] == 0.0f);
  sb.init(10);
  CHECK(sa.values != sb.values);
}
