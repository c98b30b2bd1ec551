// Closed, outward-facing part meshes for the procedural benchmark: oriented boxes and bars, rounded boxes,
// ellipsoids, cylinders, cones/frusta, tori, general hexahedra, lofts through cross-sections and tubes swept
// along a path. Every generator returns one closed part (each edge shared by exactly two faces, traversed once
// in each direction) with positive signed volume; shapes are polygon soups of such parts.
#pragma once

#include "core/types.h"

#include <array>
#include <vector>

namespace sdfkit {

/// Rotations about the coordinate axes (radians, right-handed).
Mat3 rot_x(double angle);
Mat3 rot_y(double angle);
Mat3 rot_z(double angle);
/// A rotation taking +z to `axis` (any unit or non-unit non-zero vector), minimal angle.
Mat3 rot_z_to(const Vec3& axis);

/// `A * v + t` for every vertex. When det(A) < 0 (a mirror) faces are reversed so the part stays outward-facing.
Mesh transformed(const Mesh& part, const Mat3& A, const Vec3& t);

/// Box with half extents `half` around `center`, rotated by `R` (columns = the box's axes in world space).
Mesh make_box_part(const Vec3& center, const Vec3& half, const Mat3& R = Mat3::Identity());
/// Box-shaped bar from `a` to `b` (its length axis) with cross-section `width` x `depth`; `depth` is measured
/// along `up` made orthogonal to the bar (use any vector not parallel to b - a).
Mesh make_bar(const Vec3& a, const Vec3& b, double width, double depth, const Vec3& up = Vec3::UnitY());
/// Eight corners of a deformed box, indexed by bits i = x + 2y + 4z of the logical unit cube, where the logical
/// axes x, y, z form a right-handed or left-handed frame (faces are oriented outward either way; e.g. a tapered
/// wing). Quads are split into two triangles each.
Mesh make_hexahedron(const std::array<Vec3, 8>& corners);
/// Box with edges and corners rounded by `radius` (clamped to 0.9 x the smallest half extent);
/// `arc_segments` triangle rows per quarter arc.
Mesh make_rounded_box(const Vec3& center, const Vec3& half, double radius, const Mat3& R = Mat3::Identity(),
                      int arc_segments = 3);
/// Ellipsoid with semi-axes `radii` (a cube-sphere: `grid` x `grid` quads per cube face).
Mesh make_ellipsoid(const Vec3& center, const Vec3& radii, const Mat3& R = Mat3::Identity(), int grid = 6);
/// Capped cylinder from `a` to `b`.
Mesh make_cylinder(const Vec3& a, const Vec3& b, double radius, int segments = 16);
/// Capped frustum from `a` (radius `ra`) to `b` (radius `rb`); a zero radius gives a pointed cone.
Mesh make_cone(const Vec3& a, const Vec3& b, double ra, double rb, int segments = 16);
/// Torus around `axis` through `center`: ring radius R, tube radius r (R > r).
Mesh make_torus_part(const Vec3& center, const Vec3& axis, double R, double r, int major_segments = 24,
                     int minor_segments = 10);
/// Loft through closed cross-section rings (each the same number >= 3 of points, consecutive rings
/// roughly parallel), capped at both ends with a fan around the ring's centroid. Rings may wind either way.
Mesh make_loft(const std::vector<std::vector<Vec3>>& rings);
/// Tube of circular cross-section swept along `path` (>= 2 points); `radii` has one entry per path point
/// (or a single entry for a constant radius). Joints are mitred; ends are capped.
Mesh make_tube(const std::vector<Vec3>& path, const std::vector<double>& radii, int segments = 12);

/// Points of the cubic Bezier curve p0..p3 at `n` >= 2 equally spaced parameters (ends included).
std::vector<Vec3> bezier(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, int n);
/// `n` >= 2 points on a circular arc around `center` from angle a0 to a1 in the plane spanned by unit `u`, `v`.
std::vector<Vec3> arc(const Vec3& center, const Vec3& u, const Vec3& v, double radius, double a0, double a1, int n);

}  // namespace sdfkit
