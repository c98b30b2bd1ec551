#include "nets/gan_layers.h"

#include "gradcheck.h"

#include <Eigen/SVD>
#include <doctest/doctest.h>

using namespace sdfkit;
using namespace sdfkit::test;

TEST_CASE("batch_norm2d: zero mean and gamma-scaled unit variance per channel, gradients") {
  BatchNorm2d<double> bn(3);
  ParamStore<double> store;
  store.add(bn);
  store.allocate(true);
  store.init(1);
  store.values[1] = 2.0;   // gamma of channel 1
  store.values[3 + 1] = -0.5;  // beta of channel 1
  const TensorD x = random_tensor({4, 3, 5, 6}, 2, -3, 5);
  TensorD y;
  bn.forward(x, y);
  for (int c = 0; c < 3; ++c) {
    double m = 0, v = 0;
    for (int n = 0; n < 4; ++n)
      for (int p = 0; p < 30; ++p) m += y.item(n)[c * 30 + p];
    m /= 120;
    for (int n = 0; n < 4; ++n)
      for (int p = 0; p < 30; ++p) v += (y.item(n)[c * 30 + p] - m) * (y.item(n)[c * 30 + p] - m);
    v /= 120;
    CHECK(m == doctest::Approx(c == 1 ? -0.5 : 0.0).scale(1));
    CHECK(v == doctest::Approx(c == 1 ? 4.0 : 1.0).epsilon(1e-4));
  }
  BatchNorm2d<double> g(3);
  check_layer_gradients(g, random_tensor({3, 3, 4, 5}, 3));
}

TEST_CASE("spectral_conv2d: power iteration finds the largest singular value, output is the normalised conv") {
  Conv2dSettings s;
  s.in_channels = 3;
  s.out_channels = 5;
  s.kernel = 3;
  SpectralConv2d<double> sn(s);
  ParamStore<double> store;
  store.add(sn);
  store.allocate(true);
  store.init(4);
  const TensorD x = random_tensor({2, 3, 7, 6}, 5);
  TensorD y;
  for (int i = 0; i < 400; ++i) sn.forward(x, y);
  const Eigen::Map<const MatRowT<double>> W(store.values.data(), 5, 27);
  const double top = Eigen::JacobiSVD<MatRowT<double>>(W).singularValues()[0];
  CHECK(sn.sigma() == doctest::Approx(top).epsilon(1e-7));
  // The same as a plain convolution with W / sigma.
  Conv2d<double> plain(s);
  ParamStore<double> ps;
  ps.add(plain);
  ps.allocate(false);
  for (size_t i = 0; i < ps.values.size(); ++i) ps.values[i] = store.values[i] / (i < 5 * 27 ? top : 1.0);
  TensorD yp;
  plain.forward(x, yp);
  double diff = 0;
  for (int64_t i = 0; i < y.size(); ++i) diff = std::max(diff, std::abs(y[i] - yp[i]));
  CHECK(diff < 1e-6);
  // Gradients with u held (sigma = |W^T u| is then an exact function of W).
  SpectralConv2d<double> g(s);
  g.freeze(true);
  check_layer_gradients(g, random_tensor({2, 3, 6, 5}, 6));
}

TEST_CASE("self_attention2d: identity at gamma 0, mean of the values for constant scores, gradients") {
  SelfAttention2d<double> sa(4, 2);
  ParamStore<double> store;
  store.add(sa);
  store.allocate(true);
  store.init(7);
  const TensorD x = random_tensor({2, 4, 3, 5}, 8);
  TensorD y;
  sa.forward(x, y);
  CHECK(y.data == x.data);  // gamma starts at 0
  // Zero query and key weights: every score is bq . bk, attention is uniform, o_j = mean of v_i.
  const size_t nq = 2 * 4 + 2;
  std::fill(store.values.begin(), store.values.begin() + 2 * nq, 0.0);
  store.values.back() = 1.0;
  sa.forward(x, y);
  const Eigen::Map<const MatRowT<double>> Wv(store.values.data() + 2 * nq, 4, 4);
  for (int n = 0; n < 2; ++n) {
    const Eigen::Map<const MatRowT<double>> X(x.item(n), 4, 15);
    const Eigen::VectorXd mean_v = Wv * X.rowwise().mean();  // biases are 0
    for (int c = 0; c < 4; ++c)
      for (int p = 0; p < 15; ++p) CHECK(y.item(n)[c * 15 + p] - x.item(n)[c * 15 + p] == doctest::Approx(mean_v[c]));
  }
  SelfAttention2d<double> g(4, 2);
  check_layer_gradients(g, random_tensor({2, 4, 3, 4}, 9));
}

TEST_CASE("dense_block: the input's channels pass through first, each layer adds its growth, gradients") {
  DenseBlock<double> block(3, 2, 4);
  ParamStore<double> store;
  store.add(block);
  store.allocate(true);
  store.init(10);
  const TensorD x = random_tensor({2, 3, 5, 4}, 11);
  TensorD y;
  block.forward(x, y);
  REQUIRE(y.shape == Shape{2, 11, 5, 4});
  for (int n = 0; n < 2; ++n)
    for (int i = 0; i < 3 * 20; ++i) CHECK(y.item(n)[i] == x.item(n)[i]);
  // The new channels are ReLU outputs of batch-normalised maps: non-negative, about half of them positive.
  int positive = 0;
  for (int n = 0; n < 2; ++n)
    for (int i = 3 * 20; i < 11 * 20; ++i) {
      CHECK(y.item(n)[i] >= 0);
      positive += y.item(n)[i] > 0;
    }
  CHECK(positive > 100);
  CHECK(positive < 220);
  DenseBlock<double> g(3, 2, 4);
  g.freeze(true);
  check_layer_gradients(g, random_tensor({2, 3, 4, 4}, 12));
}
