#include "sdf/bvh.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sdfkit {
namespace {

struct Builder {
  const std::vector<Vec3>& centroid;
  const std::vector<Eigen::AlignedBox3d>& tri_box;
  std::vector<int32_t>& order;
  std::vector<TriangleBvh::Node>& nodes;
  int leaf_size;

  int32_t build(int32_t begin, int32_t end) {
    const auto id = static_cast<int32_t>(nodes.size());
    nodes.emplace_back();
    Eigen::AlignedBox3d box;
    Eigen::AlignedBox3d cbox;
    for (int32_t i = begin; i < end; ++i) {
      box.extend(tri_box[order[i]]);
      cbox.extend(centroid[order[i]]);
    }
    nodes[id].box = box;
    nodes[id].begin = begin;
    nodes[id].end = end;
    if (end - begin <= leaf_size) return id;
    int axis = 0;
    cbox.sizes().maxCoeff(&axis);
    const int32_t mid = begin + (end - begin) / 2;
    // Ties broken by face index so that the split does not depend on the standard library's nth_element.
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](int32_t a, int32_t b) {
      const double ca = centroid[a][axis], cb = centroid[b][axis];
      return ca < cb || (ca == cb && a < b);
    });
    const int32_t left = build(begin, mid);
    const int32_t right = build(mid, end);
    nodes[id].left = left;
    nodes[id].right = right;
    return id;
  }
};

}  // namespace

TriangleBvh TriangleBvh::build(const Mesh& mesh, int leaf_size) {
  TriangleBvh bvh;
  const auto nf = static_cast<int32_t>(mesh.F.rows());
  if (nf == 0) return bvh;
  std::vector<Vec3> centroid(nf);
  std::vector<Eigen::AlignedBox3d> tri_box(nf);
  for (int32_t f = 0; f < nf; ++f) {
    Eigen::AlignedBox3d b;
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const Vec3 v = mesh.V.row(mesh.F(f, k)).transpose();
      b.extend(v);
      c += v;
    }
    tri_box[f] = b;
    centroid[f] = c / 3.0;
  }
  bvh.face.resize(nf);
  std::iota(bvh.face.begin(), bvh.face.end(), 0);
  bvh.nodes.reserve(static_cast<size_t>(2 * nf / std::max(1, leaf_size) + 2));
  Builder builder{centroid, tri_box, bvh.face, bvh.nodes, std::max(1, leaf_size)};
  builder.build(0, nf);
  bvh.corners.resize(nf);
  bvh.boxes.resize(nf);
  for (int32_t s = 0; s < nf; ++s) {
    for (int k = 0; k < 3; ++k) bvh.corners[s][k] = mesh.V.row(mesh.F(bvh.face[s], k)).transpose();
    bvh.boxes[s] = tri_box[bvh.face[s]];
  }
  return bvh;
}

Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int* region) {
  // Voronoi-region walk (Ericson, Real-Time Collision Detection, 5.1.5).
  int dummy = 0;
  int& r = region ? *region : dummy;
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return r = kVertexA, a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return r = kVertexB, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double den = d1 - d3;
    r = den > 0 ? kEdgeAB : kVertexA;
    return den > 0 ? Vec3(a + (d1 / den) * ab) : a;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return r = kVertexC, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double den = d2 - d6;
    r = den > 0 ? kEdgeCA : kVertexA;
    return den > 0 ? Vec3(a + (d2 / den) * ac) : a;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double den = (d4 - d3) + (d5 - d6);
    r = den > 0 ? kEdgeBC : kVertexB;
    return den > 0 ? Vec3(b + ((d4 - d3) / den) * (c - b)) : b;
  }
  const double sum = va + vb + vc;
  if (!(sum > 0)) {
    // Degenerate (zero-area) triangle: closest of the three edges (reported as the face: it has no normal).
    r = kFace;
    Vec3 best = a;
    double bd = (p - a).squaredNorm();
    const Vec3* e[3][2] = {{&a, &b}, {&b, &c}, {&c, &a}};
    for (auto& ed : e) {
      const Vec3 d = *ed[1] - *ed[0];
      const double l2 = d.squaredNorm();
      const double t = l2 > 0 ? std::clamp((p - *ed[0]).dot(d) / l2, 0.0, 1.0) : 0.0;
      const Vec3 q = *ed[0] + t * d;
      if ((p - q).squaredNorm() < bd) {
        bd = (p - q).squaredNorm();
        best = q;
      }
    }
    return best;
  }
  const double v = vb / sum, w = vc / sum;
  r = kFace;
  return a + v * ab + w * ac;
}

double triangle_solid_angle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Van Oosterom & Strackee (1983): tan(Omega / 2) = det / denominator.
  const Vec3 x = a - p, y = b - p, z = c - p;
  const double lx = x.norm(), ly = y.norm(), lz = z.norm();
  const double det = x.dot(y.cross(z));
  const double den = lx * ly * lz + x.dot(y) * lz + y.dot(z) * lx + z.dot(x) * ly;
  return 2.0 * std::atan2(det, den);
}

}  // namespace sdfkit
