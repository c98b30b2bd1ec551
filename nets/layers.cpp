#include "nets/layers.h"

#include "core/json.h"
#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {
namespace {

// Maximum number of partial gradient buffers of one layer (memory bound: chunks x params).
constexpr int64_t kMaxReduceChunks = 8;

template <typename T>
using ColMajor = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;

// Where chunk c of a backward pass accumulates its parameter gradient: with several chunks a zeroed buffer of its
// own (partials holds one per chunk, summed by add_partials), with a single chunk (partials empty) the layer's
// gradient itself, which saves zeroing and adding a buffer of the layer's size; g += a + b then becomes
// (g + a) + b, the same bytes when g starts at zero, as it does in every trainer's step.
template <typename T>
T* chunk_gradient(std::vector<AlignedVector<T>>& partials, size_t c, size_t n, T* g) {
  if (partials.empty()) return g;
  partials[c].assign(n, T(0));
  return partials[c].data();
}

// Sum per-chunk partial gradients into g in chunk order (deterministic for any thread count).
template <typename T>
void add_partials(const std::vector<AlignedVector<T>>& partials, T* g, size_t n) {
  for (const auto& p : partials)
    for (size_t i = 0; i < n; ++i) g[i] += p[i];
}

}  // namespace

// ----------------------------------------------------------------------------------------------- Conv2d
namespace {

// The output columns of kernel offset kj that read inside the input row, [lo, hi) (the others read the zero
// padding), and where their values lie. With stride 1 they are consecutive in the row. A strided convolution reads
// every s-th input column; with each input row split into its s phases (columns r, r + s, r + 2s, ... stored one
// after another, each Wp = ceil(W / s) long) they are consecutive in one phase: input column ox * s + off is entry
// ox + q of phase r, where off = q * s + r. Output column lo of input row iy reads entry at(iy) of the plane (stride
// 1) or of the phase layout (stride > 1).
struct ColumnRun {
  int lo = 0, hi = 0;
  int64_t row_stride = 0, first = 0;
  [[nodiscard]] int64_t at(int iy) const { return iy * row_stride + first; }
};

inline ColumnRun column_run(int W, int s, int p, int kj, int Wo) {
  ColumnRun run;
  const int off = kj - p;  // input column of output column 0
  // ox * s + off >= 0  <=>  ox >= ceil(-off / s);  ox * s + off <= W - 1  <=>  ox <= floor((W - 1 - off) / s).
  const int first = off >= 0 ? 0 : (-off + s - 1) / s;
  const int last = (W - 1 - off) >= 0 ? (W - 1 - off) / s : -1;
  run.lo = std::min(Wo, first);
  run.hi = std::max(run.lo, std::min(Wo, last + 1));
  if (s == 1) {
    run.row_stride = W;
    run.first = run.lo + off;
  } else {
    const int wp = (W + s - 1) / s, r = ((off % s) + s) % s, q = (off - r) / s;
    run.row_stride = static_cast<int64_t>(s) * wp;
    run.first = static_cast<int64_t>(r) * wp + run.lo + q;
  }
  return run;
}

// col is (C*k*k) x (Ho*Wo), row-major.
template <typename T>
void im2col(const T* x, int C, int H, int W, int k, int s, int p, int Ho, int Wo, T* col) {
  const int Wp = (W + s - 1) / s;
  thread_local std::vector<T> split;  // one channel's rows split into phases (stride > 1)
  if (s > 1) split.resize(static_cast<size_t>(H) * s * Wp);
  for (int c = 0; c < C; ++c) {
    const T* plane = x + static_cast<int64_t>(c) * H * W;
    if (s > 1)
      for (int iy = 0; iy < H; ++iy) {
        const T* in = plane + static_cast<int64_t>(iy) * W;
        T* o = split.data() + static_cast<int64_t>(iy) * s * Wp;
        for (int r = 0; r < s; ++r)
          for (int j = r, i = r * Wp; j < W; j += s, ++i) o[i] = in[j];
      }
    for (int ki = 0; ki < k; ++ki)
      for (int kj = 0; kj < k; ++kj) {
        T* row = col + (static_cast<int64_t>(c * k + ki) * k + kj) * Ho * Wo;
        const ColumnRun run = column_run(W, s, p, kj, Wo);
        const T* source = s == 1 ? plane : split.data();
        for (int oy = 0; oy < Ho; ++oy) {
          const int iy = oy * s - p + ki;
          T* out = row + static_cast<int64_t>(oy) * Wo;
          if (iy < 0 || iy >= H) {
            std::fill(out, out + Wo, T(0));
            continue;
          }
          std::fill(out, out + run.lo, T(0));
          if (run.hi > run.lo) std::copy_n(source + run.at(iy), run.hi - run.lo, out + run.lo);
          std::fill(out + run.hi, out + Wo, T(0));
        }
      }
  }
}

// dx (C x H x W) += scatter of dcol; dx must be zeroed by the caller. With stride > 1 the sums build up in the
// phase layout (the same additions in the same order) and are moved to dx at the end of each channel.
template <typename T>
void col2im(const T* col, int C, int H, int W, int k, int s, int p, int Ho, int Wo, T* dx) {
  const int Wp = (W + s - 1) / s;
  thread_local std::vector<T> split;
  for (int c = 0; c < C; ++c) {
    T* plane = dx + static_cast<int64_t>(c) * H * W;
    if (s > 1) split.assign(static_cast<size_t>(H) * s * Wp, T(0));
    for (int ki = 0; ki < k; ++ki)
      for (int kj = 0; kj < k; ++kj) {
        const T* row = col + (static_cast<int64_t>(c * k + ki) * k + kj) * Ho * Wo;
        const ColumnRun run = column_run(W, s, p, kj, Wo);
        if (run.hi <= run.lo) continue;
        T* target = s == 1 ? plane : split.data();
        for (int oy = 0; oy < Ho; ++oy) {
          const int iy = oy * s - p + ki;
          if (iy < 0 || iy >= H) continue;
          const T* in = row + static_cast<int64_t>(oy) * Wo + run.lo;
          T* dst = target + run.at(iy);
          for (int i = 0; i < run.hi - run.lo; ++i) dst[i] += in[i];
        }
      }
    if (s > 1)
      for (int iy = 0; iy < H; ++iy) {
        T* out = plane + static_cast<int64_t>(iy) * W;
        const T* o = split.data() + static_cast<int64_t>(iy) * s * Wp;
        for (int r = 0; r < s; ++r)
          for (int j = r, i = r * Wp; j < W; j += s, ++i) out[j] += o[i];
      }
  }
}

}  // namespace

