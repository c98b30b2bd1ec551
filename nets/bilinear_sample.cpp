#include "nets/bilinear_sample.h"

#include "nets/layer.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {
namespace {

template <typename T>
struct Cell {
  int64_t x0, x1, y0, y1;
  T fx, fy;
  bool clamped_x, clamped_y;
  T sx, sy;  // d(map coordinate) / d(input coordinate)
};

// One axis: clamp, pick the cell, fraction.
template <typename T>
void axis_cell(T v, int64_t size, T scale, int64_t& i0, int64_t& i1, T& f, bool& clamped) {
  T c = v * scale;
  const T hi = static_cast<T>(size - 1);
  clamped = !(c >= T(0) && c <= hi);  // also catches NaN
  if (!(c >= T(0))) c = T(0);
  if (!(c <= hi)) c = hi;
  if (size == 1) {
    i0 = i1 = 0;
    f = T(0);
    return;
  }
  i0 = std::min<int64_t>(static_cast<int64_t>(std::floor(c)), size - 2);
  i1 = i0 + 1;
  f = c - static_cast<T>(i0);
}

template <typename T>
Cell<T> make_cell(T x, T y, int64_t H, int64_t W, const BilinearSampleSettings& s) {
  Cell<T> c{};
  c.sx = s.reference_width > 1 ? static_cast<T>(W - 1) / static_cast<T>(s.reference_width - 1) : T(1);
  c.sy = s.reference_height > 1 ? static_cast<T>(H - 1) / static_cast<T>(s.reference_height - 1) : T(1);
  axis_cell(x, W, c.sx, c.x0, c.x1, c.fx, c.clamped_x);
  axis_cell(y, H, c.sy, c.y0, c.y1, c.fy, c.clamped_y);
  return c;
}

template <typename T>
void check(const TensorT<T>& maps, const TensorT<T>& positions) {
  require(maps.rank() == 4 && maps.dim(2) > 0 && maps.dim(3) > 0,
          "bilinear_sample: maps must be N x C x H x W, got " + shape_string(maps.shape));
  require(positions.rank() == 3 && positions.dim(2) == 2 && positions.dim(0) == maps.dim(0),
          "bilinear_sample: positions must be N x P x 2 with the maps' N, got " + shape_string(positions.shape) +
              " for maps " + shape_string(maps.shape));
}

}  // namespace

template <typename T>
void bilinear_sample(const TensorT<T>& maps, const TensorT<T>& positions, TensorT<T>& features,
                     const BilinearSampleSettings& settings) {
  check(maps, positions);
  const int64_t N = maps.dim(0), C = maps.dim(1), H = maps.dim(2), W = maps.dim(3), P = positions.dim(1);
  const int64_t HW = H * W;
  features.resize({N, P, C});
  parallel_items(N, [&](int64_t n) {
    const T* m = maps.item(n);
    for (int64_t p = 0; p < P; ++p) {
      const T* pos = positions.item(n) + 2 * p;
      const Cell<T> c = make_cell(pos[0], pos[1], H, W, settings);
      const int64_t i00 = c.y0 * W + c.x0, i01 = c.y0 * W + c.x1, i10 = c.y1 * W + c.x0, i11 = c.y1 * W + c.x1;
      const T w00 = (T(1) - c.fy) * (T(1) - c.fx), w01 = (T(1) - c.fy) * c.fx, w10 = c.fy * (T(1) - c.fx),
              w11 = c.fy * c.fx;
      T* out = features.ptr() + (n * P + p) * C;
      for (int64_t ch = 0; ch < C; ++ch) {
        const T* pl = m + ch * HW;
        out[ch] = w00 * pl[i00] + w01 * pl[i01] + w10 * pl[i10] + w11 * pl[i11];
      }
    }
  });
}

template <typename T>
void bilinear_accumulate_hwc(const T* map_hwc, int64_t H, int64_t W, int64_t C, T x, T y,
                             const BilinearSampleSettings& settings, T* acc) {
  const Cell<T> c = make_cell(x, y, H, W, settings);
  const T w00 = (T(1) - c.fy) * (T(1) - c.fx), w01 = (T(1) - c.fy) * c.fx, w10 = c.fy * (T(1) - c.fx),
          w11 = c.fy * c.fx;
  const T* p00 = map_hwc + (c.y0 * W + c.x0) * C;
  const T* p01 = map_hwc + (c.y0 * W + c.x1) * C;
  const T* p10 = map_hwc + (c.y1 * W + c.x0) * C;
  const T* p11 = map_hwc + (c.y1 * W + c.x1) * C;
  // Same expression, term order and association as bilinear_sample, so both give identical values.
  for (int64_t ch = 0; ch < C; ++ch) acc[ch] += w00 * p00[ch] + w01 * p01[ch] + w10 * p10[ch] + w11 * p11[ch];
}

