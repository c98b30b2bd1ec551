#include "nets/gan_layers.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {

namespace {

constexpr int64_t kMaxChunks = 8;  // per-chunk gradient partials, summed in chunk order

template <typename T>
void sum_partials(const std::vector<AlignedVector<T>>& partials, T* g, size_t n) {
  for (const auto& p : partials)
    for (size_t i = 0; i < n; ++i) g[i] += p[i];
}

double norm_of(const std::vector<double>& v) {
  double s = 0;
  for (const double x : v) s += x * x;
  return std::sqrt(s);
}

}  // namespace

// ----------------------------------------------------------------------------------------------- BatchNorm2d
namespace {

/// Mean and biased variance of channel c over the batch and the positions of an N x C x H x W tensor.
template <typename T>
void channel_stats(const TensorT<T>& x, int64_t c, double* mean, double* var) {
  const int64_t N = x.dim(0), P = x.dim(2) * x.dim(3);
  const double M = static_cast<double>(N * P);
  double m = 0, v = 0;
  for (int64_t n = 0; n < N; ++n)
    for (int64_t p = 0; p < P; ++p) m += x.item(n)[c * P + p];
  m /= M;
  for (int64_t n = 0; n < N; ++n)
    for (int64_t p = 0; p < P; ++p) {
      const double d = x.item(n)[c * P + p] - m;
      v += d * d;
    }
  *mean = m;
  *var = v / M;
}

}  // namespace

template <typename T>
Json BatchNorm2d<T>::hyperparams() const {
  return {{"type", type()}, {"channels", channels_}, {"eps", eps_}};
}

template <typename T>
void BatchNorm2d<T>::init_params(T* w, Rng& rng) const {
  (void)rng;
  std::fill(w, w + channels_, T(1));
  std::fill(w + channels_, w + 2 * channels_, T(0));
}

template <typename T>
Shape BatchNorm2d<T>::output_shape(const Shape& in) const {
  require(in.size() == 4 && in[1] == channels_,
          "batch_norm2d: expected N x " + std::to_string(channels_) + " x H x W input, got " + shape_string(in));
  require(in[0] * in[2] * in[3] > 1, "batch_norm2d: needs more than one value per channel");
  return in;
}

template <typename T>
void BatchNorm2d<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  this->require_bound(false);
  y.resize(output_shape(x.shape));
  const int64_t N = x.dim(0), C = channels_, P = x.dim(2) * x.dim(3);
  parallel_items(C, [&](int64_t c) {
    double mean = 0, var = 0;
    channel_stats(x, c, &mean, &var);
    const double scale = double(this->w_[c]) / std::sqrt(var + eps_), shift = double(this->w_[C + c]);
    for (int64_t n = 0; n < N; ++n)
      for (int64_t p = 0; p < P; ++p)
        y.item(n)[c * P + p] = static_cast<T>((x.item(n)[c * P + p] - mean) * scale + shift);
  });
}

template <typename T>
void BatchNorm2d<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  this->require_bound(true);
  require(dy.shape == x.shape, "batch_norm2d backward: dy " + shape_string(dy.shape) + " != " + shape_string(x.shape));
  const int64_t N = x.dim(0), C = channels_, P = x.dim(2) * x.dim(3);
  const double M = static_cast<double>(N * P);
  if (dx) dx->resize(x.shape);
  // Channels are independent: each writes its own gamma/beta gradient, so no reduction order is at stake.
  parallel_items(C, [&](int64_t c) {
    double mean = 0, var = 0;
    channel_stats(x, c, &mean, &var);
    const double inv = 1.0 / std::sqrt(var + eps_);
    double sum_dy = 0, sum_dy_xhat = 0;
    for (int64_t n = 0; n < N; ++n)
      for (int64_t p = 0; p < P; ++p) {
        const double g = dy.item(n)[c * P + p];
        sum_dy += g;
        sum_dy_xhat += g * (x.item(n)[c * P + p] - mean) * inv;
      }
    this->g_[c] += static_cast<T>(sum_dy_xhat);
    this->g_[C + c] += static_cast<T>(sum_dy);
    if (!dx) return;
    // dx = gamma / (M sigma) (M dy - sum dy - xhat sum(dy xhat)).
    const double k = double(this->w_[c]) * inv / M;
    for (int64_t n = 0; n < N; ++n)
      for (int64_t p = 0; p < P; ++p) {
        const double xhat = (x.item(n)[c * P + p] - mean) * inv;
        dx->item(n)[c * P + p] = static_cast<T>(k * (M * dy.item(n)[c * P + p] - sum_dy - xhat * sum_dy_xhat));
      }
  });
}