template <typename T>
Conv2d<T>::Conv2d(const Conv2dSettings& s) : s_(s) {
  require(s.in_channels > 0 && s.out_channels > 0 && s.kernel > 0 && s.stride > 0 && s.padding >= 0,
          "conv2d: channels, kernel and stride must be positive and padding non-negative");
}

template <typename T>
Json Conv2d<T>::hyperparams() const {
  return {{"type", type()},       {"in", s_.in_channels}, {"out", s_.out_channels}, {"kernel", s_.kernel},
          {"stride", s_.stride}, {"padding", s_.padding}, {"bias", s_.bias}};
}

template <typename T>
size_t Conv2d<T>::n_params() const {
  return static_cast<size_t>(s_.out_channels) * s_.in_channels * s_.kernel * s_.kernel + (s_.bias ? s_.out_channels : 0);
}

template <typename T>
void Conv2d<T>::init_params(T* w, Rng& rng) const {
  const int64_t kk = int64_t(s_.kernel) * s_.kernel;
  const size_t nw = static_cast<size_t>(s_.out_channels) * s_.in_channels * kk;
  xavier_uniform(w, nw, s_.in_channels * kk, s_.out_channels * kk, rng);
  if (s_.bias) std::fill(w + nw, w + nw + s_.out_channels, T(0));
}

template <typename T>
Shape Conv2d<T>::output_shape(const Shape& in) const {
  require(in.size() == 4 && in[1] == s_.in_channels,
          "conv2d: expected N x " + std::to_string(s_.in_channels) + " x H x W input, got " + shape_string(in));
  const int64_t ho = (in[2] + 2 * s_.padding - s_.kernel) / s_.stride + 1;
  const int64_t wo = (in[3] + 2 * s_.padding - s_.kernel) / s_.stride + 1;
  require(in[2] + 2 * s_.padding >= s_.kernel && in[3] + 2 * s_.padding >= s_.kernel,
          "conv2d: input " + shape_string(in) + " is smaller than the kernel");
  return {in[0], s_.out_channels, ho, wo};
}

template <typename T>
double Conv2d<T>::forward_flops(const Shape& in) const {
  const Shape os = output_shape(in);
  return 2.0 * static_cast<double>(os[0]) * static_cast<double>(os[1]) * static_cast<double>(os[2] * os[3]) *
         s_.in_channels * s_.kernel * s_.kernel;
}

template <typename T>
void Conv2d<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  this->require_bound(false);
  const Shape os = output_shape(x.shape);
  y.resize(os);
  const int C = s_.in_channels, H = int(x.dim(2)), W = int(x.dim(3)), k = s_.kernel, st = s_.stride,
            p = s_.padding, Ho = int(os[2]), Wo = int(os[3]), O = s_.out_channels;
  const int64_t CK = int64_t(C) * k * k, HWo = int64_t(Ho) * Wo;
  const bool direct = (k == 1 && st == 1 && p == 0);
  ConstMatMapT<T> Wm(this->w_, O, CK);
  parallel_items(x.batch(), [&](int64_t n) {
    thread_local AlignedVector<T> col;
    const T* colp = x.item(n);
    if (!direct) {
      col.resize(static_cast<size_t>(CK * HWo));
      im2col(x.item(n), C, H, W, k, st, p, Ho, Wo, col.data());
      colp = col.data();
    }
    MatMapT<T> Y(y.item(n), O, HWo);
    Y.noalias() = Wm * ConstMatMapT<T>(colp, CK, HWo);
    if (s_.bias) {
      const T* b = this->w_ + O * CK;
      for (int o = 0; o < O; ++o) Y.row(o).array() += b[o];
    }
  });
}

