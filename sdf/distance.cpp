#include "sdf/distance.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {
namespace {
/// Distance from x to the interval [lo, hi] (0 inside it): one axis of a point-to-box distance, from the float
/// bounds of the query layout.
inline double gap(float lo, float hi, double x) { return std::max(std::max(double(lo) - x, x - double(hi)), 0.0); }

double box_distance2(const Eigen::AlignedBox3d& b, const Vec3& p) {
  const Vec3 d = (b.min() - p).cwiseMax(p - b.max()).cwiseMax(0.0);
  return d.squaredNorm();
}

/// Visits the leaves of `bvh` whose boxes, grown by `margin`, meet the line o + t d for t in [0, tmax] (slab test),
/// calling `leaf(begin, end)` with each leaf's triangle slots; stops when it returns true, and then returns true.
template <typename Leaf>
bool any_leaf_on_line(const TriangleBvh& bvh, const Vec3& o, const Vec3& d, double tmax, double margin,
                      Leaf&& leaf) {
  int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const auto& node = bvh.nodes[static_cast<size_t>(stack[--top])];
    double t0 = 0, t1 = tmax;
    bool miss = false;
    for (int k = 0; k < 3 && !miss; ++k) {
      const double lo = node.box.min()[k] - margin, hi = node.box.max()[k] + margin;
      if (std::abs(d[k]) < 1e-300) {  // parallel to the slab
        miss = o[k] < lo || o[k] > hi;
        continue;
      }
      double ta = (lo - o[k]) / d[k], tb = (hi - o[k]) / d[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      miss = t0 > t1;
    }
    if (miss) continue;
    if (!node.leaf()) {
      stack[top++] = node.left;
      stack[top++] = node.right;
      continue;
    }
    if (leaf(node.begin, node.end)) return true;
  }
  return false;
}
}  // namespace

MeshDistance::MeshDistance(const Mesh& mesh) : bvh_(TriangleBvh::build(mesh, 4)) {
  require(mesh.F.rows() > 0, "MeshDistance: the mesh has no faces");
  slot_of_face_.resize(bvh_.face.size());
  for (size_t s = 0; s < bvh_.face.size(); ++s) slot_of_face_[static_cast<size_t>(bvh_.face[s])] = static_cast<int32_t>(s);
  require(bvh_.corners.size() < (size_t{1} << 27), "MeshDistance: too many triangles");
  require(!bvh_.nodes[0].leaf() || bvh_.nodes[0].end - bvh_.nodes[0].begin <= 7,
          "MeshDistance: BVH leaf larger than 7 triangles");
  // Rounded outward so that distances to the float box never exceed those to the exact box.
  auto round_down = [](double x) {
    float f = static_cast<float>(x);
    if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
  };
  auto round_up = [](double x) {
    float f = static_cast<float>(x);
    if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
  };
  qnodes_.resize(bvh_.nodes.size());
  for (size_t n = 0; n < bvh_.nodes.size(); ++n) {
    const auto& node = bvh_.nodes[n];
    QueryNode& q = qnodes_[n];
    q.begin = node.begin;
    q.end = node.end;
    if (node.leaf()) continue;
    const int32_t kids[2] = {node.left, node.right};
    for (int c = 0; c < 2; ++c) {
      const auto& kid = bvh_.nodes[static_cast<size_t>(kids[c])];
      require(!kid.leaf() || kid.end - kid.begin <= 7, "MeshDistance: BVH leaf larger than 7 triangles");
      q.child[c] = kid.leaf() ? leaf_code(kid.begin, kid.end) : kids[c];
      for (int a = 0; a < 3; ++a) {
        q.lo[a][c] = round_down(kid.box.min()[a]);
        q.hi[a][c] = round_up(kid.box.max()[a]);
      }
    }
  }
  slot_bound_.resize(bvh_.corners.size());
  for (size_t s = 0; s < bvh_.corners.size(); ++s) {
    const auto& t = bvh_.corners[s];
    SlotBound& sb = slot_bound_[s];
    for (int a = 0; a < 3; ++a) {
      sb.lo[a] = round_down(bvh_.boxes[s].min()[a]);
      sb.hi[a] = round_up(bvh_.boxes[s].max()[a]);
    }
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
    const double len = n.norm();
    // Only well-shaped triangles get a plane bound (a sliver's normal is not accurate enough to bound with).
    const double longest2 = std::max({(t[1] - t[0]).squaredNorm(), (t[2] - t[1]).squaredNorm(), (t[0] - t[2]).squaredNorm()});
    if (len > 1e-6 * longest2 && longest2 > 0) {
      const Vec3 u = n / len;
      sb.plane[0] = u.x(), sb.plane[1] = u.y(), sb.plane[2] = u.z(), sb.plane[3] = u.dot(t[0]);
    } else {
      sb.plane[0] = sb.plane[1] = sb.plane[2] = sb.plane[3] = 0;
    }
  }
}

