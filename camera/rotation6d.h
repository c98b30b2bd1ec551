// The continuous 6D rotation representation (Zhou et al., CVPR 2019) used by DISN's camera network:
// 6D (b1, b2) -> R by Gram-Schmidt, R -> 6D, and the analytic backward pass dL/db from dL/dR.
// Header-only templates on the scalar type: the networks use float, tests use double.
//
// Forward (docs/DESIGN.md):  r1 = N(b1),  r3 = N(r1 x b2),  r2 = r3 x r1,  R = [r1 r2 r3] (columns).
// R is orthonormal with det +1 by construction. b1 = (b[0], b[1], b[2]), b2 = (b[3], b[4], b[5]).
//
// Numerical safety (never NaN, never Inf, for any finite or non-finite input):
//  * Scale: each of b1, b2 is first divided by its largest |component| (Gram-Schmidt does not depend on the
//    length of b1 or b2), so |b| ~ 1e-20 or 1e20 (or 1e-300 / 1e300 in double) neither under- nor overflows.
//  * Degenerate b1 (all zero, or a non-finite component): r1 = e_x and dL/db1 = 0.
//  * Degenerate b2 (zero, non-finite, or nearly parallel to b1: |r1 x b2| <= tol * |b2| with
//    tol = sqrt(machine epsilon), i.e. ~1.5e-8 rad in double and ~3.5e-4 rad in float): b2 is replaced by the
//    coordinate axis least aligned with r1 (smallest |r1_k|, lowest k on ties), and dL/db2 = 0. Gradients still
//    flow into b1 through r1 x axis. Just above the threshold the gradient wrt b2 is large (~1/(tol |b2|)) but
//    finite.
//  * The returned R is re-orthogonalised in floating point (r3 projected off r1 and renormalised), which is the
//    identity in exact arithmetic, so the analytic gradient below is unchanged by it.
//  * Gradients wrt the unscaled inputs are g_scaled / scale; when that overflows (|b| below ~1e-38 in float)
//    the components are clamped to +-max(): finite, with the right sign.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {

template <typename S>
using Vec6T = Eigen::Matrix<S, 6, 1>;
template <typename S>
using Mat3T = Eigen::Matrix<S, 3, 3>;
template <typename S>
using Vec3T = Eigen::Matrix<S, 3, 1>;

/// Everything the backward pass needs, computed once by the forward pass (cheap: ~30 scalars).
template <typename S>
struct Rot6dForward {
  Mat3T<S> R = Mat3T<S>::Identity();  ///< the rotation, columns r1 r2 r3
  Vec3T<S> c = Vec3T<S>::Zero();      ///< b2 after scaling (or the fallback axis)
  S n1 = S(1);                        ///< |b1 / s1|
  S nu = S(1);                        ///< |r1 x c|
  S s1 = S(1), s2 = S(1);             ///< scale factors (max |component|) of b1 and b2
  bool b1_degenerate = false;         ///< r1 = e_x was used
  bool b2_degenerate = false;         ///< a fallback axis replaced b2
};