template <typename T>
void bilinear_sample_backward(const TensorT<T>& maps, const TensorT<T>& positions, const TensorT<T>& dfeatures,
                              TensorT<T>* dmaps, TensorT<T>* dpositions, const BilinearSampleSettings& settings) {
  check(maps, positions);
  const int64_t N = maps.dim(0), C = maps.dim(1), H = maps.dim(2), W = maps.dim(3), P = positions.dim(1);
  const int64_t HW = H * W;
  require(dfeatures.shape == Shape({N, P, C}), "bilinear_sample_backward: dfeatures " +
                                                   shape_string(dfeatures.shape) + " != " +
                                                   shape_string({N, P, C}));
  if (dmaps && dmaps->shape != maps.shape) dmaps->assign(maps.shape, T(0));
  if (dpositions) dpositions->resize(positions.shape);
  // Each item writes only its own map slice and positions: parallel over items, serial (ordered) inside.
  parallel_items(N, [&](int64_t n) {
    const T* m = maps.item(n);
    T* dm = dmaps ? dmaps->item(n) : nullptr;
    for (int64_t p = 0; p < P; ++p) {
      const T* pos = positions.item(n) + 2 * p;
      const Cell<T> c = make_cell(pos[0], pos[1], H, W, settings);
      const int64_t i00 = c.y0 * W + c.x0, i01 = c.y0 * W + c.x1, i10 = c.y1 * W + c.x0, i11 = c.y1 * W + c.x1;
      const T* g = dfeatures.ptr() + (n * P + p) * C;
      if (dm) {
        const T w00 = (T(1) - c.fy) * (T(1) - c.fx), w01 = (T(1) - c.fy) * c.fx, w10 = c.fy * (T(1) - c.fx),
                w11 = c.fy * c.fx;
        for (int64_t ch = 0; ch < C; ++ch) {
          T* pl = dm + ch * HW;
          pl[i00] += w00 * g[ch];
          pl[i01] += w01 * g[ch];
          pl[i10] += w10 * g[ch];
          pl[i11] += w11 * g[ch];
        }
      }
      if (dpositions) {
        T gx = 0, gy = 0;
        for (int64_t ch = 0; ch < C; ++ch) {
          const T* pl = m + ch * HW;
          const T v00 = pl[i00], v01 = pl[i01], v10 = pl[i10], v11 = pl[i11];
          gx += g[ch] * ((T(1) - c.fy) * (v01 - v00) + c.fy * (v11 - v10));
          gy += g[ch] * ((T(1) - c.fx) * (v10 - v00) + c.fx * (v11 - v01));
        }
        T* dp = dpositions->item(n) + 2 * p;
        dp[0] = (c.clamped_x || W == 1) ? T(0) : gx * c.sx;
        dp[1] = (c.clamped_y || H == 1) ? T(0) : gy * c.sy;
      }
    }
  });
}

template void bilinear_sample<float>(const Tensor&, const Tensor&, Tensor&, const BilinearSampleSettings&);
template void bilinear_sample<double>(const TensorD&, const TensorD&, TensorD&, const BilinearSampleSettings&);
template void bilinear_sample_backward<float>(const Tensor&, const Tensor&, const Tensor&, Tensor*, Tensor*,
                                              const BilinearSampleSettings&);
template void bilinear_sample_backward<double>(const TensorD&, const TensorD&, const TensorD&, TensorD*, TensorD*,
                                               const BilinearSampleSettings&);

template void bilinear_accumulate_hwc<float>(const float*, int64_t, int64_t, int64_t, float, float,
                                              const BilinearSampleSettings&, float*);
template void bilinear_accumulate_hwc<double>(const double*, int64_t, int64_t, int64_t, double, double,
                                               const BilinearSampleSettings&, double*);

}  // namespace sdfkit