// ----------------------------------------------------------------------------------------------- SpectralConv2d
template <typename T>
SpectralConv2d<T>::SpectralConv2d(const Conv2dSettings& s) : s_(s), conv_(s) {}

template <typename T>
Json SpectralConv2d<T>::hyperparams() const {
  Json j = conv_.hyperparams();
  j["type"] = type();
  return j;
}

template <typename T>
void SpectralConv2d<T>::init_params(T* w, Rng& rng) const {
  conv_.init_params(w, rng);
  // The power iteration's start: a seeded random unit vector (drawn after the weights, from the same stream).
  u_.resize(static_cast<size_t>(s_.out_channels));
  for (double& x : u_) x = rng.uniform(-1, 1);
  const double n = norm_of(u_);
  for (double& x : u_) x /= n;
}

template <typename T>
void SpectralConv2d<T>::bind(T* w, T* g) {
  Layer<T>::bind(w, g);
  w_sn_.assign(n_params(), T(0));
  g_sn_.assign(g ? n_params() : 0, T(0));
  conv_.bind(w_sn_.data(), g ? g_sn_.data() : nullptr);
  if (u_.empty()) u_.assign(static_cast<size_t>(s_.out_channels), 1.0 / std::sqrt(double(s_.out_channels)));
}

template <typename T>
void SpectralConv2d<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  this->require_bound(false);
  const int64_t O = s_.out_channels, K = int64_t(s_.in_channels) * s_.kernel * s_.kernel;
  const T* W = this->w_;
  auto wt_u = [&] {  // v = W^T u / |W^T u|
    std::vector<double> v(static_cast<size_t>(K), 0.0);
    for (int64_t o = 0; o < O; ++o)
      for (int64_t k = 0; k < K; ++k) v[static_cast<size_t>(k)] += double(W[o * K + k]) * u_[static_cast<size_t>(o)];
    const double n = norm_of(v);
    for (double& a : v) a /= std::max(n, 1e-12);
    return v;
  };
  if (!frozen_) {
    const std::vector<double> v = wt_u();
    for (int64_t o = 0; o < O; ++o) {
      double s = 0;
      for (int64_t k = 0; k < K; ++k) s += double(W[o * K + k]) * v[static_cast<size_t>(k)];
      u_[static_cast<size_t>(o)] = s;
    }
    const double n = norm_of(u_);
    for (double& a : u_) a /= std::max(n, 1e-12);
  }
  v_ = wt_u();
  double sigma = 0;
  for (int64_t o = 0; o < O; ++o)
    for (int64_t k = 0; k < K; ++k)
      sigma += u_[static_cast<size_t>(o)] * double(W[o * K + k]) * v_[static_cast<size_t>(k)];
  sigma_ = std::max(sigma, 1e-12);
  for (int64_t i = 0; i < O * K; ++i) w_sn_[static_cast<size_t>(i)] = static_cast<T>(double(W[i]) / sigma_);
  for (size_t i = static_cast<size_t>(O * K); i < n_params(); ++i) w_sn_[i] = W[i];
  conv_.forward(x, y);
}

template <typename T>
void SpectralConv2d<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  this->require_bound(true);
  std::fill(g_sn_.begin(), g_sn_.end(), T(0));
  conv_.backward(x, y, dy, dx);
  // W_sn = W / sigma, sigma = u^T W v: dL/dW = G / sigma - (G . W) / sigma^2 u v^T, G = dL/dW_sn.
  const int64_t O = s_.out_channels, K = int64_t(s_.in_channels) * s_.kernel * s_.kernel;
  double gw = 0;
  for (int64_t i = 0; i < O * K; ++i) gw += double(g_sn_[static_cast<size_t>(i)]) * double(this->w_[i]);
  const double a = gw / (sigma_ * sigma_);
  for (int64_t o = 0; o < O; ++o)
    for (int64_t k = 0; k < K; ++k) {
      const size_t i = static_cast<size_t>(o * K + k);
      this->g_[i] += static_cast<T>(double(g_sn_[i]) / sigma_ - a * u_[static_cast<size_t>(o)] * v_[static_cast<size_t>(k)]);
    }
  for (size_t i = static_cast<size_t>(O * K); i < n_params(); ++i) this->g_[i] += g_sn_[i];
}

// ----------------------------------------------------------------------------------------------- SelfAttention2d
template <typename T>
Json SelfAttention2d<T>::hyperparams() const {
  return {{"type", type()}, {"channels", c_}, {"key_channels", ck_}};
}