template <typename T>
void Conv2d<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  this->require_bound(true);
  const Shape os = output_shape(x.shape);
  require(dy.shape == os, "conv2d backward: dy " + shape_string(dy.shape) + " != output " + shape_string(os));
  const int C = s_.in_channels, H = int(x.dim(2)), W = int(x.dim(3)), k = s_.kernel, st = s_.stride,
            p = s_.padding, Ho = int(os[2]), Wo = int(os[3]), O = s_.out_channels;
  const int64_t CK = int64_t(C) * k * k, HWo = int64_t(Ho) * Wo;
  const bool direct = (k == 1 && st == 1 && p == 0);
  if (dx) dx->resize(x.shape);
  ConstMatMapT<T> Wm(this->w_, O, CK);
  const auto chunks = fixed_chunks(x.batch(), 1, kMaxReduceChunks);
  const size_t np = n_params();
  std::vector<AlignedVector<T>> partial(chunks.size() > 1 ? chunks.size() : 0);
  parallel_chunks(chunks, [&](size_t c, int64_t begin, int64_t end) {
    T* g = chunk_gradient(partial, c, np, this->g_);
    MatMapT<T> gW(g, O, CK);
    thread_local AlignedVector<T> col, dcol;
    for (int64_t n = begin; n < end; ++n) {
      const T* colp = x.item(n);
      if (!direct) {
        col.resize(static_cast<size_t>(CK * HWo));
        im2col(x.item(n), C, H, W, k, st, p, Ho, Wo, col.data());
        colp = col.data();
      }
      ConstMatMapT<T> dY(dy.item(n), O, HWo);
      gW.noalias() += dY * ConstMatMapT<T>(colp, CK, HWo).transpose();
      if (s_.bias)
        for (int o = 0; o < O; ++o) g[O * CK + o] += dY.row(o).sum();
      if (dx) {
        if (direct) {
          MatMapT<T>(dx->item(n), CK, HWo).noalias() = Wm.transpose() * dY;
        } else {
          dcol.resize(static_cast<size_t>(CK * HWo));
          MatMapT<T>(dcol.data(), CK, HWo).noalias() = Wm.transpose() * dY;
          T* dxn = dx->item(n);
          std::fill(dxn, dxn + x.item_size(), T(0));
          col2im(dcol.data(), C, H, W, k, st, p, Ho, Wo, dxn);
        }
      }
    }
  });
  add_partials(partial, this->g_, np);
}

// ----------------------------------------------------------------------------------------------- Linear
namespace {
constexpr int64_t kLinearMinRows = 256;  // rows per chunk at least (keeps each GEMM large)
constexpr int64_t kLinearMaxForwardChunks = 64;
}  // namespace

template <typename T>
Linear<T>::Linear(const LinearSettings& s) : s_(s) {
  require(s.in_features > 0 && s.out_features > 0, "linear: feature counts must be positive");
}

template <typename T>
Json Linear<T>::hyperparams() const {
  return {{"type", type()}, {"in", s_.in_features}, {"out", s_.out_features}, {"bias", s_.bias}};
}

template <typename T>
size_t Linear<T>::n_params() const {
  return static_cast<size_t>(s_.in_features) * s_.out_features + (s_.bias ? s_.out_features : 0);
}

template <typename T>
void Linear<T>::init_params(T* w, Rng& rng) const {
  const size_t nw = static_cast<size_t>(s_.in_features) * s_.out_features;
  xavier_uniform(w, nw, s_.in_features, s_.out_features, rng);
  if (s_.bias) std::fill(w + nw, w + nw + s_.out_features, T(0));
}

template <typename T>
Shape Linear<T>::output_shape(const Shape& in) const {
  require(!in.empty() && in.back() == s_.in_features,
          "linear: expected ... x " + std::to_string(s_.in_features) + " input, got " + shape_string(in));
  Shape out = in;
  out.back() = s_.out_features;
  return out;
}

template <typename T>
double Linear<T>::forward_flops(const Shape& in) const {
  (void)output_shape(in);  // checks the input
  const size_t rows = shape_size(in) / static_cast<size_t>(s_.in_features);  // the input's leading dimensions
  return 2.0 * static_cast<double>(rows) * s_.in_features * s_.out_features;
}

template <typename T>
void Linear<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  this->require_bound(false);
  y.resize(output_shape(x.shape));
  const int64_t I = s_.in_features, O = s_.out_features, R = x.size() / I;
  ConstMatMapT<T> Wm(this->w_, O, I);
  const T* b = this->w_ + O * I;
  parallel_chunks(fixed_chunks(R, kLinearMinRows, kLinearMaxForwardChunks), [&](size_t, int64_t r0, int64_t r1) {
    MatMapT<T> Y(y.ptr() + r0 * O, r1 - r0, O);
    Y.noalias() = ConstMatMapT<T>(x.ptr() + r0 * I, r1 - r0, I) * Wm.transpose();
    if (s_.bias) Y.rowwise() += Eigen::Map<const Eigen::Matrix<T, 1, Eigen::Dynamic>>(b, O);
  });
}