namespace detail {

template <typename S>
bool all_finite3(const Vec3T<S>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

template <typename S>
S clamp_finite(S v) {
  const S m = std::numeric_limits<S>::max();
  if (std::isnan(v)) return S(0);
  return std::min(m, std::max(-m, v));
}

}  // namespace detail

/// Forward pass with the intermediates kept for rot6d_backward().
template <typename S>
Rot6dForward<S> rot6d_forward(const Vec6T<S>& b) {
  Rot6dForward<S> f;
  const S tol = std::sqrt(std::numeric_limits<S>::epsilon());
  Vec3T<S> b1 = b.template head<3>();
  Vec3T<S> b2 = b.template tail<3>();

  Vec3T<S> r1;
  f.s1 = detail::all_finite3(b1) ? b1.cwiseAbs().maxCoeff() : S(0);
  if (!(f.s1 > S(0))) {
    f.b1_degenerate = true;
    f.s1 = S(1);
    f.n1 = S(1);
    r1 = Vec3T<S>::UnitX();
  } else {
    const Vec3T<S> a = b1 / f.s1;  // largest component is exactly +-1: no under/overflow in the norm
    f.n1 = a.norm();
    r1 = a / f.n1;
  }

  f.s2 = detail::all_finite3(b2) ? b2.cwiseAbs().maxCoeff() : S(0);
  Vec3T<S> u;
  bool fallback = !(f.s2 > S(0));
  if (!fallback) {
    f.c = b2 / f.s2;
    u = r1.cross(f.c);
    f.nu = u.norm();
    fallback = !(f.nu > tol * f.c.norm());
  }
  if (fallback) {
    f.b2_degenerate = true;
    f.s2 = S(1);
    int k = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(r1[i]) < std::abs(r1[k])) k = i;
    f.c = Vec3T<S>::Unit(k);
    u = r1.cross(f.c);
    f.nu = u.norm();  // >= sqrt(2/3) since |r1_k| <= 1/sqrt(3)
  }
  Vec3T<S> r3 = u / f.nu;
  // Floating-point clean-up (identity in exact arithmetic): make r3 exactly orthogonal to r1.
  r3 -= r1 * r1.dot(r3);
  r3.normalize();
  const Vec3T<S> r2 = r3.cross(r1);
  f.R.col(0) = r1;
  f.R.col(1) = r2;
  f.R.col(2) = r3;
  return f;
}

/// 6D -> rotation matrix (columns r1, r2, r3). See the header comment for the fallbacks.
template <typename S>
Mat3T<S> rot6d_to_matrix(const Vec6T<S>& b) {
  return rot6d_forward(b).R;
}

/// Rotation matrix -> 6D: its first two columns. rot6d_to_matrix(matrix_to_rot6d(R)) == R up to rounding
/// for any rotation R.
template <typename S>
Vec6T<S> matrix_to_rot6d(const Mat3T<S>& R) {
  Vec6T<S> b;
  b.template head<3>() = R.col(0);
  b.template tail<3>() = R.col(1);
  return b;
}

/// Vector-Jacobian product: dL/db (6) from dL/dR (3x3, same layout as R) at the forward state `f`.
template <typename S>
Vec6T<S> rot6d_backward(const Rot6dForward<S>& f, const Mat3T<S>& dL_dR) {
  const Vec3T<S> r1 = f.R.col(0), r3 = f.R.col(2);
  const Vec3T<S> g1 = dL_dR.col(0), g2 = dL_dR.col(1), g3 = dL_dR.col(2);
  // r2 = r3 x r1
  const Vec3T<S> gr3 = g3 + r1.cross(g2);
  Vec3T<S> gr1 = g1 + g2.cross(r3);
  // r3 = u / |u|
  const Vec3T<S> gu = (gr3 - r3 * r3.dot(gr3)) / f.nu;
  // u = r1 x c
  gr1 += f.c.cross(gu);
  const Vec3T<S> gc = gu.cross(r1);
  // r1 = a / |a|
  const Vec3T<S> ga = (gr1 - r1 * r1.dot(gr1)) / f.n1;
  Vec6T<S> g;
  for (int i = 0; i < 3; ++i) {
    g[i] = f.b1_degenerate ? S(0) : detail::clamp_finite(ga[i] / f.s1);
    g[3 + i] = f.b2_degenerate ? S(0) : detail::clamp_finite(gc[i] / f.s2);
  }
  return g;
}

/// Convenience: dL/db from b and dL/dR (recomputes the forward pass).
template <typename S>
Vec6T<S> rot6d_backward(const Vec6T<S>& b, const Mat3T<S>& dL_dR) {
  return rot6d_backward(rot6d_forward(b), dL_dR);
}

/// Full 9 x 6 Jacobian d vec(R) / d b with vec(R) column-major: rows 0-2 = r1, 3-5 = r2, 6-8 = r3.
template <typename S>
Eigen::Matrix<S, 9, 6> rot6d_jacobian(const Vec6T<S>& b) {
  const Rot6dForward<S> f = rot6d_forward(b);
  Eigen::Matrix<S, 9, 6> J;
  for (int k = 0; k < 9; ++k) {
    Mat3T<S> G = Mat3T<S>::Zero();
    G(k % 3, k / 3) = S(1);
    J.row(k) = rot6d_backward(f, G).transpose();
  }
  return J;
}

}  // namespace sdfkit
