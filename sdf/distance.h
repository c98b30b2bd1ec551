// Exact unsigned point-to-mesh distances (closest point over all triangles) through a triangle BVH.
#pragma once

#include "core/types.h"
#include "sdf/bvh.h"

namespace sdfkit {

/// Result of a closest-point query.
struct ClosestPoint {
  double distance = 0;  ///< Euclidean distance to the closest triangle
  Vec3 point = Vec3::Zero();
  int32_t face = -1;    ///< index of the closest face in the mesh
  int region = -1;      ///< feature of that face the point lies on (TriangleRegion of sdf/bvh.h)
};

class MeshDistance {
 public:
  explicit MeshDistance(const Mesh& mesh);

  /// Exact closest point on the mesh (thread-safe). `upper_bound`: search only closer than this (returns
  /// distance = upper_bound and face = -1 if nothing is closer).
  [[nodiscard]] ClosestPoint closest(const Vec3& p, double upper_bound = 1e300) const;
  /// Same, starting from mesh face `hint` (e.g. the closest face of a nearby point): its distance bounds the
  /// search from the start, which prunes most of the tree. Same distance as without a hint (at exact ties
  /// between faces the reported face may differ).
  [[nodiscard]] ClosestPoint closest(const Vec3& p, double upper_bound, int32_t hint) const;
  [[nodiscard]] double operator()(const Vec3& p) const { return closest(p).distance; }
  /// True when the segment [a, b] may touch a triangle: conservative (touching an edge or a vertex, or lying
  /// within round-off of a triangle counts as a hit), so false means that no surface lies between a and b.
  [[nodiscard]] bool segment_may_cross(const Vec3& a, const Vec3& b) const;
  /// Winding number of p from the signed crossings of the ray p + t dir, t > 0 (+1 where the ray leaves through
  /// a triangle's front side, -1 where it enters): exact for meshes whose every edge is crossed as often in one
  /// direction as in the other (closed parts), and one BVH walk instead of a winding-number hierarchy. False
  /// (and `winding` untouched) when the answer is not certain: the ray passes within round-off of an edge or a
  /// vertex, runs in a triangle's plane, or p lies on a triangle; try another direction.
  [[nodiscard]] bool ray_winding(const Vec3& p, const Vec3& dir, int* winding) const;
  /// Unsigned distances of every row of P, in parallel (TBB).
  [[nodiscard]] Eigen::VectorXd query(const Points& P) const;

  /// O(#F) reference for tests.
  static double brute_force(const Mesh& mesh, const Vec3& p);

 private:
  /// Query layout of one inner BVH node: both children's boxes side by side (one fetch, two box distances).
  /// A child that is a leaf is encoded in place (leaf_code: its slot range), so that leaves cost no node fetch.
  struct alignas(64) QueryNode {
    float lo[3][2], hi[3][2];  ///< [axis][child], rounded outward (float: one cache line per node)
    int32_t child[2] = {-1, -1};  ///< inner child: its index (>= 0); leaf child: leaf_code (< 0)
    int32_t begin = 0, end = 0;   ///< the node's own slot range
  };
  /// A leaf as a negative number: -(begin * 8 + count) - 1 (a leaf holds at most 4 triangles).
  static int32_t leaf_code(int32_t begin, int32_t end) { return -(begin * 8 + (end - begin)) - 1; }
  /// Per slot: what rejects a triangle before its exact test, in one cache line.
  struct alignas(64) SlotBound {
    double plane[4];       ///< unit normal and offset (zero when degenerate)
    float lo[3], hi[3];    ///< the triangle's bounding box, rounded outward
  };
  TriangleBvh bvh_;
  std::vector<QueryNode> qnodes_;            ///< one per bvh_.nodes entry
  std::vector<SlotBound> slot_bound_;         ///< one per slot
  std::vector<int32_t> slot_of_face_;  ///< inverse of bvh_.face
};

}  // namespace sdfkit