template <typename T>
size_t SelfAttention2d<T>::n_params() const {
  const size_t c = static_cast<size_t>(c_), k = static_cast<size_t>(ck_);
  return 2 * (k * c + k) + (c * c + c) + 1;
}

template <typename T>
void SelfAttention2d<T>::init_params(T* w, Rng& rng) const {
  const size_t c = static_cast<size_t>(c_), k = static_cast<size_t>(ck_);
  T* p = w;
  for (const size_t rows : {k, k, c}) {
    xavier_uniform(p, rows * c, c_, static_cast<int64_t>(rows), rng);
    std::fill(p + rows * c, p + rows * c + rows, T(0));
    p += rows * c + rows;
  }
  *p = T(0);  // gamma
}

template <typename T>
Shape SelfAttention2d<T>::output_shape(const Shape& in) const {
  require(in.size() == 4 && in[1] == c_,
          "self_attention2d: expected N x " + std::to_string(c_) + " x H x W input, got " + shape_string(in));
  return in;
}

template <typename T>
double SelfAttention2d<T>::forward_flops(const Shape& in) const {
  const double N = double(in[0]), P = double(in[2] * in[3]), C = c_, K = ck_;
  return 2.0 * N * (P * C * (2 * K + C) + P * P * (K + C));
}

namespace {

/// The per-image pieces of the attention: projections, attention matrix, attended values.
template <typename T>
struct AttentionParts {
  using Mat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
  Mat Q, K, V, A, O;  // Ck x P, Ck x P, C x P, P x P (row j: weights over i), C x P
};

template <typename T>
void attention_parts(const T* w, int C, int Ck, const T* x, int64_t P, AttentionParts<T>& a) {
  using Mat = typename AttentionParts<T>::Mat;
  const Eigen::Map<const Mat> X(x, P, C);  // x is C x P row-major = P x C column-major
  const Eigen::Map<const MatRowT<T>> Wq(w, Ck, C), Wk(w + Ck * C + Ck, Ck, C),
      Wv(w + 2 * (Ck * C + Ck), C, C);
  const Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>> bq(w + Ck * C, Ck), bk(w + 2 * Ck * C + Ck, Ck),
      bv(w + 2 * (Ck * C + Ck) + C * C, C);
  a.Q = (Wq * X.transpose()).colwise() + bq;
  a.K = (Wk * X.transpose()).colwise() + bk;
  a.V = (Wv * X.transpose()).colwise() + bv;
  a.A = a.Q.transpose() * a.K;  // P x P, S_ji = q_j . k_i
  for (int64_t j = 0; j < P; ++j) {
    const T m = a.A.row(j).maxCoeff();
    a.A.row(j) = (a.A.row(j).array() - m).exp();
    a.A.row(j) /= a.A.row(j).sum();
  }
  a.O = a.V * a.A.transpose();  // o_j = sum_i A_ji v_i
}

}  // namespace

template <typename T>
void SelfAttention2d<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  this->require_bound(false);
  y.resize(output_shape(x.shape));
  const int64_t P = x.dim(2) * x.dim(3);
  const T gamma = this->w_[n_params() - 1];
  parallel_items(x.batch(), [&](int64_t n) {
    AttentionParts<T> a;
    attention_parts(this->w_, c_, ck_, x.item(n), P, a);
    MatMapT<T> Y(y.item(n), c_, P);
    Y = gamma * a.O + ConstMatMapT<T>(x.item(n), c_, P);
  });
}

