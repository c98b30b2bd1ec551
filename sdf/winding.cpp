#include "sdf/winding.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace sdfkit {
namespace {
constexpr double kInv4Pi = 1.0 / (4.0 * M_PI);
}

WindingNumber::WindingNumber(const Mesh& mesh, double beta) : bvh_(TriangleBvh::build(mesh, 8)), beta_(beta) {
  require(beta > 0, "WindingNumber: beta must be positive");
  expansion_.resize(bvh_.nodes.size());
  // Children follow their parent in `nodes` (pre-order), so a reverse sweep sees children first; but the
  // first-order term needs the node's own centre, so each node sums its triangles directly (O(#F log #F)).
  for (size_t n = 0; n < bvh_.nodes.size(); ++n) {
    const auto& node = bvh_.nodes[n];
    Expansion& e = expansion_[n];
    double area = 0;
    Vec3 weighted = Vec3::Zero();
    e.normal_sum.setZero();
    for (int32_t s = node.begin; s < node.end; ++s) {
      const auto& t = bvh_.corners[s];
      const Vec3 an = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
      const double a = an.norm();
      area += a;
      weighted += a * (t[0] + t[1] + t[2]) / 3.0;
      e.normal_sum += an;
    }
    e.center = area > 0 ? Vec3(weighted / area) : node.box.center();
    e.first.setZero();
    for (auto& m : e.second) m.setZero();
    double r2 = 0;
    for (int32_t s = node.begin; s < node.end; ++s) {
      const auto& t = bvh_.corners[s];
      const Vec3 an = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
      const Vec3 c = (t[0] + t[1] + t[2]) / 3.0;
      e.first += (c - e.center) * an.transpose();
      // Second moment of the triangle about the centre: A/12 (a a^T + b b^T + c c^T + s s^T), s = a + b + c.
      const Vec3 a = t[0] - e.center, b = t[1] - e.center, cc = t[2] - e.center, sum = a + b + cc;
      const Mat3 moment =
          (a * a.transpose() + b * b.transpose() + cc * cc.transpose() + sum * sum.transpose()) / 12.0;
      for (int i = 0; i < 3; ++i) e.second[i] += an[i] * moment;  // an = area * unit normal
      for (int k = 0; k < 3; ++k) r2 = std::max(r2, (t[k] - e.center).squaredNorm());
    }
    e.radius2 = beta * beta * r2;
  }
}

double WindingNumber::operator()(const Vec3& p) const {
  if (bvh_.nodes.empty()) return 0.0;
  double w = 0;
  int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int32_t n = stack[--top];
    const auto& node = bvh_.nodes[n];
    const Expansion& e = expansion_[n];
    const Vec3 y = e.center - p;
    const double d2 = y.squaredNorm();
    if (d2 > e.radius2) {
      // w = integral of f(x - p) . n dA with f(y) = y / (4 pi |y|^3), Taylor-expanded about y0 = centre - p:
      // order 0: f(y0) . N; order 1: J_f(y0) : M with J_f = (I / r^3 - 3 y y^T / r^5) / 4 pi; order 2:
      // 1/2 d2f_i/dy_j dy_k C_ijk with d2f_i/dy_j dy_k = (-3 (d_ij y_k + d_ik y_j + d_jk y_i) / r^5
      // + 15 y_i y_j y_k / r^7) / 4 pi.
      const double d = std::sqrt(d2);
      const double inv3 = 1.0 / (d2 * d);
      const double inv5 = inv3 / d2;
      const double inv7 = inv5 / d2;
      double o2 = 0;
      {
        double cubic = 0, lin = 0;
        for (int i = 0; i < 3; ++i) {
          cubic += y[i] * y.dot(e.second[i] * y);
          lin += y[i] * e.second[i].trace() + 2.0 * y.dot(e.second[i].row(i).transpose());
        }
        o2 = 0.5 * (-3.0 * lin * inv5 + 15.0 * cubic * inv7);
      }
      w += kInv4Pi * (y.dot(e.normal_sum) * inv3 + e.first.trace() * inv3 - 3.0 * y.dot(e.first * y) * inv5 + o2);
      continue;
    }
    if (node.leaf()) {
      double omega = 0;
      for (int32_t s = node.begin; s < node.end; ++s) {
        const auto& t = bvh_.corners[s];
        omega += triangle_solid_angle(p, t[0], t[1], t[2]);
      }
      w += omega * kInv4Pi;
      continue;
    }
    stack[top++] = node.right;
    stack[top++] = node.left;
  }
  return w;
}

Eigen::VectorXd WindingNumber::query(const Points& P) const {
  Eigen::VectorXd w(P.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 256), [&](const auto& r) {
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) w[i] = (*this)(P.row(i).transpose());
  });
  return w;
}

double WindingNumber::brute_force(const Mesh& mesh, const Vec3& p) {
  double omega = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    omega += triangle_solid_angle(p, mesh.V.row(mesh.F(f, 0)).transpose(), mesh.V.row(mesh.F(f, 1)).transpose(),
                                  mesh.V.row(mesh.F(f, 2)).transpose());
  return omega * kInv4Pi;
}

Eigen::VectorXd winding_numbers(const Mesh& mesh, const Points& P, double beta) {
  return WindingNumber(mesh, beta).query(P);
}

}  // namespace sdfkit
