// A differentiable soft rasteriser (SoftRas / PyTorch3D's soft silhouette and softmax RGB blending) on the CPU:
// silhouettes and per-vertex-colour images of a triangle mesh through a camera, with the gradients of any loss on
// those images to the vertex positions and colours. `sdfkit refine` deforms meshes with it.
//
// The image model (pixel centres at (j + 0.5, i + 0.5), camera/camera.h's pixel convention):
//  * a face f meets pixel q with coverage p_f = sigmoid(-s d^2 / sigma), d = the distance in pixels from q to the
//    face's projection, s = -1 inside it and +1 outside; p_f = 1/2 on its edges and tends to the sharp indicator as
//    sigma -> 0 (camera/silhouette.h with one sample per pixel). Faces meet only the pixels within the radius where
//    p_f >= cutoff, sqrt(sigma ln(1/cutoff - 1)) pixels: a face's work is its bounding box grown by that radius.
//  * silhouette alpha = 1 - prod_f (1 - p_f);
//  * colour = (sum_f w_f c_f + w_b background) / (sum_f w_f + w_b), w_f = p_f exp(zeta_f / gamma),
//    w_b = exp(eps / gamma), zeta = (z_far - z) / (z_far - z_near) of the face's depth z at q; c_f and z come from
//    the face's vertex colours and camera depths, interpolated with q's barycentric coordinates clamped to the
//    triangle (renormalised), as PyTorch3D's blending does. Unlit by default (c_f = the vertex colours); with
//    `lit`, c_f = diffuse_f * albedo + specular_f, the flat Lambert + Blinn-Phong shading of camera/render.h under the
//    same camera-fixed light rig (face normal turned towards the camera, non-local viewer), so that a render of the
//    mesh by `sdfkit render` is matched by the right shape and albedo, and the colour term sees the surface's
//    orientation (gradients reach the positions through the face normals).
//  * faces with a vertex closer than `near` to the camera, or with a projected area under 1e-12 px^2, are dropped.
//
// Gradients are exact for this model (finite-difference checks in tests/camera/soft_raster_test.cpp), except at
// its kinks: where the nearest edge of a face changes, where a barycentric coordinate is clamped, at the cutoff.
// Work is parallel over 16 x 16 pixel tiles; results and gradients do not depend on the thread count.
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "camera/render.h"
#include "core/types.h"

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace sdfkit {

struct SoftRasterSettings {
  double sigma = 0.5;      ///< px^2; 0.5 is PyTorch3D's 1e-4 (NDC units) at 141 px
  double cutoff = 1e-4;    ///< smallest coverage kept, (0, 0.5)
  double gamma = 1e-4;     ///< depth softness of the colour blending (> 0; small = nearest face wins)
  double z_near = 1.0, z_far = 100.0;  ///< depth range of the blending weights, 0 <= z_near < z_far
  double near = 1e-3;      ///< faces with a vertex at z_cam < near are dropped
  Eigen::Vector3d background = Eigen::Vector3d::Ones();  ///< colour where no face is
  bool colour = true;      ///< false: silhouettes only (cheaper)
  /// Shade the vertex colours (as albedo) with camera/render.h's model; the defaults are RenderSettings' own.
  bool lit = false;
  double ambient = 0.2;
  std::vector<Light> lights = default_light_rig();
  double specular = 0.12, shininess = 24.0;

  /// Radius in pixels beyond which a face's coverage is under `cutoff`.
  [[nodiscard]] double radius() const;
};

/// Throws InvalidInput naming the bad field.
void validate_soft_raster_settings(const SoftRasterSettings& settings);

/// What a forward pass keeps for its backward pass: the (pixel, face) fragments and the per-pixel sums.
struct SoftRasterCache {
  struct Fragment {
    int32_t face = 0;
    double p = 0;          ///< coverage
    double z = 0;          ///< interpolated camera depth
    double weight = 0;     ///< w_f / exp(max zeta / gamma) (the blending weight, shifted for range)
    double bary[3] = {0, 0, 0};  ///< clamped, renormalised barycentrics
  };
  Camera camera;
  std::vector<Fragment> fragments;   ///< grouped by pixel, faces in index order within a pixel
  std::vector<int64_t> offsets;      ///< pixel k's fragments: [offsets[k], offsets[k + 1]), k = y * W + x
  std::vector<double> background_weight;  ///< w_b, shifted as the fragments' weights, per pixel
  std::vector<double> shade;         ///< lit: per face, diffuse factor and specular term (2 per face); else empty
  Points V;                          ///< the positions and colours rendered
  Points C;
};

/// The images of one forward pass: alpha (1 channel) and, when SoftRasterSettings::colour, rgb (3 channels).
struct SoftImages {
  Image alpha;
  Image rgb;
};

/// The colour a fragment of `cache`'s forward pass blends: the albedo (vertex colours C at its barycentrics), shaded
/// by its face's diffuse factor and specular term when the pass was lit.
Eigen::Vector3d fragment_colour(const SoftRasterCache& cache, const Points& C, const Faces& F,
                                const SoftRasterCache::Fragment& fr);

/// A soft rasteriser for one mesh topology (the faces); positions and colours change between calls.
class SoftRasterizer {
 public:
  /// Throws InvalidInput for an empty face list, negative indices, or bad settings.
  SoftRasterizer(Faces faces, SoftRasterSettings settings = {});

  /// Renders positions V (#V x 3, object frame) with vertex colours C (#V x 3 RGB in double precision, as an
  /// optimiser holds them; ignored, may be empty, when settings.colour is false) through `cam` at cam.width x cam.height. `cache` (optional) keeps what backward needs.
  /// Throws InvalidInput for indices beyond V, a colour count other than #V, or non-finite positions.
  [[nodiscard]] SoftImages render(const Points& V, const Points& C, const Camera& cam,
                                  SoftRasterCache* cache = nullptr) const;

  /// Adds d loss / d V and d loss / d C (#V x 3 each, resized and zeroed when their size differs) for the images of
  /// `cache`'s forward pass, given d loss / d alpha and d loss / d rgb (images of the forward's size; rgb may be empty
  /// when there is no colour loss). With `rgb_to_positions` false, d_rgb reaches the colours only: dV is then the
  /// gradient of the alpha term alone (as with an empty d_rgb) and dC the whole colour gradient, in one pass.
  void backward(const SoftRasterCache& cache, const Image& d_alpha, const Image& d_rgb, Points& dV, Points& dC,
                bool rgb_to_positions = true) const;

  [[nodiscard]] const SoftRasterSettings& settings() const { return settings_; }
  [[nodiscard]] const Faces& faces() const { return faces_; }

 private:
  Faces faces_;
  SoftRasterSettings settings_;
};

}  // namespace sdfkit
