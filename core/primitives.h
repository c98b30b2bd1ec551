// Closed, outward-oriented triangle meshes of simple solids and their exact signed distance functions.
// Used by tests everywhere (closed forms to compare against) and by the procedural benchmark (synth/).
#pragma once

#include "core/types.h"

namespace sdfkit {

/// UV sphere: `stacks` >= 2 latitude bands, `slices` >= 3 longitudes; poles are single vertices.
Mesh make_sphere(const Vec3& center, double radius, int stacks = 32, int slices = 64);
/// Icosphere: icosahedron subdivided `levels` times and projected on the sphere (near-uniform triangles).
Mesh make_icosphere(const Vec3& center, double radius, int levels = 3);
/// Axis-aligned box [lo, hi], 12 triangles.
Mesh make_box(const Vec3& lo, const Vec3& hi);
/// Torus around the z axis: major radius R, minor radius r.
Mesh make_torus(const Vec3& center, double R, double r, int major_segments = 64, int minor_segments = 32);

/// Exact signed distances (negative inside).
double sphere_sdf(const Vec3& p, const Vec3& center, double radius);
double box_sdf(const Vec3& p, const Vec3& lo, const Vec3& hi);
double torus_sdf(const Vec3& p, const Vec3& center, double R, double r);

/// Signed volume of a closed mesh (positive when faces point outward).
double signed_volume(const Mesh& mesh);
/// Total surface area.
double surface_area(const Mesh& mesh);

}  // namespace sdfkit
