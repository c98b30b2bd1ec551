#include "sdf/distance.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace sdfkit {
namespace {
double box_distance2(const Eigen::AlignedBox3d& b, const Vec3& p) {
  const Vec3 d = (b.min() - p).cwiseMax(p - b.max()).cwiseMax(0.0);
  return d.squaredNorm();
}
}  // namespace

MeshDistance::MeshDistance(const Mesh& mesh) : bvh_(TriangleBvh::build(mesh, 4)) {
  require(mesh.F.rows() > 0, "MeshDistance: the mesh has no faces");
  slot_of_face_.resize(bvh_.face.size());
  for (size_t s = 0; s < bvh_.face.size(); ++s) slot_of_face_[static_cast<size_t>(bvh_.face[s])] = static_cast<int32_t>(s);
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
    int32_t node;
    double d2;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {0, box_distance2(bvh_.nodes[0].box, p)};
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.d2 >= best2) continue;
    const auto& node = bvh_.nodes[e.node];
    if (node.leaf()) {
      for (int32_t s = node.begin; s < node.end; ++s) {
        if (box_distance2(bvh_.boxes[s], p) > best2) continue;  // cannot be closer (ties still compared below)
        const auto& t = bvh_.corners[s];
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
    const double dl = box_distance2(bvh_.nodes[node.left].box, p);
    const double dr = box_distance2(bvh_.nodes[node.right].box, p);
    // Push the farther child first so the nearer one is explored first.
    if (dl < dr) {
      stack[top++] = {node.right, dr};
      stack[top++] = {node.left, dl};
    } else {
      stack[top++] = {node.left, dl};
      stack[top++] = {node.right, dr};
    }
  }
  if (best.face >= 0) best.distance = std::sqrt(best2);
  return best;
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