template <typename T>
void Linear<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  this->require_bound(true);
  require(dy.shape == output_shape(x.shape), "linear backward: dy " + shape_string(dy.shape) + " does not match");
  const int64_t I = s_.in_features, O = s_.out_features, R = x.size() / I;
  ConstMatMapT<T> Wm(this->w_, O, I);
  if (dx) dx->resize(x.shape);
  const auto chunks = fixed_chunks(R, kLinearMinRows, kMaxReduceChunks);
  const size_t np = n_params();
  std::vector<AlignedVector<T>> partial(chunks.size() > 1 ? chunks.size() : 0);
  parallel_chunks(chunks, [&](size_t c, int64_t r0, int64_t r1) {
    T* g = chunk_gradient(partial, c, np, this->g_);
    ConstMatMapT<T> dY(dy.ptr() + r0 * O, r1 - r0, O);
    ConstMatMapT<T> X(x.ptr() + r0 * I, r1 - r0, I);
    MatMapT<T>(g, O, I).noalias() += dY.transpose() * X;
    if (s_.bias) Eigen::Map<Eigen::Matrix<T, 1, Eigen::Dynamic>>(g + O * I, O) += dY.colwise().sum();
    if (dx) MatMapT<T>(dx->ptr() + r0 * I, r1 - r0, I).noalias() = dY * Wm;
  });
  add_partials(partial, this->g_, np);
}

// ----------------------------------------------------------------------------------------------- Activation
template <typename T>
std::string Activation<T>::type() const {
  switch (kind_) {
    case ActivationKind::kReLU: return "relu";
    case ActivationKind::kLeakyReLU: return "leaky_relu";
    case ActivationKind::kSigmoid: return "sigmoid";
    case ActivationKind::kTanh: return "tanh";
  }
  return "activation";
}

template <typename T>
Json Activation<T>::hyperparams() const {
  Json j = {{"type", type()}};
  if (kind_ == ActivationKind::kLeakyReLU) j["slope"] = slope_;
  return j;
}

template <typename T>
void Activation<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  y.resize(x.shape);
  const int64_t n = x.size();
  const T* a = x.ptr();
  T* b = y.ptr();
  const T slope = static_cast<T>(slope_);
  switch (kind_) {
    case ActivationKind::kReLU:
      for (int64_t i = 0; i < n; ++i) b[i] = a[i] > T(0) ? a[i] : T(0);
      break;
    case ActivationKind::kLeakyReLU:
      for (int64_t i = 0; i < n; ++i) b[i] = a[i] > T(0) ? a[i] : slope * a[i];
      break;
    case ActivationKind::kSigmoid:
      for (int64_t i = 0; i < n; ++i)
        b[i] = a[i] >= T(0) ? T(1) / (T(1) + std::exp(-a[i])) : std::exp(a[i]) / (T(1) + std::exp(a[i]));
      break;
    case ActivationKind::kTanh:
      for (int64_t i = 0; i < n; ++i) b[i] = std::tanh(a[i]);
      break;
  }
}

template <typename T>
void Activation<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  if (!dx) return;
  require(dy.size() == x.size() && y.size() == x.size(), type() + " backward: sizes differ");
  dx->resize(x.shape);
  const int64_t n = x.size();
  const T *a = x.ptr(), *o = y.ptr(), *g = dy.ptr();
  T* d = dx->ptr();
  const T slope = static_cast<T>(slope_);
  switch (kind_) {
    case ActivationKind::kReLU:
      for (int64_t i = 0; i < n; ++i) d[i] = a[i] > T(0) ? g[i] : T(0);
      break;
    case ActivationKind::kLeakyReLU:
      for (int64_t i = 0; i < n; ++i) d[i] = a[i] > T(0) ? g[i] : slope * g[i];
      break;
    case ActivationKind::kSigmoid:
      for (int64_t i = 0; i < n; ++i) d[i] = g[i] * o[i] * (T(1) - o[i]);
      break;
    case ActivationKind::kTanh:
      for (int64_t i = 0; i < n; ++i) d[i] = g[i] * (T(1) - o[i] * o[i]);
      break;
  }
}

// ----------------------------------------------------------------------------------------------- Pooling
template <typename T>
Json Pool2d<T>::hyperparams() const {
  return {{"type", type()}, {"kernel", k_}, {"stride", s_}};
}

template <typename T>
Shape Pool2d<T>::output_shape(const Shape& in) const {
  require(k_ > 0 && s_ > 0, type() + ": kernel and stride must be positive");
  require(in.size() == 4 && in[2] >= k_ && in[3] >= k_,
          type() + ": expected N x C x H x W with H, W >= kernel, got " + shape_string(in));
  return {in[0], in[1], (in[2] - k_) / s_ + 1, (in[3] - k_) / s_ + 1};
}

