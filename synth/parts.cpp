#include "synth/parts.h"

#include "core/error.h"
#include "core/primitives.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <tuple>

namespace sdfkit {
namespace {

using Tri = std::array<int32_t, 3>;

Mesh from_lists(const std::vector<Vec3>& V, const std::vector<Tri>& F) {
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(static_cast<Eigen::Index>(i)) << F[i][0], F[i][1], F[i][2];
  return m;
}

void flip(Mesh& m) { m.F.col(1).swap(m.F.col(2)); }

/// Two unit vectors u, w with u x w = unit(d).
void perpendicular_frame(const Vec3& d, Vec3& u, Vec3& w) {
  const Vec3 n = d.normalized();
  const Vec3 helper = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  u = helper.cross(n).normalized();
  w = n.cross(u);
}

/// Surface of the grid box with per-axis coordinate lists, mapped by `position(q)` where q holds the three
/// grid coordinates. Vertices are keyed by integer grid indices, so faces meeting at cube edges share them.
Mesh cube_grid(const std::array<std::vector<double>, 3>& coords, const std::function<Vec3(const Vec3&)>& position) {
  std::map<std::array<int, 3>, int32_t> index;
  std::vector<Vec3> V;
  std::vector<Tri> F;
  const std::array<int, 3> K = {static_cast<int>(coords[0].size()) - 1, static_cast<int>(coords[1].size()) - 1,
                                static_cast<int>(coords[2].size()) - 1};
  auto vertex = [&](const std::array<int, 3>& g) {
    const auto it = index.find(g);
    if (it != index.end()) return it->second;
    const Vec3 q(coords[0][g[0]], coords[1][g[1]], coords[2][g[2]]);
    V.push_back(position(q));
    const auto id = static_cast<int32_t>(V.size() - 1);
    index.emplace(g, id);
    return id;
  };
  for (int a = 0; a < 3; ++a) {
    const int ua = (a + 1) % 3, va = (a + 2) % 3;  // e_ua x e_va = e_a
    for (int side = 0; side < 2; ++side) {
      for (int u = 0; u < K[ua]; ++u)
        for (int v = 0; v < K[va]; ++v) {
          auto g = [&](int du, int dv) {
            std::array<int, 3> r{};
            r[a] = side == 0 ? 0 : K[a];
            r[ua] = u + du;
            r[va] = v + dv;
            return vertex(r);
          };
          const int32_t p00 = g(0, 0), p10 = g(1, 0), p11 = g(1, 1), p01 = g(0, 1);
          if (side == 1) {
            F.push_back({p00, p10, p11});
            F.push_back({p00, p11, p01});
          } else {
            F.push_back({p00, p11, p10});
            F.push_back({p00, p01, p11});
          }
        }
    }
  }
  return from_lists(V, F);
}

}  // namespace

Mat3 rot_x(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }
Mat3 rot_y(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Mat3 rot_z(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

Mat3 rot_z_to(const Vec3& axis) {
  require(axis.norm() > 0, "rot_z_to: zero axis");
  return Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), axis.normalized()).toRotationMatrix();
}

Mesh transformed(const Mesh& part, const Mat3& A, const Vec3& t) {
  Mesh out = part;
  for (Eigen::Index i = 0; i < out.V.rows(); ++i) out.V.row(i) = (A * part.V.row(i).transpose() + t).transpose();
  if (A.determinant() < 0) flip(out);
  return out;
}

Mesh make_hexahedron(const std::array<Vec3, 8>& c) {
  const std::vector<Vec3> V(c.begin(), c.end());
  const std::vector<Tri> F = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                              {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  Mesh out = from_lists(V, F);
  if (signed_volume(out) < 0) flip(out);  // corners given in a left-handed logical frame
  return out;
}

Mesh make_box_part(const Vec3& center, const Vec3& half, const Mat3& R) {
  require((half.array() > 0).all(), "make_box_part: half extents must be positive");
  std::array<Vec3, 8> c;
  for (int i = 0; i < 8; ++i) {
    const Vec3 s((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1);
    c[i] = center + R * s.cwiseProduct(half);
  }
  return make_hexahedron(c);
}

Mesh make_bar(const Vec3& a, const Vec3& b, double width, double depth, const Vec3& up) {
  const Vec3 d = b - a;
  require(d.norm() > 0 && width > 0 && depth > 0, "make_bar: need a != b and positive width and depth");
  const Vec3 z = d.normalized();
  Vec3 y = up - up.dot(z) * z;
  if (y.norm() < 1e-9 * up.norm() || y.norm() == 0) {
    Vec3 u, w;
    perpendicular_frame(z, u, w);
    y = w;
  }
  y.normalize();
  const Vec3 x = y.cross(z);
  Mat3 R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return make_box_part(0.5 * (a + b), Vec3(0.5 * width, 0.5 * depth, 0.5 * d.norm()), R);
}

Mesh make_rounded_box(const Vec3& center, const Vec3& half, double radius, const Mat3& R, int arc_segments) {
  require((half.array() > 0).all() && radius >= 0 && arc_segments >= 1,
          "make_rounded_box: need positive half extents, radius >= 0, arc_segments >= 1");
  const double r = std::min(radius, 0.9 * half.minCoeff());
  if (r <= 0) return make_box_part(center, half, R);
  std::array<std::vector<double>, 3> coords;
  for (int a = 0; a < 3; ++a) {
    // Band of width r at each end: angles 45 deg .. 0 from the face normal, spaced evenly in angle.
    std::vector<double> band;
    for (int k = arc_segments; k >= 0; --k) band.push_back(r * (1.0 - std::tan(M_PI / 4 * k / arc_segments)));
    for (const double t : band) coords[a].push_back(-half[a] + t);
    for (auto it = band.rbegin(); it != band.rend(); ++it) coords[a].push_back(half[a] - *it);
  }
  const Vec3 inner = half - Vec3::Constant(r);
  return cube_grid(coords, [&](const Vec3& q) {
    const Vec3 p = q.cwiseMax(-inner).cwiseMin(inner);
    const Vec3 n = (q - p).normalized();
    return Vec3(center + R * (p + r * n));
  });
}

Mesh make_ellipsoid(const Vec3& center, const Vec3& radii, const Mat3& R, int grid) {
  require((radii.array() > 0).all() && grid >= 1, "make_ellipsoid: need positive radii and grid >= 1");
  std::vector<double> t;
  for (int i = 0; i <= grid; ++i) t.push_back(std::tan(-M_PI / 4 + M_PI / 2 * i / grid));
  t.front() = -1;
  t.back() = 1;
  return cube_grid({t, t, t}, [&](const Vec3& q) { return Vec3(center + R * q.normalized().cwiseProduct(radii)); });
}

Mesh make_cone(const Vec3& a, const Vec3& b, double ra, double rb, int segments) {
  require((b - a).norm() > 0 && ra >= 0 && rb >= 0 && (ra > 0 || rb > 0) && segments >= 3,
          "make_cone: need a != b, radii >= 0 (not both 0), segments >= 3");
  Vec3 u, w;
  perpendicular_frame(b - a, u, w);
  std::vector<Vec3> V;
  std::vector<Tri> F;
  auto ring = [&](const Vec3& c, double r) {
    const auto start = static_cast<int32_t>(V.size());
    if (r == 0) {
      V.push_back(c);
      return std::make_pair(start, false);
    }
    for (int k = 0; k < segments; ++k) {
      const double phi = 2 * M_PI * k / segments;
      V.push_back(c + r * (std::cos(phi) * u + std::sin(phi) * w));
    }
    return std::make_pair(start, true);
  };
  const auto [b0, bring] = ring(a, ra);
  const auto [t0, tring] = ring(b, rb);
  for (int k = 0; k < segments; ++k) {
    const int k1 = (k + 1) % segments;
    const int32_t bk = bring ? b0 + k : b0, bk1 = bring ? b0 + k1 : b0;
    const int32_t tk = tring ? t0 + k : t0, tk1 = tring ? t0 + k1 : t0;
    if (bring) F.push_back({bk, bk1, tk1});
    if (tring) F.push_back({bk, tk1, tk});
  }
  if (bring) {
    const auto c = static_cast<int32_t>(V.size());
    V.push_back(a);
    for (int k = 0; k < segments; ++k) F.push_back({c, b0 + (k + 1) % segments, b0 + k});
  }
  if (tring) {
    const auto c = static_cast<int32_t>(V.size());
    V.push_back(b);
    for (int k = 0; k < segments; ++k) F.push_back({c, t0 + k, t0 + (k + 1) % segments});
  }
  return from_lists(V, F);
}

Mesh make_cylinder(const Vec3& a, const Vec3& b, double radius, int segments) {
  require(radius > 0, "make_cylinder: radius must be positive");
  return make_cone(a, b, radius, radius, segments);
}

Mesh make_torus_part(const Vec3& center, const Vec3& axis, double R, double r, int major_segments,
                     int minor_segments) {
  const Mesh t = make_torus(Vec3::Zero(), R, r, major_segments, minor_segments);
  return transformed(t, rot_z_to(axis), center);
}

Mesh make_loft(const std::vector<std::vector<Vec3>>& rings) {
  require(rings.size() >= 2, "make_loft: need at least two rings");
  const size_t M = rings[0].size();
  require(M >= 3, "make_loft: rings need at least 3 points");
  for (const auto& r : rings) require(r.size() == M, "make_loft: every ring needs the same number of points");
  std::vector<Vec3> V;
  std::vector<Tri> F;
  for (const auto& r : rings) V.insert(V.end(), r.begin(), r.end());
  const auto m = static_cast<int32_t>(M);
  for (size_t i = 0; i + 1 < rings.size(); ++i) {
    const auto base = static_cast<int32_t>(i * M);
    for (int32_t k = 0; k < m; ++k) {
      const int32_t k1 = (k + 1) % m;
      F.push_back({base + k, base + k1, base + m + k1});
      F.push_back({base + k, base + m + k1, base + m + k});
    }
  }
  auto centroid = [&](const std::vector<Vec3>& r) {
    Vec3 c = Vec3::Zero();
    for (const auto& p : r) c += p;
    return Vec3(c / static_cast<double>(r.size()));
  };
  const auto c0 = static_cast<int32_t>(V.size());
  V.push_back(centroid(rings.front()));
  for (int32_t k = 0; k < m; ++k) F.push_back({c0, (k + 1) % m, k});
  const auto c1 = static_cast<int32_t>(V.size());
  V.push_back(centroid(rings.back()));
  const auto last = static_cast<int32_t>((rings.size() - 1) * M);
  for (int32_t k = 0; k < m; ++k) F.push_back({c1, last + k, last + (k + 1) % m});
  Mesh out = from_lists(V, F);
  if (signed_volume(out) < 0) flip(out);
  return out;
}

Mesh make_tube(const std::vector<Vec3>& path, const std::vector<double>& radii, int segments) {
  require(path.size() >= 2 && segments >= 3, "make_tube: need >= 2 path points and >= 3 segments");
  require(radii.size() == 1 || radii.size() == path.size(), "make_tube: need one radius or one per path point");
  for (const double r : radii) require(r > 0, "make_tube: radii must be positive");
  const size_t n = path.size();
  std::vector<Vec3> seg_dir(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) {
    const Vec3 d = path[i + 1] - path[i];
    require(d.norm() > 0, "make_tube: consecutive path points must differ");
    seg_dir[i] = d.normalized();
  }
  // Parallel transport of a normal along the path keeps the rings from twisting.
  Vec3 u, w;
  perpendicular_frame(seg_dir[0], u, w);
  std::vector<std::vector<Vec3>> rings;
  for (size_t i = 0; i < n; ++i) {
    Vec3 t;
    double miter = 1;
    if (i == 0) {
      t = seg_dir[0];
    } else if (i == n - 1) {
      t = seg_dir[n - 2];
    } else {
      t = (seg_dir[i - 1] + seg_dir[i]);
      if (t.norm() < 1e-9) t = seg_dir[i];
      t.normalize();
      miter = 1.0 / std::max(0.5, t.dot(seg_dir[i]));
    }
    u = (u - u.dot(t) * t).normalized();
    w = t.cross(u);
    const double r = radii.size() == 1 ? radii[0] : radii[i];
    std::vector<Vec3> ring;
    // The mitre stretches the ring along the bend direction only.
    Vec3 bend = Vec3::Zero();
    if (i > 0 && i + 1 < n) {
      bend = seg_dir[i] - seg_dir[i - 1];
      bend = bend - bend.dot(t) * t;
      if (bend.norm() > 1e-12) bend.normalize();
    }
    for (int k = 0; k < segments; ++k) {
      const double phi = 2 * M_PI * k / segments;
      Vec3 off = r * (std::cos(phi) * u + std::sin(phi) * w);
      if (bend.norm() > 0) off += (miter - 1) * off.dot(bend) * bend;
      ring.push_back(path[i] + off);
    }
    rings.push_back(std::move(ring));
  }
  return make_loft(rings);
}

std::vector<Vec3> bezier(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, int n) {
  require(n >= 2, "bezier: need n >= 2");
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1), s = 1 - t;
    out.push_back(s * s * s * p0 + 3 * s * s * t * p1 + 3 * s * t * t * p2 + t * t * t * p3);
  }
  return out;
}

std::vector<Vec3> arc(const Vec3& center, const Vec3& u, const Vec3& v, double radius, double a0, double a1, int n) {
  require(n >= 2 && radius > 0, "arc: need n >= 2 and radius > 0");
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) {
    const double a = a0 + (a1 - a0) * i / (n - 1);
    out.push_back(center + radius * (std::cos(a) * u + std::sin(a) * v));
  }
  return out;
}

}  // namespace sdfkit