ClosestPoint MeshDistance::closest(const Vec3& p, double upper_bound) const { return closest(p, upper_bound, -1); }

ClosestPoint MeshDistance::closest(const Vec3& p, double upper_bound, int32_t hint) const {
  ClosestPoint best;
  double best2 = upper_bound * upper_bound;
  best.distance = upper_bound;
  if (hint >= 0 && static_cast<size_t>(hint) < slot_of_face_.size()) {
    const auto& t = bvh_.corners[static_cast<size_t>(slot_of_face_[static_cast<size_t>(hint)])];
    int region = 0;
    const Vec3 q = closest_point_on_triangle(p, t[0], t[1], t[2], &region);
    const double d2 = (q - p).squaredNorm();
    if (d2 < best2) {
      best2 = d2;
      best.point = q;
      best.face = hint;
      best.region = region;
    }
  }
  struct Entry {
    int32_t node;  ///< inner node index, or a leaf_code
    double d2;
  };
  Entry stack[128];
  int top = 0;
  const auto& root = bvh_.nodes[0];
  stack[top++] = {root.leaf() ? leaf_code(root.begin, root.end) : 0, box_distance2(root.box, p)};
  const double px = p.x(), py = p.y(), pz = p.z();
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.d2 >= best2) continue;
    if (e.node < 0) {
      const int32_t code = -(e.node + 1), begin = code >> 3, end = begin + (code & 7);
      for (int32_t s = begin; s < end; ++s) {
        const SlotBound& sb = slot_bound_[static_cast<size_t>(s)];
        const double plane = sb.plane[0] * px + sb.plane[1] * py + sb.plane[2] * pz - sb.plane[3];  // a lower bound
        if (plane * plane > best2) continue;  // cannot be closer (ties still compared below)
        const double bx = gap(sb.lo[0], sb.hi[0], px), by = gap(sb.lo[1], sb.hi[1], py),
                     bz = gap(sb.lo[2], sb.hi[2], pz);
        if (bx * bx + by * by + bz * bz > best2) continue;
        const auto& t = bvh_.corners[static_cast<size_t>(s)];
        int region = 0;
        const Vec3 q = closest_point_on_triangle(p, t[0], t[1], t[2], &region);
        const double d2 = (q - p).squaredNorm();
        if (d2 < best2 || (d2 == best2 && best.face >= 0 && bvh_.face[s] < best.face)) {
          best2 = d2;
          best.point = q;
          best.face = bvh_.face[s];
          best.region = region;
        }
      }
      continue;
    }
    const QueryNode& node = qnodes_[static_cast<size_t>(e.node)];
    double d[2];
    for (int c = 0; c < 2; ++c) {
      const double dx = gap(node.lo[0][c], node.hi[0][c], px), dy = gap(node.lo[1][c], node.hi[1][c], py),
                   dz = gap(node.lo[2][c], node.hi[2][c], pz);
      d[c] = dx * dx + dy * dy + dz * dz;
    }
    // Push the farther child first so the nearer one is explored first; children beyond the bound not at all.
    const int near = d[0] < d[1] ? 0 : 1, far = 1 - near;
    if (d[far] < best2) stack[top++] = {node.child[far], d[far]};
    if (d[near] < best2) stack[top++] = {node.child[near], d[near]};
  }
  if (best.face >= 0) best.distance = std::sqrt(best2);
  return best;
}

