// CPU rasteriser for dataset renders: RGB(A) with flat Lambert + Blinn-Phong shading under a fixed light rig,
// anti-aliased silhouettes by supersampling, depth and normal maps. z-buffered, two-sided (polygon soups may be
// oriented arbitrarily), TBB-parallel over tiles, deterministic (same bytes for any thread count).
//
// How it works (docs/camera.md has the details):
//  * every pixel holds s x s samples on a regular grid at ((j + (a + 0.5) / s), (i + (b + 0.5) / s));
//  * vertices are projected once per view; triangles are snapped to 1/256 of a sample and rasterised with exact
//    64-bit integer edge functions and a top-left fill rule, so shared edges are covered exactly once;
//  * depth test on perspective-correct 1/z, ties won by the lower face index (triangles are binned to tiles in
//    index order), so the result does not depend on scheduling;
//  * triangles crossing the near plane (z_cam < near) or reaching far outside the image are clipped in camera
//    space; nothing is culled for facing;
//  * alpha = covered samples / s^2; RGB = mean colour of the covered samples (straight, not premultiplied);
//  * depth (z_cam) and normal (camera frame, turned towards the camera) are those of the sample nearest the
//    pixel centre (the centre itself for odd s), 0 where that sample is background: depth maps are not blended.
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "core/types.h"

#include <vector>

namespace sdfkit {

/// A directional light in the camera frame (x right, y down, z forward); `direction` points from the surface
/// towards the light.
struct Light {
  Eigen::Vector3f direction = Eigen::Vector3f(0, 0, -1);
  float intensity = 1.0f;
};

/// The default rig, fixed to the camera so every view is lit alike: a key light from the upper left, a fill
/// from the right and a top light (intensities 0.55, 0.25, 0.15 with ambient 0.2).
std::vector<Light> default_light_rig();

struct RenderSettings {
  int supersampling = 3;  ///< s: s x s samples per pixel (1..8); alpha has s^2 + 1 levels
  Eigen::Vector3f default_color = Eigen::Vector3f(0.72f, 0.72f, 0.75f);  ///< albedo when the mesh has no colours
  float ambient = 0.2f;
  std::vector<Light> lights = default_light_rig();
  float specular = 0.12f;   ///< Blinn-Phong specular weight (white highlights), non-local viewer
  float shininess = 24.0f;  ///< Blinn-Phong exponent
  double near = 1e-3;       ///< near clipping plane (z_cam)
  bool depth = false;       ///< also produce the depth map
  bool normals = false;     ///< also produce the normal map
  bool albedo = false;      ///< also produce the albedo (unlit colour) map
};

struct RenderResult {
  Image rgba;     ///< 4 channels, straight alpha, values in [0, 1]
  Image depth;    ///< 1 channel z_cam, 0 = background (empty unless settings.depth)
  Image normals;  ///< 3 channels camera-frame unit normals, 0 = background (empty unless settings.normals)
  Image albedo;   ///< 3 channels unlit colour, mean over covered samples, 0 = background (settings.albedo)
  long rasterised_triangles = 0;  ///< triangles that covered at least one sample's bounding box
};

/// Renders many views of one mesh: validates and converts the mesh once.
class MeshRenderer {
 public:
  /// Throws InvalidInput for an empty mesh, out-of-range indices or non-finite coordinates, and for bad
  /// settings (supersampling outside 1..8, non-finite or negative light values).
  explicit MeshRenderer(const Mesh& mesh, RenderSettings settings = {});
  [[nodiscard]] RenderResult render(const Camera& cam) const;
  [[nodiscard]] const RenderSettings& settings() const { return settings_; }

 private:
  RenderSettings settings_;
  std::vector<float> V_;        // #V x 3 positions (object frame)
  std::vector<int32_t> F_;      // #F x 3
  std::vector<float> C_;        // #V x 3 colours, or empty
};

/// One-off convenience: MeshRenderer(mesh, settings).render(cam).
RenderResult render(const Mesh& mesh, const Camera& cam, const RenderSettings& settings = {});

/// How two RGBA images of one size differ over the union of their silhouettes (alpha >= 0.5 in either): a pixel
/// differs when it lies inside one silhouette only, or inside both with a colour channel apart by more than
/// `colour_tol`. eval-pose --twins compares a view with the same shape turned by this to find the cameras an image
/// cannot tell apart.
struct ViewDifference {
  long differing = 0;   ///< pixels that differ
  long silhouette = 0;  ///< pixels inside either silhouette
  /// differing / silhouette (0 when both images are empty).
  [[nodiscard]] double share() const {
    return silhouette > 0 ? static_cast<double>(differing) / static_cast<double>(silhouette) : 0.0;
  }
};

/// Throws InvalidInput unless both images have 4 channels and the same size, or for a negative or non-finite
/// colour_tol.
ViewDifference view_difference(const Image& a, const Image& b, float colour_tol = 0.1f);

/// The search of view_twin_turns.
struct TwinSearch {
  double step = 5;        ///< candidate turns: the multiples of step degrees ...
  double window = 15;     ///< ... within window degrees of the given turn ...
  double min_turn = 20;   ///< ... and at least min_turn degrees from no turn (modulo 360)
  double tol = 0.01;      ///< largest share of the silhouettes' pixels that may differ
  float colour_tol = 0.1f;  ///< view_difference's colour tolerance
};

/// The turns of the object about its vertical axis (+y), near `turn_deg`, that the view from `truth` cannot be
/// told from: the candidate turns a of `search` whose render from the truth composed with R_y(a) (the camera
/// (R_t R_y(a), t_t), i.e. turn_about_vertical(truth, -a)) differs from the render from `truth` in at most
/// search.tol of the silhouettes' pixels. A pose estimate turned by turn_deg from the truth (rotation_error_degrees)
/// reads such a view rightly. Returns the accepted turns in degrees, ascending; *best_share receives the smallest
/// share of any candidate (+inf when there was none). InvalidInput for a non-positive step, negative window or
/// min_turn, more than 3600 candidates, or tol outside [0, 1].
std::vector<double> view_twin_turns(const MeshRenderer& renderer, const Camera& truth, double turn_deg,
                                    const TwinSearch& search = {}, double* best_share = nullptr);

}  // namespace sdfkit
