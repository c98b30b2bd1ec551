#include "camera/rotation6d.h"
#include "core/random.h"
#include "core/types.h"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

template <typename S>
void check_rotation(const Mat3T<S>& R, double tol) {
  REQUIRE(R.allFinite());
  const double orth = (R.transpose() * R - Mat3T<S>::Identity()).cwiseAbs().maxCoeff();
  CHECK(orth < tol);
  CHECK(std::abs(static_cast<double>(R.determinant()) - 1.0) < tol);
}

Vec6T<double> random6(Rng& rng, double scale = 1.0) {
  Vec6T<double> b;
  for (int i = 0; i < 6; ++i) b[i] = scale * rng.normal();
  return b;
}

// Loss L = sum(W .* R) for a fixed random W: dL/dR = W.
double loss(const Vec6T<double>& b, const Mat3& W) { return (rot6d_to_matrix(b).array() * W.array()).sum(); }

}  // namespace

TEST_CASE("rot6d: Gram-Schmidt matches the definition and gives rotations") {
  Rng rng(1);
  for (int k = 0; k < 200; ++k) {
    const Vec6T<double> b = random6(rng);
    const Mat3 R = rot6d_to_matrix(b);
    check_rotation(R, 1e-12);
    const Vec3 b1 = b.head<3>(), b2 = b.tail<3>();
    const Vec3 r1 = b1.normalized();
    const Vec3 r3 = r1.cross(b2).normalized();
    CHECK((R.col(0) - r1).norm() < 1e-12);
    CHECK((R.col(2) - r3).norm() < 1e-12);
    CHECK((R.col(1) - r3.cross(r1)).norm() < 1e-12);
    // r2 lies in the plane of b1, b2 on b2's side.
    CHECK(R.col(1).dot(b2) > 0);
  }
}

TEST_CASE("rot6d: round trip R -> 6D -> R") {
  Rng rng(2);
  for (int k = 0; k < 100; ++k) {
    const Mat3 R = rot6d_to_matrix(random6(rng));
    const Mat3 R2 = rot6d_to_matrix(matrix_to_rot6d(R));
    CHECK((R - R2).cwiseAbs().maxCoeff() < 1e-15 * 8);
  }
  const Mat3 I = rot6d_to_matrix(matrix_to_rot6d<double>(Mat3::Identity()));
  CHECK(I == Mat3::Identity());
}

TEST_CASE("rot6d: adversarial inputs give finite rotations and finite gradients") {
  std::vector<Vec6T<double>> cases;
  Vec6T<double> b;
  b << 1, 2, 3, 2, 4, 6;  // b2 parallel to b1
  cases.push_back(b);
  b << 1, 2, 3, -1, -2, -3;  // antiparallel
  cases.push_back(b);
  b << 1, 2, 3, 1 + 1e-12, 2, 3;  // nearly parallel
  cases.push_back(b);
  b << 1e-20, 2e-20, -1e-20, 3e-20, -1e-20, 5e-20;  // tiny
  cases.push_back(b);
  b << 1e20, -2e20, 1e20, 3e20, 1e20, -5e20;  // huge
  cases.push_back(b);
  b << 1e300, 1e300, 1e300, -1e300, 1e300, 1e-300;  // would overflow a naive norm
  cases.push_back(b);
  b << 1e-320, 0, 0, 0, 1e-320, 0;  // denormals
  cases.push_back(b);
  b.setZero();  // all zero
  cases.push_back(b);
  b << 0, 0, 0, 1, 2, 3;  // zero b1
  cases.push_back(b);
  b << 1, 2, 3, 0, 0, 0;  // zero b2
  cases.push_back(b);
  b << NAN, 1, 2, 3, 4, 5;  // non-finite
  cases.push_back(b);
  b << 1, 2, 3, INFINITY, 4, 5;
  cases.push_back(b);
  Rng rng(3);
  const Mat3 W = Mat3::Random();
  for (const auto& c : cases) {
    CAPTURE(c.transpose());
    check_rotation(rot6d_to_matrix(c), 1e-12);
    const Vec6T<double> g = rot6d_backward(c, W);
    CHECK(g.allFinite());
    // float too
    const Vec6T<float> cf = c.cast<float>();
    check_rotation(rot6d_to_matrix(cf), 1e-5);
    CHECK(rot6d_backward(cf, Mat3T<float>(W.cast<float>())).allFinite());
  }
  // Scale invariance: tiny and huge inputs give the rotation of the unit-scale input.
  const Vec6T<double> base = random6(rng);
  const Mat3 R0 = rot6d_to_matrix(base);
  for (double s : {1e-20, 1e20, 1e-300, 1e300}) CHECK((rot6d_to_matrix(Vec6T<double>(base * s)) - R0).norm() < 1e-13);
  // Tiny floats (1e-20 is a normal float): still the right rotation.
  CHECK((rot6d_to_matrix(Vec6T<float>((base * 1e-20).cast<float>())).cast<double>() - R0).norm() < 1e-5);
  // Parallel b2 falls back to the axis least aligned with b1 and ignores b2's gradient.
  Vec6T<double> par;
  par << 0, 0, 2, 0, 0, 5;
  const Rot6dForward<double> f = rot6d_forward(par);
  CHECK(f.b2_degenerate);
  CHECK((f.R.col(0) - Vec3::UnitZ()).norm() < 1e-15);
  CHECK(rot6d_backward(f, W).tail<3>().isZero());
}

TEST_CASE("rot6d: analytic gradient matches central finite differences") {
  Rng rng(4);
  for (int k = 0; k < 50; ++k) {
    const double scale = k < 25 ? 1.0 : std::pow(10.0, rng.uniform(-3, 3));
    const Vec6T<double> b = random6(rng, scale);
    Mat3 W;
    for (int i = 0; i < 9; ++i) W.data()[i] = rng.normal();
    const Vec6T<double> g = rot6d_backward(b, W);
    for (int i = 0; i < 6; ++i) {
      const double h = 1e-6 * std::max(1e-300, b.cwiseAbs().maxCoeff());
      Vec6T<double> bp = b, bm = b;
      bp[i] += h;
      bm[i] -= h;
      const double fd = (loss(bp, W) - loss(bm, W)) / (2 * h);
      CHECK(std::abs(fd - g[i]) < 1e-6 * (1 + std::abs(fd)) / std::min(1.0, scale));
    }
    // The full Jacobian agrees with the vector-Jacobian product.
    const Eigen::Matrix<double, 9, 6> J = rot6d_jacobian(b);
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> w(W.data());  // column-major vec
    CHECK((J.transpose() * w - g).norm() < 1e-10 * (1 + g.norm()));
  }
}

TEST_CASE("rot6d: float gradient agrees with double") {
  Rng rng(5);
  for (int k = 0; k < 20; ++k) {
    const Vec6T<double> b = random6(rng);
    const Mat3 W = Mat3::Random();
    const Vec6T<double> gd = rot6d_backward(b, W);
    const Vec6T<float> gf = rot6d_backward(Vec6T<float>(b.cast<float>()), Mat3T<float>(W.cast<float>()));
    CHECK((gf.cast<double>() - gd).norm() < 1e-3 * (1 + gd.norm()));
  }
}