bool MeshDistance::segment_may_cross(const Vec3& a, const Vec3& b) const {
  const Vec3 d = b - a;
  const double len = d.norm();
  if (!(len > 0)) return closest(a, 1e-12).face >= 0;
  // Tolerances relative to the segment and the coordinates' magnitude: generous against round-off.
  const double scale = std::max({1.0, a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()});
  const double margin = 1e-9 * scale;
  return any_leaf_on_line(bvh_, a, d, 1.0, margin, [&](int32_t begin, int32_t end) {
    for (int32_t s = begin; s < end; ++s) {
      const auto& t = bvh_.corners[static_cast<size_t>(s)];
      // Moller-Trumbore with a tolerance on the barycentrics and on the segment parameter.
      const Vec3 e1 = t[1] - t[0], e2 = t[2] - t[0];
      const Vec3 pv = d.cross(e2);
      const double det = e1.dot(pv);
      const double area = e1.cross(e2).norm();
      if (std::abs(det) <= 1e-9 * len * area) {
        // Parallel (or degenerate): a hit when the segment comes within round-off of the triangle.
        const Vec3 q = closest_point_on_triangle(a, t[0], t[1], t[2]);
        const double dist_a = (q - a).squaredNorm();
        if (dist_a <= len * len * 4 + margin) {
          // Close enough to matter: be conservative.
          return true;
        }
        continue;
      }
      const double inv = 1.0 / det;
      const Vec3 tv = a - t[0];
      const double u = tv.dot(pv) * inv;
      const double eps = 1e-7;
      if (u < -eps || u > 1 + eps) continue;
      const Vec3 qv = tv.cross(e1);
      const double v = d.dot(qv) * inv;
      if (v < -eps || u + v > 1 + eps) continue;
      const double tt = e2.dot(qv) * inv;
      if (tt < -eps || tt > 1 + eps) continue;
      return true;
    }
    return false;
  });
}

bool MeshDistance::ray_winding(const Vec3& p, const Vec3& dir, int* winding) const {
  const double len = dir.norm();
  if (!(len > 0) || !p.allFinite()) return false;
  const Vec3 d = dir / len;
  const double scale = std::max(1.0, p.cwiseAbs().maxCoeff());
  const double margin = 1e-9 * scale;
  int sum = 0;
  bool uncertain = false;  // a crossing within round-off of an edge, a vertex, p or the plane
  any_leaf_on_line(bvh_, p, d, std::numeric_limits<double>::infinity(), margin, [&](int32_t begin, int32_t end) {
    for (int32_t s = begin; s < end; ++s) {
      const auto& t = bvh_.corners[static_cast<size_t>(s)];
      const Vec3 e1 = t[1] - t[0], e2 = t[2] - t[0];
      const Vec3 n = e1.cross(e2);
      const double area = n.norm();
      if (!(area > 0)) {
        // Degenerate: contributes nothing unless the ray touches it (then the count is not certain).
        const Vec3 q = closest_point_on_triangle(p, t[0], t[1], t[2]);
        const double along = (q - p).dot(d);
        if (along >= -margin && (q - p - along * d).norm() <= margin) return uncertain = true;
        continue;
      }
      const Vec3 pv = d.cross(e2);
      const double det = e1.dot(pv);  // = -d . n
      const Vec3 tv = p - t[0];
      if (std::abs(det) <= 1e-9 * area) {
        // Parallel to the plane: uncertain only when the ray runs in the plane.
        if (std::abs(tv.dot(n)) <= 1e-9 * area * std::max(1.0, tv.norm())) return uncertain = true;
        continue;
      }
      const double inv_det = 1.0 / det;
      const double u = tv.dot(pv) * inv_det;
      const double eps = 1e-7;
      if (u < -eps || u > 1 + eps) continue;
      const Vec3 qv = tv.cross(e1);
      const double v = d.dot(qv) * inv_det;
      if (v < -eps || u + v > 1 + eps) continue;
      const double tt = e2.dot(qv) * inv_det;
      if (tt < -margin) continue;
      // Within round-off of the triangle's border, or of p itself: not certain.
      if (u < eps || v < eps || u + v > 1 - eps || tt <= margin) return uncertain = true;
      sum += det < 0 ? 1 : -1;
    }
    return false;
  });
  if (uncertain) return false;
  *winding = sum;
  return true;
}

Eigen::VectorXd MeshDistance::query(const Points& P) const {
  Eigen::VectorXd d(P.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 256), [&](const auto& r) {
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) d[i] = closest(P.row(i).transpose()).distance;
  });
  return d;
}

double MeshDistance::brute_force(const Mesh& mesh, const Vec3& p) {
  double best = 1e300;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Vec3 q = closest_point_on_triangle(p, mesh.V.row(mesh.F(f, 0)).transpose(),
                                             mesh.V.row(mesh.F(f, 1)).transpose(), mesh.V.row(mesh.F(f, 2)).transpose());
    best = std::min(best, (q - p).squaredNorm());
  }
  return std::sqrt(best);
}

}  // namespace sdfkit
