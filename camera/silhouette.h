// Silhouettes: the coverage of a mesh's projection through a camera (no depth, no shading), and the soft IoU of
// two coverage images. Used by test-time camera refinement (recon/camera_refine.h), which renders one mesh through
// a few hundred candidate cameras, so this is a lean alternative to camera/render.h's alpha channel.
//
// Conventions (the same sample grid as camera/render.h, docs/camera.md):
//  * every pixel holds s x s samples at (j + (a + 0.5) / s, i + (b + 0.5) / s), a, b = 0..s-1;
//  * a sample is covered when it lies in the closed projection of any triangle (edges inclusive; render.h uses a
//    top-left rule, so the two can differ only on samples lying exactly on an outer silhouette edge);
//  * coverage of a pixel = covered samples / s^2;
//  * triangles crossing the near plane (z_cam < near) are clipped in camera space, nothing is culled for facing.
// Deterministic (single-threaded, no floating-point reductions that depend on order).
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "core/types.h"

#include <vector>

namespace sdfkit {

/// Renders the silhouette of one mesh through many cameras (validates and converts the mesh once).
class SilhouetteRenderer {
 public:
  /// Throws InvalidInput for an empty mesh, out-of-range indices, non-finite coordinates or supersampling outside
  /// 1..8.
  explicit SilhouetteRenderer(const Mesh& mesh, int supersampling = 2, double near = 1e-3);
  /// 1-channel coverage image (values k / s^2) of cam.width x cam.height pixels.
  [[nodiscard]] Image render(const Camera& cam) const;
  [[nodiscard]] int supersampling() const { return s_; }

 private:
  int s_;
  double near_;
  std::vector<double> V_;  // #V x 3
  std::vector<int32_t> F_;  // #F x 3
};

/// One-off convenience: SilhouetteRenderer(mesh, supersampling).render(cam).
Image render_silhouette(const Mesh& mesh, const Camera& cam, int supersampling = 2);

/// Soft IoU of two coverage images (first channel of each, values clamped to [0, 1]):
/// sum_p min(a_p, b_p) / sum_p max(a_p, b_p); 1 when both are empty. Throws InvalidInput for different sizes.
double silhouette_iou(const Image& a, const Image& b);

}  // namespace sdfkit
