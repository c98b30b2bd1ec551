// Single-view reconstruction as a library function (what `sdfkit recon` runs per image):
//   image (any size, 1-4 channels; alpha or a mask composited on white, see nets/dataset.h network_image)
//   -> camera: estimated by the pose network, or given
//   -> SDF network: per-shape encoding once, then batches of points
//   -> adaptive extraction of the 0 level (extract/adaptive.h; safety factor > 1 because the network's field is
//      only an approximate SDF), clean-up of small components (extract/cleanup.h)
//   -> closed mesh in the object frame + a preview image (input | render from the input view | two other views).
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "core/types.h"
#include "nets/sdf_net.h"

#include <memory>
#include <mutex>
#include <string>

namespace sdfkit {

class PoseNet;

struct ReconSettings {
  int resolution = 129;          ///< final grid points per axis (65, 129, 257, ...)
  int coarse_resolution = 17;    ///< first level of the adaptive extraction
  double safety = 2.0;           ///< Lipschitz allowance of the network field (1 = trust it as a true SDF)
  double box_half = 1.05;        ///< sampled cube [-box_half, box_half]^3 (object frame: the unit sphere + 5%)
  bool dense = false;            ///< evaluate the full grid instead (the baseline of `sdfkit bench recon`)
  double min_component_fraction = 0.3;  ///< DISN's clean-up: drop components under 30% of the largest (faces)
  bool preview = true;
  int preview_size = 192;        ///< side of each preview panel in pixels
  /// An input is refused as "only background" when fewer than this fraction of its network-image pixels differ
  /// from the white background by more than 0.05 (after alpha/mask compositing).
  double min_foreground_fraction = 0.002;
};

struct ReconTimings {
  double prepare = 0;   ///< image -> network input
  double pose = 0;      ///< camera estimation (0 when the camera was given)
  double encode = 0;    ///< SDF network per-shape work
  double field = 0;     ///< network evaluations inside the extraction
  double extract = 0;   ///< extraction excluding field evaluations (marching cubes, refinement bookkeeping)
  double cleanup = 0;
  double preview = 0;
  double total = 0;
};

struct ReconResult {
  Mesh mesh;                    ///< closed, object frame
  Camera camera;                ///< the camera used (137 px)
  bool camera_estimated = false;
  long evaluations = 0;         ///< field evaluations
  int components_removed = 0;
  ReconTimings timings;
  Image preview;                ///< RGB, 4 panels side by side (empty when settings.preview is false)
};

/// Input image -> network input (3 x 137 x 137). `mask` (optional, any size, white = object) replaces the
/// image's alpha. Throws InvalidInput naming `what` for an empty image, a mask of another size, or an image that
/// is only background.
Eigen::VectorXf prepare_recon_input(const Image& image, const Image* mask, const ReconSettings& settings,
                                    const std::string& what);

/// Holds the networks; run() is thread-safe (the pose network is serialised by a mutex).
class Reconstructor {
 public:
  /// `pose` may be null: then every run needs a camera.
  Reconstructor(std::unique_ptr<SdfNet> sdf, std::unique_ptr<PoseNet> pose);
  ~Reconstructor();
  /// Load both models (pose_path may be empty). IoError naming the file on failure.
  static std::unique_ptr<Reconstructor> load(const std::string& sdf_path, const std::string& pose_path);

  [[nodiscard]] const SdfNet& sdf() const { return *sdf_; }
  [[nodiscard]] bool has_pose() const { return pose_ != nullptr; }

  /// Reconstruct one image. `camera` null = estimate it. `what` names the input in error messages.
  ReconResult run(const Image& image, const Image* mask, const Camera* camera, const ReconSettings& settings,
                  const std::string& what) const;
  /// Same from a prepared network input (3 x 137 x 137).
  ReconResult run_input(const Eigen::VectorXf& input, const Camera* camera, const ReconSettings& settings,
                        const std::string& what) const;
  /// Camera estimate of a network input (InvalidInput when no pose network is loaded).
  Camera estimate_camera(const Eigen::VectorXf& input) const;

 private:
  std::unique_ptr<SdfNet> sdf_;
  std::unique_ptr<PoseNet> pose_;
  mutable std::mutex pose_mutex_;
};

/// The preview: input | render of `mesh` from `camera` | two more views (azimuth +120 and +240 degrees, slightly
/// higher), each panel size x size, RGB on white.
Image recon_preview(const Eigen::VectorXf& input, const Mesh& mesh, const Camera& camera, int size);

}  // namespace sdfkit