template <typename T>
void Pool2d<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  const Shape os = output_shape(x.shape);
  y.resize(os);
  const int64_t H = x.dim(2), W = x.dim(3), Ho = os[2], Wo = os[3], planes = x.dim(0) * x.dim(1);
  const T inv = T(1) / T(k_ * k_);
  parallel_items(planes, [&](int64_t pl) {
    const T* in = x.ptr() + pl * H * W;
    T* out = y.ptr() + pl * Ho * Wo;
    for (int64_t oy = 0; oy < Ho; ++oy)
      for (int64_t ox = 0; ox < Wo; ++ox) {
        T acc = kind_ == PoolKind::kMax ? -std::numeric_limits<T>::infinity() : T(0);
        for (int ki = 0; ki < k_; ++ki)
          for (int kj = 0; kj < k_; ++kj) {
            const T v = in[(oy * s_ + ki) * W + ox * s_ + kj];
            if (kind_ == PoolKind::kMax)
              acc = v > acc ? v : acc;
            else
              acc += v;
          }
        out[oy * Wo + ox] = kind_ == PoolKind::kMax ? acc : acc * inv;
      }
  });
}

template <typename T>
void Pool2d<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  if (!dx) return;
  const Shape os = output_shape(x.shape);
  require(dy.shape == os, type() + " backward: dy shape mismatch");
  dx->assign(x.shape, T(0));
  const int64_t H = x.dim(2), W = x.dim(3), Ho = os[2], Wo = os[3], planes = x.dim(0) * x.dim(1);
  const T inv = T(1) / T(k_ * k_);
  parallel_items(planes, [&](int64_t pl) {
    const T* in = x.ptr() + pl * H * W;
    const T* g = dy.ptr() + pl * Ho * Wo;
    T* d = dx->ptr() + pl * H * W;
    for (int64_t oy = 0; oy < Ho; ++oy)
      for (int64_t ox = 0; ox < Wo; ++ox) {
        const T go = g[oy * Wo + ox];
        if (kind_ == PoolKind::kMax) {
          int64_t best = (oy * s_) * W + ox * s_;
          for (int ki = 0; ki < k_; ++ki)
            for (int kj = 0; kj < k_; ++kj) {
              const int64_t idx = (oy * s_ + ki) * W + ox * s_ + kj;
              if (in[idx] > in[best]) best = idx;
            }
          d[best] += go;
        } else {
          for (int ki = 0; ki < k_; ++ki)
            for (int kj = 0; kj < k_; ++kj) d[(oy * s_ + ki) * W + ox * s_ + kj] += go * inv;
        }
      }
  });
}

template <typename T>
Shape GlobalPool<T>::output_shape(const Shape& in) const {
  require(in.size() == 4 && in[2] * in[3] > 0, type() + ": expected N x C x H x W, got " + shape_string(in));
  return {in[0], in[1]};
}

template <typename T>
void GlobalPool<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  y.resize(output_shape(x.shape));
  const int64_t HW = x.dim(2) * x.dim(3);
  parallel_items(x.dim(0), [&](int64_t n) {
    for (int64_t c = 0; c < x.dim(1); ++c) {
      const int64_t pl = n * x.dim(1) + c;
      const T* in = x.ptr() + pl * HW;
      if (kind_ == PoolKind::kMax) {
        T m = in[0];
        for (int64_t i = 1; i < HW; ++i) m = in[i] > m ? in[i] : m;
        y[pl] = m;
      } else {
        T s = 0;
        for (int64_t i = 0; i < HW; ++i) s += in[i];
        y[pl] = s / T(HW);
      }
    }
  });
}

template <typename T>
void GlobalPool<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  if (!dx) return;
  require(dy.shape == output_shape(x.shape), type() + " backward: dy shape mismatch");
  dx->resize(x.shape);
  const int64_t HW = x.dim(2) * x.dim(3), planes = x.dim(0) * x.dim(1);
  for (int64_t pl = 0; pl < planes; ++pl) {
    const T* in = x.ptr() + pl * HW;
    T* d = dx->ptr() + pl * HW;
    if (kind_ == PoolKind::kMax) {
      std::fill(d, d + HW, T(0));
      int64_t best = 0;
      for (int64_t i = 1; i < HW; ++i)
        if (in[i] > in[best]) best = i;
      d[best] = dy[pl];
    } else {
      std::fill(d, d + HW, dy[pl] / T(HW));
    }
  }
}

// ----------------------------------------------------------------------------------------------- Resize
namespace {

struct Tap {
  int64_t i0, i1;
  double f;  // weight of i1
};

std::vector<Tap> resize_taps(int64_t in, int64_t out, bool align) {
  std::vector<Tap> taps(static_cast<size_t>(out));
  for (int64_t d = 0; d < out; ++d) {
    double src;
    if (align)
      src = out > 1 ? static_cast<double>(d) * static_cast<double>(in - 1) / static_cast<double>(out - 1) : 0.0;
    else
      src = (static_cast<double>(d) + 0.5) * static_cast<double>(in) / static_cast<double>(out) - 0.5;
    src = std::clamp(src, 0.0, static_cast<double>(in - 1));
    int64_t i0 = static_cast<int64_t>(std::floor(src));
    i0 = std::min(i0, std::max<int64_t>(0, in - 2));
    const int64_t i1 = std::min(i0 + 1, in - 1);
    taps[static_cast<size_t>(d)] = {i0, i1, in > 1 ? src - static_cast<double>(i0) : 0.0};
  }
  return taps;
}

}  // namespace