template <typename T>
void SelfAttention2d<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy,
                                  TensorT<T>* dx) const {
  (void)y;
  this->require_bound(true);
  require(dy.shape == x.shape, "self_attention2d backward: dy " + shape_string(dy.shape) + " != " +
                                   shape_string(x.shape));
  using Mat = typename AttentionParts<T>::Mat;
  const int64_t P = x.dim(2) * x.dim(3);
  const int C = c_, Ck = ck_;
  const size_t np = n_params();
  const T gamma = this->w_[np - 1];
  if (dx) dx->resize(x.shape);
  const auto chunks = fixed_chunks(x.batch(), 1, kMaxChunks);
  std::vector<AlignedVector<T>> partial(chunks.size());
  parallel_chunks(chunks, [&](size_t ci, int64_t begin, int64_t end) {
    AlignedVector<T>& g = partial[ci];
    g.assign(np, T(0));
    MatMapT<T> gWq(g.data(), Ck, C), gWk(g.data() + Ck * C + Ck, Ck, C), gWv(g.data() + 2 * (Ck * C + Ck), C, C);
    T* gbq = g.data() + Ck * C;
    T* gbk = g.data() + 2 * Ck * C + Ck;
    T* gbv = g.data() + 2 * (Ck * C + Ck) + C * C;
    for (int64_t n = begin; n < end; ++n) {
      AttentionParts<T> a;
      attention_parts(this->w_, C, Ck, x.item(n), P, a);
      const ConstMatMapT<T> dY(dy.item(n), C, P);
      const ConstMatMapT<T> X(x.item(n), C, P);
      g[np - 1] += (dY.array() * a.O.array()).sum();
      const Mat dO = gamma * Mat(dY);
      const Mat dV = dO * a.A;                       // C x P
      Mat dA = dO.transpose() * a.V;                 // P x P: dA_ji = do_j . v_i
      // Softmax rows: dS_ji = A_ji (dA_ji - sum_i' dA_ji' A_ji').
      for (int64_t j = 0; j < P; ++j) {
        const T s = (dA.row(j).array() * a.A.row(j).array()).sum();
        dA.row(j) = (a.A.row(j).array() * (dA.row(j).array() - s)).matrix();
      }
      const Mat dQ = a.K * dA.transpose();  // S = Q^T K: dQ = K dS^T
      const Mat dK = a.Q * dA;              // dK = Q dS
      gWq.noalias() += dQ * X.transpose();
      gWk.noalias() += dK * X.transpose();
      gWv.noalias() += dV * X.transpose();
      for (int r = 0; r < Ck; ++r) {
        gbq[r] += dQ.row(r).sum();
        gbk[r] += dK.row(r).sum();
      }
      for (int r = 0; r < C; ++r) gbv[r] += dV.row(r).sum();
      if (dx) {
        const Eigen::Map<const MatRowT<T>> Wq(this->w_, Ck, C), Wk(this->w_ + Ck * C + Ck, Ck, C),
            Wv(this->w_ + 2 * (Ck * C + Ck), C, C);
        MatMapT<T> dX(dx->item(n), C, P);
        dX = dY;
        dX.noalias() += Wq.transpose() * dQ;
        dX.noalias() += Wk.transpose() * dK;
        dX.noalias() += Wv.transpose() * dV;
      }
    }
  });
  sum_partials(partial, this->g_, np);
}

// ----------------------------------------------------------------------------------------------- DenseBlock
namespace {

/// The first `k` channels of every image of x (N x C x H x W) into out (N x k x H x W).
template <typename T>
void take_channels(const TensorT<T>& x, int64_t k, TensorT<T>& out) {
  const int64_t P = x.dim(2) * x.dim(3);
  out.resize({x.dim(0), k, x.dim(2), x.dim(3)});
  for (int64_t n = 0; n < x.dim(0); ++n) std::copy(x.item(n), x.item(n) + k * P, out.item(n));
}

/// Adds src (N x k x H x W) into channels [c0, c0 + k) of every image of dst.
template <typename T>
void add_channels(const TensorT<T>& src, int64_t c0, TensorT<T>& dst) {
  const int64_t P = dst.dim(2) * dst.dim(3), k = src.dim(1);
  for (int64_t n = 0; n < dst.dim(0); ++n) {
    T* d = dst.item(n) + c0 * P;
    const T* s = src.item(n);
    for (int64_t i = 0; i < k * P; ++i) d[i] += s[i];
  }
}

}  // namespace

template <typename T>
DenseBlock<T>::DenseBlock(int in_channels, int layers, int growth) : in_(in_channels), layers_(layers), growth_(growth) {
  require(in_channels > 0 && layers > 0 && growth > 0, "dense_block: channels, layers and growth must be positive");
  for (int l = 0; l < layers; ++l) {
    Conv2dSettings s;
    s.in_channels = in_channels + l * growth;
    s.out_channels = growth;
    s.kernel = 3;
    s.padding = 1;
    convs_.push_back(std::make_unique<SpectralConv2d<T>>(s));
    norms_.push_back(std::make_unique<BatchNorm2d<T>>(growth));
  }
}

template <typename T>
Json DenseBlock<T>::hyperparams() const {
  return {{"type", type()}, {"in", in_}, {"layers", layers_}, {"growth", growth_}};
}

template <typename T>
size_t DenseBlock<T>::n_params() const {
  size_t n = 0;
  for (int l = 0; l < layers_; ++l) n += convs_[static_cast<size_t>(l)]->n_params() + norms_[static_cast<size_t>(l)]->n_params();
  return n;
}

