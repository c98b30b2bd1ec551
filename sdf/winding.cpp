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
    double r2 = 0;
    for (int32_t s = node.begin; s < node.end; ++s) {
      const auto& t = bvh_.corners[s];
      const Vec3 an = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
      const Vec3 c = (t[0] + t[1] + t[2]) / 3.0;
      e.first += (c - e.center) * an.transpose();
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
      // f(y) = y / (4 pi |y|^3); w ~ f(y0) . N + J_f(y0) : M, J_f = (I |y|^2 - 3 y y^T) / (4 pi |y|^5).
      const double d = std::sqrt(d2);
      const double inv3 = 1.0 / (d2 * d);
      const double inv5 = inv3 / d2;
      w += kInv4Pi * (y.dot(e.normal_sum) * inv3 + e.first.trace() * inv3 - 3.0 * y.dot(e.first * y) * inv5);
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