template <typename T>
Json BilinearResize<T>::hyperparams() const {
  return {{"type", type()}, {"height", h_}, {"width", w_out_}, {"align_corners", align_}};
}

template <typename T>
Shape BilinearResize<T>::output_shape(const Shape& in) const {
  require(h_ > 0 && w_out_ > 0, "resize_bilinear: output size must be positive");
  require(in.size() == 4 && in[2] > 0 && in[3] > 0, "resize_bilinear: expected N x C x H x W, got " + shape_string(in));
  return {in[0], in[1], h_, w_out_};
}

template <typename T>
void BilinearResize<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  const Shape os = output_shape(x.shape);
  y.resize(os);
  const int64_t H = x.dim(2), W = x.dim(3), planes = x.dim(0) * x.dim(1);
  const auto ty = resize_taps(H, h_, align_), tx = resize_taps(W, w_out_, align_);
  parallel_items(planes, [&](int64_t pl) {
    const T* in = x.ptr() + pl * H * W;
    T* out = y.ptr() + pl * int64_t(h_) * w_out_;
    for (int64_t oy = 0; oy < h_; ++oy) {
      const Tap& a = ty[oy];
      const T fy = static_cast<T>(a.f);
      const T* r0 = in + a.i0 * W;
      const T* r1 = in + a.i1 * W;
      for (int64_t ox = 0; ox < w_out_; ++ox) {
        const Tap& b = tx[ox];
        const T fx = static_cast<T>(b.f);
        const T top = r0[b.i0] + fx * (r0[b.i1] - r0[b.i0]);
        const T bot = r1[b.i0] + fx * (r1[b.i1] - r1[b.i0]);
        out[oy * w_out_ + ox] = top + fy * (bot - top);
      }
    }
  });
}

template <typename T>
void BilinearResize<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy,
                                 TensorT<T>* dx) const {
  (void)y;
  if (!dx) return;
  require(dy.shape == output_shape(x.shape), "resize_bilinear backward: dy shape mismatch");
  dx->assign(x.shape, T(0));
  const int64_t H = x.dim(2), W = x.dim(3), planes = x.dim(0) * x.dim(1);
  const auto ty = resize_taps(H, h_, align_), tx = resize_taps(W, w_out_, align_);
  parallel_items(planes, [&](int64_t pl) {
    const T* g = dy.ptr() + pl * int64_t(h_) * w_out_;
    T* d = dx->ptr() + pl * H * W;
    for (int64_t oy = 0; oy < h_; ++oy) {
      const Tap& a = ty[oy];
      const T fy = static_cast<T>(a.f);
      for (int64_t ox = 0; ox < w_out_; ++ox) {
        const Tap& b = tx[ox];
        const T fx = static_cast<T>(b.f);
        const T go = g[oy * w_out_ + ox];
        d[a.i0 * W + b.i0] += go * (T(1) - fy) * (T(1) - fx);
        d[a.i0 * W + b.i1] += go * (T(1) - fy) * fx;
        d[a.i1 * W + b.i0] += go * fy * (T(1) - fx);
        d[a.i1 * W + b.i1] += go * fy * fx;
      }
    }
  });
}

// ----------------------------------------------------------------------------------------------- Flatten
template <typename T>
Shape Flatten<T>::output_shape(const Shape& in) const {
  require(!in.empty(), "flatten: empty shape");
  return {in[0], shape_size(in) / std::max<int64_t>(1, in[0])};
}

template <typename T>
void Flatten<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  y.shape = output_shape(x.shape);
  y.data = x.data;
}

template <typename T>
void Flatten<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  if (!dx) return;
  require(dy.size() == x.size(), "flatten backward: size mismatch");
  dx->shape = x.shape;
  dx->data = dy.data;
}

// ----------------------------------------------------------------------------------------------- Sequential
template <typename T>
Json Sequential<T>::hyperparams() const {
  Json layers = Json::array();
  for (const auto& l : layers_) layers.push_back(l->hyperparams());
  return {{"type", type()}, {"layers", layers}};
}

template <typename T>
size_t Sequential<T>::n_params() const {
  size_t n = 0;
  for (const auto& l : layers_) n += l->n_params();
  return n;
}

template <typename T>
void Sequential<T>::init_params(T* w, Rng& rng) const {
  for (const auto& l : layers_) {
    l->init_params(w, rng);
    w += l->n_params();
  }
}

template <typename T>
void Sequential<T>::bind(T* w, T* g) {
  Layer<T>::bind(w, g);
  for (const auto& l : layers_) {
    l->bind(w, g);
    const size_t n = l->n_params();
    if (w) w += n;
    if (g) g += n;
  }
}

