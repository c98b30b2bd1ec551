// Single-view reconstruction as a library function (what `sdfkit recon` runs per image):
//   image (any size, 1-4 channels) -> framing (recon/framing.h): the object found (alpha, mask, plain background or
//   GrabCut), composited on white and cropped like the training renders to 137 x 137
//   -> camera: estimated by the pose network, or given
//   -> SDF network: per-shape encoding once, then batches of points
//   -> adaptive extraction of the 0 level (extract/adaptive.h; safety factor > 1 because the network's field is
//      only an approximate SDF; the surface followed from the cells kept, so that a cell the bound misjudged leaves
//      no hole), clean-up of small components (extract/cleanup.h)
//   -> closed mesh in the object frame + a preview image (input | render from the input view | two other views).
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "core/types.h"
#include "extract/cleanup.h"
#include "models/pose_net.h"
#include "models/sdf_net.h"
#include "recon/camera_refine.h"
#include "recon/framing.h"

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace sdfkit {

/// The camera refinement settings recon uses by default (see ReconSettings::refine).
inline CameraRefineSettings recon_refine_defaults() {
  CameraRefineSettings s;
  s.sweep_azimuth_deg = 60.0;
  s.sweep_step_deg = 10.0;
  s.local_search = false;
  s.refine_distance = false;
  s.max_evaluations = 60;
  return s;
}

/// The adaptive extraction's safety factor for a model of `variant` when ReconSettings::safety is 0. An SDF network's
/// field is nearly a distance: 2. A binary-variant model's field (-logit / sdf_scale) is flat inside and outside and
/// steep at the surface; with surface following the refinement only has to touch every surface component once, and
/// 10 does that for the thinnest test shapes (docs/recon.md, "Extraction").
/// recon's default zoom TTA of the pose network (ReconSettings::pose_zoom_tta); empty = off.
inline const std::vector<double> kDefaultPoseZoomTta = {};

inline double default_extraction_safety(SdfVariant variant) { return variant == SdfVariant::kBinary ? 10.0 : 2.0; }

struct ReconSettings {
  int resolution = 129;          ///< final grid points per axis (65, 129, 257, ...)
  int coarse_resolution = 17;    ///< first level of the adaptive extraction
  /// Lipschitz allowance of the network field for the adaptive extraction (1 = trust it as a true SDF); 0 = the
  /// model's default (default_extraction_safety).
  double safety = 0;
  /// Binary-variant models: the occupancy probability whose level set is the surface (Occupancy Networks' threshold
  /// tau), in (0, 1). Not read for an SDF model, whose surface is its 0 level (`recon --threshold` refuses one).
  double threshold = 0.5;
  /// Mirror test-time augmentation: the SDF network also reads the input flipped left to right through the mirrored
  /// camera (mirror_camera), which shows it the object mirrored across x = 0; its field at the mirror image of each
  /// point is averaged with the plain one. An exact symmetry of the task (no assumption that the object is
  /// symmetric); twice the network work.
  bool mirror_tta = false;
  double box_half = 1.05;        ///< sampled cube [-box_half, box_half]^3 (object frame: the unit sphere + 5%)
  bool dense = false;            ///< evaluate the full grid instead (the baseline of `sdfkit bench recon`)
  /// Follow the surface from the adaptive extraction's final cells (ExtractSettings::follow_surface): every surface
  /// component the refinement touches comes out whole, as on the dense grid. What makes the adaptive extraction
  /// right for a binary-variant model, whose field (-logit / sdf_scale) is no distance and breaks the bound.
  bool follow_surface = true;
  /// Clean-up: drop components under this fraction of the largest's faces (extract/cleanup.h; DISN's rule is 0.3)
  double min_component_fraction = kDefaultKeepFraction;
  bool preview = true;
  int preview_size = 192;        ///< side of each preview panel in pixels
  /// Margin of the pose model's flip check (PoseNet::set_flip_check; used when the model has an azimuth head):
  /// the regressed camera is turned to the azimuth the head prefers when the head gives that azimuth more than
  /// this many times the probability mass of the regressed one. 0 = the 6D head alone.
  double flip_check = kDefaultFlipCheck;
  /// Mirror test-time augmentation of the pose network (PoseNet::set_mirror_tta): it also reads the input flipped
  /// left to right and combines the two estimates. One more pose forward pass (about 10 ms).
  bool pose_mirror_tta = true;
  /// Zoom test-time augmentation of the pose network (PoseNet::set_zoom_tta): the magnifications at which it also
  /// reads the input, the readings that agree averaged. One more pose forward pass per magnification (two with the
  /// mirror TTA). Empty = off.
  std::vector<double> pose_zoom_tta = kDefaultPoseZoomTta;
  /// The training renders' camera distances (camera/views.h: 2.45-3.0). With both set, an estimated camera whose
  /// distance falls outside them is read as a focal length (camera.h's distance_as_focal): the pose network answers
  /// an object magnified by recon's crop with a shorter distance, while that image is the one a camera at a render
  /// distance with a longer focal length makes, and the SDF network projects its points through the camera it is
  /// given. Both 0 = off (the network's camera as it is).
  double pose_distance_min = 0, pose_distance_max = 0;
  /// Rounds of test-time camera refinement by silhouette alignment (recon/camera_refine.h; 0 = off). Each round
  /// reconstructs a mesh at `refine_resolution` with the current camera, aligns its silhouette to the input's
  /// object mask (the framing's mask) and continues with the refined camera; the final mesh is reconstructed with
  /// the last camera.
  int refine_rounds = 0;
  /// true: the objective re-reconstructs the mesh with every candidate camera (the network's local features move
  /// with the camera, so a wrong camera yields a mesh carved to the mask as seen through that wrong camera; the
  /// joint objective scores how well the network's shape and the camera agree). false: align the one mesh
  /// reconstructed with the round's start camera (cheaper).
  bool refine_joint = true;
  int refine_resolution = 33;    ///< grid of the intermediate meshes (the final resolution when that is lower)
  /// The optimisation (docs/recon.md, "Camera refinement (`--refine-camera`)"): the joint objective, azimuth turns of -60..+60 degrees
  /// in 10 degree steps, no local search (the joint objective's coarse meshes make it noisy for Nelder-Mead).
  CameraRefineSettings refine = recon_refine_defaults();
  /// How run() finds and frames the object in the input image.
  FramingSettings framing;
  /// Rounds of fitting the crop to the object when the framing reframed the input (0 = off; docs/recon.md, "Input
  /// and framing"). frame_input centres the object's box at one size; a render shows the object-frame origin at the
  /// centre and the object at its distance's size. With a given camera one round moves the crop there exactly
  /// (training_crop); with an estimated one each round re-cuts the crop where the pose network's camera shows the
  /// object (framing_fit_centre), and the pose network then reads the new crop.
  int framing_fit_rounds = 1;
  int framing_fit_resolution = 33;
  /// Where a fitting round with an estimated camera puts the crop (docs/recon.md, "Input and framing"):
  /// kCamera: where the camera shows the object-frame origin, at its distance's size (what a given camera gets);
  /// kShape: at the unit-sphere frame (centre and radius, sdf/normalize.h) of a coarse mesh reconstructed through
  /// the camera (`framing_fit_resolution`); kAuto: kCamera when the pose network reading the reframed image has a
  /// centre head (it reads where the origin is), else kShape (its cameras show the origin at the image centre).
  enum class FitCentre { kAuto, kCamera, kShape };
  FitCentre framing_fit_centre = FitCentre::kAuto;
};

struct ReconTimings {
  double prepare = 0;   ///< image -> network input
  double pose = 0;      ///< camera estimation (0 when the camera was given)
  double encode = 0;    ///< SDF network per-shape work
  double field = 0;     ///< network evaluations inside the extraction
  double extract = 0;   ///< extraction excluding field evaluations (marching cubes, refinement bookkeeping)
  double cleanup = 0;
  double refine = 0;    ///< camera refinement: intermediate reconstructions + silhouette alignment
  double preview = 0;
  double total = 0;
};

struct ReconResult {
  Mesh mesh;                    ///< closed, object frame
  Camera camera;                ///< the camera used, of the 137 px network image, after refinement when it ran
  Camera input_camera;          ///< the same camera as a camera of the input image (run(); = camera for run_input)
  FramedInput framing;          ///< how run() framed the input (empty for run_input)
  int framing_fits = 0;         ///< rounds of ReconSettings::framing_fit_rounds that moved the crop
  bool camera_estimated = false;
  double flip_turn_deg = 0;     ///< degrees the flip check turned the estimated camera about +y (0 = kept)
  bool pose_mirror_tta = false; ///< the estimated camera combines the mirrored input's reading
  std::vector<double> pose_zoom_tta;  ///< the magnifications the pose network also read (empty = none)
  bool photo_pose = false;      ///< the camera was estimated by the photo pose network (a reframed input)
  bool photo_model = false;     ///< the photo SDF network reconstructed it (a reframed input)
  Camera initial_camera;        ///< the estimated or given camera before refinement
  std::vector<CameraRefineResult> refinements;  ///< one per refinement round (empty when off)
  long evaluations = 0;         ///< field evaluations
  int components_removed = 0;
  bool dense = false;           ///< the full grid was evaluated (ReconSettings::dense)
  double threshold = 0;         ///< occupancy threshold of a binary-variant model (0: an SDF model, level 0)
  bool mirror_tta = false;      ///< the field averaged with the mirrored input's (ReconSettings::mirror_tta)
  /// run_views: every view's network camera (given or estimated), in the order of the images; empty for one view
  std::vector<Camera> view_cameras;
  std::vector<Camera> view_input_cameras;  ///< the same as cameras of each input image
  std::vector<bool> view_estimated;        ///< whether each view's camera was estimated
  std::vector<bool> view_photo_pose;       ///< whether the photo pose network estimated it
  std::vector<bool> view_photo_model;      ///< whether the photo SDF network read it
  ReconTimings timings;
  Image preview;                ///< RGB, 4 panels side by side (empty when settings.preview is false)
};

/// A network input (C x size x size, channels first) flipped left to right: what the camera mirror_camera() of the
/// input's camera sees of the object mirrored across x = 0.
Eigen::VectorXf flip_network_input(const Eigen::VectorXf& input, int size);

/// The non-white pixels (is_ink, train/dataset.h: any channel off white by more than 0.05) of a network input (3 x 137 x 137).
Image input_foreground(const Eigen::VectorXf& input);

/// Holds the networks; run() is thread-safe (the pose network is serialised by a mutex).
class Reconstructor {
 public:
  /// `pose` may be null: then every run needs a camera. `photo_pose` (optional) estimates the camera of reframed
  /// inputs instead of `pose` (a pose network trained on images framed as recon frames a photo, with a centre head:
  /// data/models/pose_photo.md); inputs framed like the renders keep `pose`.
  /// `photo_sdf` (optional) likewise reconstructs reframed inputs instead of `sdf` (an SDF network fine-tuned on
  /// such crops: data/models/sdf_photo.md); it must share `sdf`'s variant, field scale and input channels
  /// (InvalidInput otherwise).
  Reconstructor(std::unique_ptr<SdfNet> sdf, std::unique_ptr<PoseNet> pose,
                std::unique_ptr<PoseNet> photo_pose = nullptr, std::unique_ptr<SdfNet> photo_sdf = nullptr);
  ~Reconstructor();
  /// Load the models (pose_path, photo_pose_path and photo_sdf_path may be empty). IoError naming the file on
  /// failure; InvalidInput naming photo_sdf_path when it does not match the SDF model.
  static std::unique_ptr<Reconstructor> load(const std::string& sdf_path, const std::string& pose_path,
                                             const std::string& photo_pose_path = "",
                                             const std::string& photo_sdf_path = "");

  [[nodiscard]] const SdfNet& sdf() const { return *sdf_; }
  [[nodiscard]] bool has_pose() const { return pose_ != nullptr; }
  [[nodiscard]] bool has_photo_pose() const { return photo_pose_ != nullptr; }
  /// The safety factor the adaptive extraction uses: settings.safety, or the model's default when it is 0.
  [[nodiscard]] double extraction_safety(const ReconSettings& settings) const;
  /// The occupancy threshold a binary-variant model is extracted at (settings.threshold; InvalidInput outside
  /// (0, 1)); 0 for an SDF model.
  [[nodiscard]] double occupancy_threshold(const ReconSettings& settings) const;
  /// The level of the network field (SdfNet::field) that is extracted: 0 for an SDF model; -logit(threshold) /
  /// sdf_scale for a binary one (its field is -logit / sdf_scale).
  [[nodiscard]] double surface_level(const ReconSettings& settings) const;

  /// Reconstruct one image: frame it (settings.framing), then run_input. `camera` (null = estimate it) is a camera of
  /// the input image (a camera of another size is scaled to the image's size first). `what` names the input in
  /// error messages. `missing` (optional, 1 channel, the image's size): coverage of the pixels whose content is
  /// unknown (occluded), taken through the framing; in the network image they are blended to the white background
  /// by their coverage, which is also the SDF network's mask channel when it has one (an RGB network sees the white).
  ReconResult run(const Image& image, const Image* mask, const Camera* camera, const ReconSettings& settings,
                  const std::string& what, const Image* missing = nullptr) const;
  /// Same from a prepared network input: 3 x 137 x 137 RGB, or 4 x 137 x 137 with the missing-data mask, or 8 x 137
  /// x 137: those four channels, then the unmasked crop and the object's mask (context_input, recon/framing.h) that a
  /// photo SDF model with an object channel reads (SdfNetConfig::MaskChannel::kObject; run() makes them for the inputs
  /// it reframes when that model is loaded). The pose network, camera refinement and the preview read the first three
  /// channels. `silhouette` (137 x 137 coverage: the framed alpha in run()) is
  /// the mask camera refinement aligns to; null = input_foreground(input).
  /// `reframed`: the input is a crop recon made of a larger image (run() passes FramedInput::reframed): its camera
  /// is estimated by the photo pose network when one is loaded.
  ReconResult run_input(const Eigen::VectorXf& input, const Camera* camera, const ReconSettings& settings,
                        const std::string& what, const Image* silhouette = nullptr, bool reframed = false) const;
  /// Multi-view reconstruction (DISN's multi-view application): several images of one object, each framed as run()
  /// frames one, each with its camera (`cameras[i]`, a camera of image i; null = estimated by the pose network, whose
  /// cameras all refer to the canonical object frame), and one mesh extracted from the mean of the views' fields
  /// (for a binary model, of their logits). The result's camera, framing and preview are those of the first view;
  /// view_cameras holds every view's network camera. Camera refinement is refused (it aligns one view).
  ReconResult run_views(const std::vector<Image>& images, const std::vector<const Camera*>& cameras,
                        const ReconSettings& settings, const std::vector<std::string>& what) const;
  /// Camera estimate of a network input (InvalidInput when no pose network is loaded), with the pose model's flip
  /// check at `flip_check` (ReconSettings::flip_check) and its mirror TTA when `mirror_tta`
  /// (ReconSettings::pose_mirror_tta) and zoom TTA at `zoom_tta` (ReconSettings::pose_zoom_tta); *flip_turn_deg (may
  /// be null) gets the check's turn. `reframed`: read by the photo pose network when one is loaded.
  Camera estimate_camera(const Eigen::VectorXf& input, double flip_check = kDefaultFlipCheck,
                         double* flip_turn_deg = nullptr, bool mirror_tta = true, bool reframed = false,
                         const std::vector<double>& zoom_tta = kDefaultPoseZoomTta) const;

 private:
  struct MeshStats;
  /// The network input of `framed` (frame_input's answer for `image`) in run_input's layout: RGB on white, the
  /// missing-data mask taken through the crop when `missing` (1 channel, the image's size) is given, and the
  /// context channels when the input is reframed and the photo SDF model reads them (missing pixels white there,
  /// and out of the object's mask).
  Eigen::VectorXf framed_input(const Image& image, const FramedInput& framed, const Image* missing) const;
  /// ReconSettings::framing_fit_rounds for run(): moves `framed`'s crop (and `input`, remade by `make_input`);
  /// returns the rounds that moved it.
  int fit_framing(const Image& image, FramedInput& framed, Eigen::VectorXf& input, const Camera* camera,
                  const ReconSettings& settings, const std::string& what,
                  const std::function<Eigen::VectorXf(const FramedInput&)>& make_input) const;
  /// The camera run_input and run_views use when none is given: estimate_camera with the settings' flip check and
  /// TTA, its distance read as a focal length when settings.pose_distance_max > 0 (distance_as_focal).
  Camera estimate_network_camera(const Eigen::VectorXf& input, const ReconSettings& settings, double* flip_turn_deg,
                                 bool reframed) const;
  struct ViewRef {
    const Eigen::VectorXf* input;  ///< network input (3, 4 or 8 x 137 x 137: run_input's layout)
    Camera camera;                 ///< its camera of the 137 px network image
    const SdfNet* net;             ///< the SDF network that reads it (sdf_for)
  };
  /// The SDF network of an input: the photo one for a reframed input when it is loaded.
  const SdfNet& sdf_for(bool reframed) const { return reframed && photo_sdf_ ? *photo_sdf_ : *sdf_; }
  /// The pose network that reads an input (the photo pose model for a reframed one when loaded); null without one.
  PoseNet* pose_for(bool reframed) const { return reframed && photo_pose_ ? photo_pose_.get() : pose_.get(); }
  Mesh reconstruct(const Eigen::VectorXf& input, const Camera& camera, const ReconSettings& settings, int resolution,
                   const std::string& what, MeshStats& stats, bool reframed = false) const;
  /// The result's fields every reconstruction fills the same way from the final mesh's stats, and the preview
  /// (of `preview_input`, 3 x 137 x 137).
  void finish_result(ReconResult& r, const MeshStats& st, const ReconSettings& settings,
                     const Eigen::VectorXf& preview_input) const;
  /// The mesh of the mean of the views' fields.
  Mesh reconstruct(const std::vector<ViewRef>& views, const ReconSettings& settings, int resolution,
                   const std::string& what, MeshStats& stats) const;
  std::unique_ptr<SdfNet> sdf_, photo_sdf_;
  std::unique_ptr<PoseNet> pose_, photo_pose_;
  mutable std::mutex pose_mutex_;  ///< serialises both pose networks
};

/// The preview: input | render of `mesh` from `camera` | two more views (azimuth +120 and +240 degrees, slightly
/// higher), each panel size x size, RGB on white.
Image recon_preview(const Eigen::VectorXf& input, const Mesh& mesh, const Camera& camera, int size);

}  // namespace sdfkit
