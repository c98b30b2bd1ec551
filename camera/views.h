// DISN-like view sets: V seeded random look-at cameras around a unit-sphere-normalised object, rendered to
// views_dir/NN.png (RGBA) with their cameras in views_dir/NN.json.
//
// Defaults (docs/camera.md explains them): 24 views, 137 px, azimuth uniform in [0, 360), elevation uniform in
// [25, 30] degrees (3D-R2N2's renders, which DISN trains on), distance uniform in [2.45, 3.0] object-frame
// units. 3D-R2N2 places the camera at 0.65..0.85 x 1.75 = 1.14..1.49 ShapeNet units from objects of radius
// about 0.5, i.e. 2.3..3.0 radii; we start at 2.45 because from there the whole unit sphere stays inside the
// 137 px image (its silhouette radius f / sqrt(d^2 - 1) is 67.0 px at d = 2.45 and 53.0 px at d = 3.0).
#pragma once

#include "camera/camera.h"
#include "camera/occlusion.h"
#include "camera/render.h"
#include "core/types.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct ViewSetSettings {
  int views = 24;
  int size = 137;  ///< square image side in pixels; intrinsics are DISN's scaled to it
  double azimuth_min = 0, azimuth_max = 360;
  double elevation_min = 25, elevation_max = 30;
  double distance_min = 2.45, distance_max = 3.0;
  RenderSettings render;  ///< render.depth / .normals / .albedo also write NN_depth.exr / NN_normal.exr / NN_albedo.png
  OcclusionSettings occlusion;   ///< mode != none: NN.png is occluded and NN_mask.png (white = removed) written
};

/// Throws InvalidInput naming the bad field (views < 1, size < 8, empty/inverted ranges, distance <= 0, ...).
void validate_view_set_settings(const ViewSetSettings& settings);

/// The cameras alone: view k draws azimuth, elevation, distance (in that order) from Rng::derived(seed, k),
/// so view k does not depend on how many views are requested.
std::vector<Camera> view_set_cameras(const ViewSetSettings& settings, uint64_t seed);

/// "00".."23": two digits, more when views > 100.
std::string view_name(int index, int views);

/// Renders the view set of a mesh already in the object frame (unit sphere). Writes, per view k with name NN:
/// NN.png (RGBA 8-bit), optional NN_depth.exr / NN_normal.exr / NN_albedo.png / NN_mask.png, and NN.json last (camera_to_json,
/// plus "occlusion": mode when occluded), each file atomically, so an NN.json present means view NN is complete.
/// Views are rendered in parallel; the bytes do not depend on the thread count. Returns the cameras.
std::vector<Camera> render_view_set(const Mesh& normalized_mesh, const std::string& views_dir,
                                    const ViewSetSettings& settings, uint64_t seed);

}  // namespace sdfkit