template <typename T>
void DenseBlock<T>::init_params(T* w, Rng& rng) const {
  for (int l = 0; l < layers_; ++l) {
    convs_[static_cast<size_t>(l)]->init_params(w, rng);
    w += convs_[static_cast<size_t>(l)]->n_params();
    norms_[static_cast<size_t>(l)]->init_params(w, rng);
    w += norms_[static_cast<size_t>(l)]->n_params();
  }
}

template <typename T>
void DenseBlock<T>::bind(T* w, T* g) {
  Layer<T>::bind(w, g);
  for (int l = 0; l < layers_; ++l) {
    SpectralConv2d<T>& c = *convs_[static_cast<size_t>(l)];
    BatchNorm2d<T>& b = *norms_[static_cast<size_t>(l)];
    c.bind(w, g);
    w += c.n_params();
    if (g) g += c.n_params();
    b.bind(w, g);
    w += b.n_params();
    if (g) g += b.n_params();
  }
}

template <typename T>
Shape DenseBlock<T>::output_shape(const Shape& in) const {
  require(in.size() == 4 && in[1] == in_,
          "dense_block: expected N x " + std::to_string(in_) + " x H x W input, got " + shape_string(in));
  return {in[0], in_ + int64_t(layers_) * growth_, in[2], in[3]};
}

template <typename T>
double DenseBlock<T>::forward_flops(const Shape& in) const {
  double f = 0;
  for (int l = 0; l < layers_; ++l)
    f += convs_[static_cast<size_t>(l)]->forward_flops({in[0], in_ + int64_t(l) * growth_, in[2], in[3]});
  return f;
}

template <typename T>
void DenseBlock<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  const Shape os = output_shape(x.shape);
  const int64_t P = x.dim(2) * x.dim(3);
  y.assign(os, T(0));
  for (int64_t n = 0; n < x.dim(0); ++n) std::copy(x.item(n), x.item(n) + in_ * P, y.item(n));
  inputs_.resize(static_cast<size_t>(layers_));
  convolved_.resize(static_cast<size_t>(layers_));
  normed_.resize(static_cast<size_t>(layers_));
  TensorT<T> f;
  for (int l = 0; l < layers_; ++l) {
    const size_t i = static_cast<size_t>(l);
    const int64_t c = in_ + int64_t(l) * growth_;
    take_channels(y, c, inputs_[i]);
    convs_[i]->forward(inputs_[i], convolved_[i]);
    norms_[i]->forward(convolved_[i], normed_[i]);
    f.resize(normed_[i].shape);
    for (int64_t k = 0; k < f.size(); ++k) f[k] = std::max(normed_[i][k], T(0));
    add_channels(f, c, y);  // y's channels [c, c + growth) were 0
  }
}

template <typename T>
void DenseBlock<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  require(dy.shape == output_shape(x.shape), "dense_block backward: dy " + shape_string(dy.shape) + " != output");
  require(inputs_.size() == static_cast<size_t>(layers_), "dense_block backward: no forward to go back through");
  const int64_t P = x.dim(2) * x.dim(3), N = x.dim(0);
  TensorT<T> d = dy, df, dnormed, dconv, din;
  for (int l = layers_ - 1; l >= 0; --l) {
    const size_t i = static_cast<size_t>(l);
    const int64_t c = in_ + int64_t(l) * growth_;
    // The layer's output channels [c, c + growth) of the running gradient, through the ReLU.
    df.resize(normed_[i].shape);
    for (int64_t n = 0; n < N; ++n) {
      const T* src = d.item(n) + c * P;
      T* dst = df.item(n);
      const T* z = normed_[i].item(n);
      for (int64_t k = 0; k < growth_ * P; ++k) dst[k] = z[k] > T(0) ? src[k] : T(0);
    }
    norms_[i]->backward(convolved_[i], normed_[i], df, &dnormed);
    TensorT<T> conv_out;  // SpectralConv2d's backward does not read y
    convs_[i]->backward(inputs_[i], conv_out, dnormed, &din);
    add_channels(din, 0, d);
  }
  if (dx) take_channels(d, in_, *dx);
}

template <typename T>
void DenseBlock<T>::freeze(bool on) {
  for (auto& c : convs_) c->freeze(on);
}

#define SDFKIT_GAN_LAYERS(T)          \
  template class BatchNorm2d<T>;      \
  template class SpectralConv2d<T>;   \
  template class SelfAttention2d<T>;  \
  template class DenseBlock<T>;
SDFKIT_GAN_LAYERS(float)
SDFKIT_GAN_LAYERS(double)
#undef SDFKIT_GAN_LAYERS

}  // namespace sdfkit
