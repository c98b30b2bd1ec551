// The unit-sphere object frame of docs/DESIGN.md: centre = area-weighted surface centroid, scale = 1 / (largest
// distance of a vertex from it). Every prepared shape stores norm = [cx, cy, cz, r].
#pragma once

#include "core/files.h"
#include "core/types.h"

namespace sdfkit {

struct Normalization {
  Vec3 center = Vec3::Zero();
  double radius = 1.0;

  /// Original units -> object frame: (p - center) / radius.
  [[nodiscard]] Vec3 to_object(const Vec3& p) const { return (p - center) / radius; }
  /// Object frame -> original units: center + radius * q.
  [[nodiscard]] Vec3 from_object(const Vec3& q) const { return center + radius * q; }
};

/// Centre = exact area-weighted centroid of the triangles (the limit of DISN's 16384 area-weighted samples),
/// radius = max distance from it over vertices that some face uses (stray unreferenced vertices are ignored).
/// Throws InvalidInput when the mesh has no area.
Normalization unit_sphere_normalization(const Mesh& mesh);

/// Vertices mapped into the object frame (faces and colours unchanged).
Mesh apply_normalization(const Mesh& mesh, const Normalization& norm);
/// Inverse of apply_normalization: object frame back to the source units.
Mesh undo_normalization(const Mesh& mesh, const Normalization& norm);

/// {"norm": [cx, cy, cz, r]}.
Json normalization_to_json(const Normalization& norm);
/// Reads the "norm" array of a norm.json object; InvalidInput if it is missing, not 4 numbers, or r <= 0.
Normalization normalization_from_json(const Json& j);

}  // namespace sdfkit
