#include "sdf/band_triangle.h"

#include "sdf/bvh.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {

BandTriangle BandTriangle::make(const Vec3& a, const Vec3& b, const Vec3& c) {
  BandTriangle t;
  t.v = {a, b, c};
  double longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    t.dir[k] = t.v[(k + 1) % 3] - t.v[k];
    t.len2[k] = t.dir[k].squaredNorm();
    t.inv_len2[k] = t.len2[k] > 0 ? 1.0 / t.len2[k] : 0.0;
    longest2 = std::max(longest2, t.len2[k]);
  }
  const Vec3 cross = (b - a).cross(c - a);
  const double area2 = cross.norm();  // twice the area
  // Smallest height / longest edge > 1e-6: the normal (and the in-plane edge normals) are accurate to ~1e-10.
  t.regular = longest2 > 0 && area2 > 1e-6 * longest2;
  if (!t.regular) return t;
  t.n = cross / area2;
  t.offset = t.n.dot(a);
  for (int k = 0; k < 3; ++k) {
    t.m[k] = t.dir[k].cross(t.n).normalized();  // points away from the opposite corner for (b - a) x (c - a)
    t.m_offset[k] = t.m[k].dot(t.v[k]);
  }
  return t;
}

double BandTriangle::squared_distance(const Vec3& p) const {
  if (!regular) return (closest_point_on_triangle(p, v[0], v[1], v[2]) - p).squaredNorm();
  const double plane = n.dot(p) - offset;
  double d2 = 1e300;
  bool outside = false;
  for (int k = 0; k < 3; ++k) {
    if (m[k].dot(p) - m_offset[k] <= 0) continue;
    outside = true;
    const Vec3 u = p - v[k];
    const double s = u.dot(dir[k]);
    const double t = std::clamp(s * inv_len2[k], 0.0, 1.0);
    d2 = std::min(d2, u.squaredNorm() - t * (2.0 * s - t * len2[k]));
  }
  return outside ? std::max(d2, 0.0) : plane * plane;
}

void BandTriangle::row_min(double px, double py, int32_t z_begin, int32_t count, int32_t index_offset, double h,
                           double* best, double limit2) const {
  if (!regular) {
    for (int32_t k = 0; k < count; ++k) {
      const Vec3 p(px, py, (z_begin + k - index_offset) * h);
      best[k] = std::min(best[k], (closest_point_on_triangle(p, v[0], v[1], v[2]) - p).squaredNorm());
    }
    return;
  }
  // Row constants: every quantity below is (row constant) + (z coefficient) * pz.
  const double plane0 = n.x() * px + n.y() * py - offset, plane_z = n.z();
  double edge0[3], edge_z[3];
  for (int j = 0; j < 3; ++j) {
    edge0[j] = m[j].x() * px + m[j].y() * py - m_offset[j];
    edge_z[j] = m[j].z();
  }
  if (count <= 0) return;
  {
    // The whole row at once: affine bounds reach their minimum at an end of the row.
    const double za = (z_begin - index_offset) * h, zb = (z_begin + count - 1 - index_offset) * h;
    const double pa = plane0 + plane_z * za, pb = plane0 + plane_z * zb;
    const double plane_min = pa * pb <= 0 ? 0.0 : std::min(std::abs(pa), std::abs(pb));
    double edge_min = 0;
    for (int j = 0; j < 3; ++j)
      edge_min = std::max(edge_min, std::min(edge0[j] + edge_z[j] * za, edge0[j] + edge_z[j] * zb));
    if (plane_min * plane_min + edge_min * edge_min >= limit2) return;
  }
  double s0[3], s_z[3], u0[3], vz[3];
  bool edges_ready = false;
  auto prepare_edges = [&] {
    for (int j = 0; j < 3; ++j) {
      const double ux = px - v[j].x(), uy = py - v[j].y();
      s0[j] = dir[j].x() * ux + dir[j].y() * uy - dir[j].z() * v[j].z();
      s_z[j] = dir[j].z();
      u0[j] = ux * ux + uy * uy;
      vz[j] = v[j].z();
    }
    edges_ready = true;
  };
  for (int32_t k = 0; k < count; ++k) {
    const double pz = (z_begin + k - index_offset) * h;
    const double plane = plane0 + plane_z * pz;
    const double plane2 = plane * plane;
    if (plane2 >= best[k]) continue;  // the plane distance is a lower bound
    const double e0 = edge0[0] + edge_z[0] * pz, e1 = edge0[1] + edge_z[1] * pz, e2 = edge0[2] + edge_z[2] * pz;
    const double emax = std::max(e0, std::max(e1, e2));
    if (emax <= 0) {  // the projection lies in the triangle
      best[k] = plane2;
      continue;
    }
    // The edge with the largest outward distance bounds the in-plane offset from below.
    if (plane2 + emax * emax >= best[k]) continue;
    if (!edges_ready) prepare_edges();
    const double e[3] = {e0, e1, e2};
    double d2 = 1e300;
    for (int j = 0; j < 3; ++j) {
      if (e[j] <= 0) continue;
      const double s = s0[j] + s_z[j] * pz;
      const double t = std::clamp(s * inv_len2[j], 0.0, 1.0);
      const double dz = pz - vz[j];
      d2 = std::min(d2, u0[j] + dz * dz - t * (2.0 * s - t * len2[j]));
    }
    best[k] = std::min(best[k], std::max(d2, 0.0));
  }
}

}  // namespace sdfkit
