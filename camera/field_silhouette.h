// Soft silhouettes of an implicit field seen through a camera, the differentiable render the occlusion critic
// judges (`train sdf --adversarial`). For every pixel of a size x size grid over the camera's image, the ray through
// the pixel centre is searched, inside a bounding sphere, for the point where the field is smallest; the pixel's
// coverage is then a sigmoid of the field there:
//     alpha = sigmoid(-f(p*) / temperature).
// A ray passing through the object has f(p*) < 0 (alpha near 1), a ray missing it keeps f(p*) > 0 (alpha near 0), and
// the derivative d alpha / d f(p*) = -alpha (1 - alpha) / temperature moves the field at the ray's point of closest
// approach: the one place where a change of the field changes the silhouette. The search itself is not
// differentiated (p* is a constant of the render), as in sphere-tracing renderers of signed distance fields.
// Knows nothing of networks: the field is any function of a batch of points.
#pragma once

#include "camera/camera.h"
#include "core/types.h"

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace sdfkit {

struct FieldSilhouetteSettings {
  int size = 56;         ///< pixels per side of the render (the camera's image scaled to size x size)
  double radius = 1.05;  ///< bounding sphere at the origin; rays missing it have alpha 0
  int samples = 16;      ///< uniform samples along the chord inside the sphere (interval midpoints)
  int refine = 4;        ///< extra samples at +-1/4 and +-1/2 of the spacing about the best sample (0 or 4)
};

/// field(points, values): values (one per row of points) of the field at object-frame points.
using PointField = std::function<void(const PointsF& points, Eigen::VectorXf& values)>;

/// The rays' points of smallest field value. Pixel (j, i) of the grid (row i, column j) is index i * size + j;
/// its ray passes through the camera pixel ((j + 0.5) w / size, (i + 0.5) h / size) for the camera's w x h image.
struct FieldSilhouetteRays {
  int size = 0;
  PointsF points;          ///< size^2 x 3: p* of each pixel (the chord's midpoint for rays missing the sphere)
  std::vector<char> hit;   ///< size^2: 1 when the ray meets the sphere
  Eigen::VectorXf value;   ///< size^2: f(p*) (0 for rays missing the sphere)
  long evaluations = 0;    ///< field values computed by the search
};

/// Search every pixel ray (one batch per search round: all hitting rays' samples, then the refinement samples).
/// Throws InvalidInput for settings out of range (size < 1, radius <= 0, samples < 1, refine not 0 or 4) or an
/// invalid camera.
FieldSilhouetteRays find_silhouette_points(const Camera& camera, const FieldSilhouetteSettings& settings,
                                           const PointField& field);

/// alpha = sigmoid(-value / temperature) per pixel (0 where the ray misses), and d alpha / d value in `dalpha`
/// when not null (0 where the ray misses).
Eigen::VectorXf soft_coverage(const FieldSilhouetteRays& rays, const Eigen::VectorXf& value, double temperature,
                              Eigen::VectorXf* dalpha = nullptr);

}  // namespace sdfkit