template <typename T>
Shape Sequential<T>::output_shape(const Shape& in) const {
  Shape s = in;
  for (const auto& l : layers_) s = l->output_shape(s);
  return s;
}

template <typename T>
double Sequential<T>::forward_flops(const Shape& in) const {
  double flops = 0;
  Shape s = in;
  for (const auto& l : layers_) {
    flops += l->forward_flops(s);
    s = l->output_shape(s);
  }
  return flops;
}

template <typename T>
void Sequential<T>::forward(const TensorT<T>& x, TensorT<T>& y) const {
  if (layers_.empty()) {
    y = x;
    return;
  }
  if (training_) {
    forward_into(x, acts_);
    y = acts_.back();
    return;
  }
  acts_.clear();
  const TensorT<T>* in = &x;
  for (size_t i = 0; i + 1 < layers_.size(); ++i) {
    TensorT<T>& out = (i % 2 == 0) ? ping_ : pong_;
    layers_[i]->forward(*in, out);
    in = &out;
  }
  layers_.back()->forward(*in, y);
}

template <typename T>
void Sequential<T>::backward(const TensorT<T>& x, const TensorT<T>& y, const TensorT<T>& dy, TensorT<T>* dx) const {
  (void)y;
  require(training_ && acts_.size() == layers_.size(),
          "sequential backward: call training(true) and forward() on the same input first");
  if (layers_.empty()) {
    if (dx) *dx = dy;
    return;
  }
  const TensorT<T>* g = &dy;
  for (size_t i = layers_.size(); i-- > 0;) {
    const TensorT<T>& in = i == 0 ? x : acts_[i - 1];
    TensorT<T>* out = nullptr;
    if (i > 0)
      out = (i % 2 == 0) ? &grad_a_ : &grad_b_;
    else
      out = dx;
    // The first layer skips its input gradient when the caller does not want dx.
    layers_[i]->backward(in, acts_[i], *g, out);
    g = out;
  }
}

template <typename T>
void Sequential<T>::forward_into(const TensorT<T>& x, std::vector<TensorT<T>>& acts) const {
  acts.resize(layers_.size());
  const TensorT<T>* in = &x;
  for (size_t i = 0; i < layers_.size(); ++i) {
    layers_[i]->forward(*in, acts[i]);
    in = &acts[i];
  }
}

template <typename T>
void Sequential<T>::backward_from(const TensorT<T>& x, const std::vector<TensorT<T>>& acts, const TensorT<T>& dy,
                                  TensorT<T>* dx) const {
  require(acts.size() == layers_.size(), "sequential backward: the activations are not this chain's");
  TensorT<T> g = dy, prev;
  for (size_t i = layers_.size(); i-- > 0;) {
    const TensorT<T>& in = i == 0 ? x : acts[i - 1];
    const bool need_dx = i > 0 || dx != nullptr;
    layers_[i]->backward(in, acts[i], g, need_dx ? &prev : nullptr);
    if (need_dx) std::swap(g, prev);
  }
  if (dx) *dx = std::move(g);
}

template <typename T>
void Sequential<T>::run(const TensorT<T>& x, TensorT<T>& y) const {
  TensorT<T> a, b;
  run(x, y, a, b);
}

template <typename T>
void Sequential<T>::run(const TensorT<T>& x, TensorT<T>& y, TensorT<T>& a, TensorT<T>& b) const {
  const TensorT<T>* in = &x;
  for (size_t i = 0; i < layers_.size(); ++i) {
    TensorT<T>& out = (i + 1 == layers_.size()) ? y : (i % 2 == 0 ? a : b);
    layers_[i]->forward(*in, out);
    in = &out;
  }
  if (layers_.empty()) y = x;
}

template <typename T>
double Sequential<T>::flops(Shape in, double* first, Shape* out) const {
  double total = 0;
  for (size_t i = 0; i < layers_.size(); ++i) {
    const double f = layers_[i]->forward_flops(in);
    if (i == 0 && first) *first = f;
    total += f;
    in = layers_[i]->output_shape(in);
  }
  if (out) *out = in;
  return total;
}

template <typename T>
std::unique_ptr<Sequential<T>> make_point_mlp(const std::vector<int>& channels, ActivationKind act,
                                              bool last_activation) {
  require(channels.size() >= 2, "point MLP: need at least input and output channel counts");
  auto s = std::make_unique<Sequential<T>>();
  for (size_t i = 0; i + 1 < channels.size(); ++i) {
    s->template emplace<Linear<T>>(channels[i], channels[i + 1]);
    if (i + 2 < channels.size() || last_activation) s->template emplace<Activation<T>>(act);
  }
  return s;
}

// ----------------------------------------------------------------------------------------------- concat, broadcast
namespace {
int normalize_axis(int axis, int rank) {
  const int a = axis < 0 ? axis + rank : axis;
  require(a >= 0 && a < rank, "concat: axis " + std::to_string(axis) + " out of range for rank " +
                                  std::to_string(rank));
  return a;
}
}  // namespace

