// Inside/outside of a closed mesh from the angle-weighted pseudo-normal at the closest feature (Baerentzen &
// Aanaes 2005): p is inside iff (p - q) . n < 0, q the closest point, n the pseudo-normal of the face, edge or
// vertex q lies on. Exact for closed, consistently oriented, edge-manifold meshes without self-intersections,
// and free once the closest point is known; winding numbers (sdf/winding.h) stay the method for everything else.
#pragma once

#include "core/types.h"
#include "sdf/distance.h"

#include <array>
#include <functional>
#include <vector>

namespace sdfkit {

class PseudoNormals {
 public:
  /// Throws InvalidInput unless every edge is shared by exactly two faces in opposite directions
  /// (is_closed_oriented of sdf/orientation.h).
  explicit PseudoNormals(const Mesh& mesh);

  /// Pseudo-normal (not unit) of `face`'s feature `region` (a TriangleRegion of sdf/bvh.h).
  [[nodiscard]] Vec3 normal(int32_t face, int region) const;
  /// True when p is inside, given its closest point on the mesh (MeshDistance::closest). A point on the
  /// surface (p == q) counts as outside.
  [[nodiscard]] bool inside(const Vec3& p, const ClosestPoint& cp) const {
    return (p - cp.point).dot(normal(cp.face, cp.region)) < 0;
  }

 private:
  std::vector<Vec3> face_normal_;                ///< unit normal per face
  std::vector<Vec3> vertex_normal_;              ///< angle-weighted sum of unit face normals per vertex
  std::vector<std::array<Vec3, 3>> edge_normal_; ///< per face, edges (0,1), (1,2), (2,0): sum of both faces' normals
  Faces F_;
};

/// True when the pseudo-normal sign is exact for `mesh` as far as cheap checks can tell: closed and consistently
/// oriented (every edge used by exactly two faces in opposite directions), one connected part (two closed parts
/// may interpenetrate; one part may still self-intersect, which the caller guards by agreement checks).
bool pseudo_normal_sign_applies(const Mesh& mesh);

/// Cheap guard against self-intersecting closed meshes: compares the pseudo-normal and the winding-number
/// inside/outside at `count` deterministic points at 0.5 to 4 `spacing` from random surface points. True when
/// they all agree.
bool pseudo_normal_agrees_with_winding(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                       double spacing, int count = 256);
class WindingNumber;
/// Same, with the mesh's winding-number hierarchy already built.
bool pseudo_normal_agrees_with_winding(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                       double spacing, const WindingNumber& wn, int count = 256);
/// Same test points, with the winding number of each from signed ray crossings (MeshDistance::ray_winding):
/// exact and without a winding-number hierarchy, valid when every edge of `mesh` is balanced (closed parts,
/// as pseudo_normal_sign_applies requires). A point whose rays all graze an edge asks `fallback` for the
/// hierarchy (built only then).
bool pseudo_normal_agrees_with_rays(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                    double spacing, const std::function<const WindingNumber&()>& fallback,
                                    int count = 256);

}  // namespace sdfkit
