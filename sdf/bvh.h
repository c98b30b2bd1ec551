// A bounding-volume hierarchy over the triangles of a mesh: the shared spatial index behind exact
// point-to-mesh distances (sdf/distance.h) and hierarchical winding numbers (sdf/winding.h).
#pragma once

#include "core/types.h"

#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace sdfkit {

/// Binary BVH built by median splits along the longest axis of the triangle centroids. Triangles are
/// stored in BVH order (slot s holds mesh face `face[s]`) so that a leaf reads contiguous memory.
/// Building is deterministic: the same mesh gives the same tree.
struct TriangleBvh {
  struct Node {
    Eigen::AlignedBox3d box;  ///< bounds of the node's triangles
    int32_t left = -1;        ///< child indices into `nodes`; -1 for a leaf
    int32_t right = -1;
    int32_t begin = 0;        ///< slot range [begin, end) of the node's triangles
    int32_t end = 0;
    [[nodiscard]] bool leaf() const { return left < 0; }
  };
  std::vector<Node> nodes;                   ///< nodes[0] is the root (empty when the mesh has no faces)
  std::vector<int32_t> face;                 ///< mesh face index per slot
  std::vector<std::array<Vec3, 3>> corners;  ///< triangle corners per slot
  std::vector<Eigen::AlignedBox3d> boxes;    ///< triangle bounding box per slot (cheap rejection before exact tests)

  /// `leaf_size` >= 1 triangles per leaf at most.
  static TriangleBvh build(const Mesh& mesh, int leaf_size = 4);
};

/// Feature of a triangle on which a closest point lies (closest_point_on_triangle's `region`).
enum TriangleRegion : int8_t {
  kVertexA = 0, kVertexB = 1, kVertexC = 2,  ///< a corner
  kEdgeAB = 3, kEdgeBC = 4, kEdgeCA = 5,     ///< the inside of an edge
  kFace = 6,                                 ///< the inside of the triangle
};

/// Closest point to `p` on triangle (a, b, c) (exact, handles degenerate triangles). `region`, when given,
/// receives the feature the point lies on (a TriangleRegion).
Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int* region = nullptr);

/// Signed solid angle of triangle (a, b, c) seen from p, in [-2 pi, 2 pi]; positive when p lies on the side
/// opposite to the triangle's normal (b - a) x (c - a), i.e. inside a closed outward-oriented surface.
double triangle_solid_angle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace sdfkit
