// Point samples of a mesh for scoring: area-weighted surface samples (with their face normals) and samples of the
// vertex set with replacement (DISN's protocol). Every draw is seeded (core/random.h): same seed, same points.
#pragma once

#include "core/types.h"

#include <cstdint>

namespace sdfkit {

/// Points on a surface and, for surface samples, the unit normal of the face each point lies on.
struct SurfaceSamples {
  Points points;   ///< n x 3
  Points normals;  ///< n x 3 unit face normals (orientation as the mesh's winding); empty for vertex samples
  Eigen::VectorXi faces;  ///< n face indices; empty for vertex samples
};

/// `n` points drawn uniformly with respect to surface area: a face is chosen with probability proportional to its
/// area, then a point uniformly inside it (u = 1 - sqrt(r1), v = sqrt(r1)(1 - r2), w = sqrt(r1) r2).
/// Zero-area faces are never chosen. Throws InvalidInput if the mesh is empty, has non-finite coordinates or
/// out-of-range indices, or has zero total area; `what` names the mesh in the message.
SurfaceSamples sample_surface(const Mesh& mesh, long n, uint64_t seed, const std::string& what = "mesh");

/// `n` rows of `points` drawn uniformly with replacement (DISN draws its 2048 scoring points from mesh vertices
/// this way). Throws InvalidInput if `points` is empty or non-finite.
Points sample_with_replacement(const Points& points, long n, uint64_t seed, const std::string& what = "points");

/// `n` distinct rows of `points` (n <= rows), drawn uniformly without replacement (seeded partial Fisher-Yates),
/// kept in their order in `points`. Throws InvalidInput if n is not in [1, rows] or `points` is empty or non-finite.
Points sample_without_replacement(const Points& points, long n, uint64_t seed, const std::string& what = "points");

/// How a point cloud becomes the `n` points a protocol scores (metrics/protocols.h).
enum class CloudSampling {
  kAsGiven,     ///< exactly n points: used as they are
  kSubsampled,  ///< more than n: n of them drawn without replacement
  kPadded,      ///< fewer than n: every point once, plus n - rows drawn with replacement (EMD needs equal sizes)
};
std::string to_string(CloudSampling s);  ///< "as_given", "subsampled", "padded"

/// `n` points from a point cloud by the rule of CloudSampling (the choice is returned in `how`). Deterministic
/// given the seed. Throws InvalidInput as sample_with_replacement.
Points sample_cloud(const Points& points, long n, uint64_t seed, CloudSampling* how, const std::string& what = "points");

/// Throws InvalidInput naming `what` if `points` is empty or holds a non-finite coordinate.
void require_finite_points(const Points& points, const std::string& what);

}  // namespace sdfkit
