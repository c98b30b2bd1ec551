#include "core/primitives.h"

#include "core/error.h"

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace sdfkit {

Mesh make_sphere(const Vec3& center, double radius, int stacks, int slices) {
  require(stacks >= 2 && slices >= 3 && radius > 0, "make_sphere: need stacks >= 2, slices >= 3, radius > 0");
  Mesh m;
  const int rings = stacks - 1;
  m.V.resize(2 + rings * slices, 3);
  m.V.row(0) = (center + Vec3(0, 0, radius)).transpose();
  for (int i = 1; i <= rings; ++i) {
    const double theta = M_PI * i / stacks;
    for (int j = 0; j < slices; ++j) {
      const double phi = 2 * M_PI * j / slices;
      m.V.row(1 + (i - 1) * slices + j) =
          (center + radius * Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)))
              .transpose();
    }
  }
  const int south = 1 + rings * slices;
  m.V.row(south) = (center - Vec3(0, 0, radius)).transpose();
  std::vector<std::array<int32_t, 3>> F;
  for (int j = 0; j < slices; ++j) F.push_back({0, 1 + j, 1 + (j + 1) % slices});
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < slices; ++j) {
      const int a = 1 + i * slices + j, b = 1 + i * slices + (j + 1) % slices;
      const int c = a + slices, d = b + slices;
      F.push_back({a, c, d});
      F.push_back({a, d, b});
    }
  for (int j = 0; j < slices; ++j) {
    const int a = 1 + (rings - 1) * slices + j, b = 1 + (rings - 1) * slices + (j + 1) % slices;
    F.push_back({a, south, b});
  }
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) m.F.row(static_cast<Eigen::Index>(f)) << F[f][0], F[f][1], F[f][2];
  return m;
}

Mesh make_icosphere(const Vec3& center, double radius, int levels) {
  require(levels >= 0 && levels <= 8 && radius > 0, "make_icosphere: need 0 <= levels <= 8, radius > 0");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> V = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : V) v.normalize();
  std::vector<std::array<int32_t, 3>> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                           {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                           {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                           {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int32_t, int32_t>, int32_t> mid;
    auto midpoint = [&](int32_t a, int32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      const auto idx = static_cast<int32_t>(V.size() - 1);
      mid.emplace(key, idx);
      return idx;
    };
    std::vector<std::array<int32_t, 3>> next;
    for (const auto& f : F) {
      const int32_t a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.push_back({f[0], a, c});
      next.push_back({f[1], b, a});
      next.push_back({f[2], c, b});
      next.push_back({a, b, c});
    }
    F = std::move(next);
  }
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = (center + radius * V[i]).transpose();
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) m.F.row(static_cast<Eigen::Index>(f)) << F[f][0], F[f][1], F[f][2];
  return m;
}

Mesh make_box(const Vec3& lo, const Vec3& hi) {
  require((lo.array() < hi.array()).all(), "make_box: need lo < hi on every axis");
  Mesh m;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    m.V.row(i) << ((i & 1) ? hi.x() : lo.x()), ((i & 2) ? hi.y() : lo.y()), ((i & 4) ? hi.z() : lo.z());
  m.F.resize(12, 3);
  m.F << 0, 2, 1, 1, 2, 3,  // z = lo
      4, 5, 6, 5, 7, 6,     // z = hi
      0, 1, 4, 1, 5, 4,     // y = lo
      2, 6, 3, 3, 6, 7,     // y = hi
      0, 4, 2, 2, 4, 6,     // x = lo
      1, 3, 5, 3, 7, 5;     // x = hi
  return m;
}

Mesh make_torus(const Vec3& center, double R, double r, int major_segments, int minor_segments) {
  require(R > r && r > 0 && major_segments >= 3 && minor_segments >= 3, "make_torus: need R > r > 0, segments >= 3");
  Mesh m;
  m.V.resize(major_segments * minor_segments, 3);
  m.F.resize(2 * major_segments * minor_segments, 3);
  for (int i = 0; i < major_segments; ++i) {
    const double u = 2 * M_PI * i / major_segments;
    for (int j = 0; j < minor_segments; ++j) {
      const double v = 2 * M_PI * j / minor_segments;
      m.V.row(i * minor_segments + j) =
          (center + Vec3((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)))
              .transpose();
    }
  }
  int f = 0;
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) {
      const int i1 = (i + 1) % major_segments, j1 = (j + 1) % minor_segments;
      const int a = i * minor_segments + j, b = i1 * minor_segments + j, c = i1 * minor_segments + j1,
                d = i * minor_segments + j1;
      m.F.row(f++) << a, b, c;
      m.F.row(f++) << a, c, d;
    }
  return m;
}

double sphere_sdf(const Vec3& p, const Vec3& center, double radius) { return (p - center).norm() - radius; }

double box_sdf(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const Vec3 q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double torus_sdf(const Vec3& p, const Vec3& center, double R, double r) {
  const Vec3 q = p - center;
  const double ring = std::hypot(q.x(), q.y()) - R;
  return std::hypot(ring, q.z()) - r;
}

double signed_volume(const Mesh& mesh) {
  double v = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    v += a.dot(b.cross(c));
  }
  return v / 6.0;
}

double surface_area(const Mesh& mesh) {
  double s = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    s += (b - a).cross(c - a).norm();
  }
  return s / 2.0;
}

}  // namespace sdfkit