template <typename T>
void concat(const std::vector<const TensorT<T>*>& inputs, int axis, TensorT<T>& y) {
  require(!inputs.empty(), "concat: no inputs");
  const Shape& s0 = inputs[0]->shape;
  const int a = normalize_axis(axis, static_cast<int>(s0.size()));
  Shape out = s0;
  out[a] = 0;
  for (const auto* t : inputs) {
    require(t->shape.size() == s0.size(), "concat: ranks differ");
    for (size_t d = 0; d < s0.size(); ++d)
      require(static_cast<int>(d) == a || t->shape[d] == s0[d],
              "concat: shapes " + shape_string(s0) + " and " + shape_string(t->shape) + " differ off the axis");
    out[a] += t->shape[a];
  }
  int64_t outer = 1, inner = 1;
  for (int d = 0; d < a; ++d) outer *= s0[d];
  for (size_t d = a + 1; d < s0.size(); ++d) inner *= s0[d];
  y.resize(out);
  const int64_t row = out[a] * inner;
  for (int64_t o = 0; o < outer; ++o) {
    T* dst = y.ptr() + o * row;
    for (const auto* t : inputs) {
      const int64_t n = t->shape[a] * inner;
      std::copy(t->ptr() + o * n, t->ptr() + (o + 1) * n, dst);
      dst += n;
    }
  }
}

template <typename T>
void concat_backward(const TensorT<T>& dy, const std::vector<Shape>& input_shapes, int axis,
                     const std::vector<TensorT<T>*>& dxs) {
  require(dxs.size() == input_shapes.size() && !input_shapes.empty(), "concat_backward: one gradient per input");
  const int a = normalize_axis(axis, dy.rank());
  int64_t outer = 1, inner = 1, total = 0;
  for (int d = 0; d < a; ++d) outer *= dy.shape[d];
  for (int d = a + 1; d < dy.rank(); ++d) inner *= dy.shape[d];
  for (const auto& s : input_shapes) total += s.at(a);
  require(total == dy.shape[a], "concat_backward: input shapes do not add up to dy");
  for (size_t i = 0; i < dxs.size(); ++i)
    if (dxs[i]) dxs[i]->resize(input_shapes[i]);
  const int64_t row = dy.shape[a] * inner;
  for (int64_t o = 0; o < outer; ++o) {
    const T* src = dy.ptr() + o * row;
    for (size_t i = 0; i < dxs.size(); ++i) {
      const int64_t n = input_shapes[i][a] * inner;
      if (dxs[i]) std::copy(src, src + n, dxs[i]->ptr() + o * n);
      src += n;
    }
  }
}

template <typename T>
void broadcast_points(const TensorT<T>& x, int64_t points, TensorT<T>& y) {
  require(x.rank() == 2 && points > 0, "broadcast_points: expected N x C input and P > 0, got " + shape_string(x.shape));
  const int64_t N = x.dim(0), C = x.dim(1);
  y.resize({N, points, C});
  for (int64_t n = 0; n < N; ++n)
    for (int64_t p = 0; p < points; ++p) std::copy(x.item(n), x.item(n) + C, y.ptr() + (n * points + p) * C);
}

template <typename T>
void broadcast_points_backward(const TensorT<T>& dy, TensorT<T>& dx) {
  require(dy.rank() == 3, "broadcast_points_backward: expected N x P x C, got " + shape_string(dy.shape));
  const int64_t N = dy.dim(0), P = dy.dim(1), C = dy.dim(2);
  dx.assign({N, C}, T(0));
  for (int64_t n = 0; n < N; ++n)
    for (int64_t p = 0; p < P; ++p) {
      const T* g = dy.ptr() + (n * P + p) * C;
      T* d = dx.item(n);
      for (int64_t c = 0; c < C; ++c) d[c] += g[c];
    }
}

#define SDFKIT_NETS_INSTANTIATE(T)                                                                           \
  template class Conv2d<T>;                                                                                  \
  template class Linear<T>;                                                                                  \
  template class Activation<T>;                                                                              \
  template class Pool2d<T>;                                                                                  \
  template class GlobalPool<T>;                                                                              \
  template class BilinearResize<T>;                                                                          \
  template class Flatten<T>;                                                                                 \
  template class Sequential<T>;                                                                              \
  template std::unique_ptr<Sequential<T>> make_point_mlp<T>(const std::vector<int>&, ActivationKind, bool);   \
  template void concat<T>(const std::vector<const TensorT<T>*>&, int, TensorT<T>&);                          \
  template void concat_backward<T>(const TensorT<T>&, const std::vector<Shape>&, int,                        \
                                   const std::vector<TensorT<T>*>&);                                         \
  template void broadcast_points<T>(const TensorT<T>&, int64_t, TensorT<T>&);                                \
  template void broadcast_points_backward<T>(const TensorT<T>&, TensorT<T>&);

SDFKIT_NETS_INSTANTIATE(float)
SDFKIT_NETS_INSTANTIATE(double)

}  // namespace sdfkit
