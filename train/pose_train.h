// Training and evaluation of the pose estimator (`sdfkit train pose`, `sdfkit eval-pose`): seeded batches from
// the prepared dataset (train/dataset.h), DISN's L_cam, Adam, periodic validation (L_cam, d3D, d2D), a CSV loss
// curve + SVG plot, checkpoints that a resumed run continues bit for bit, and the model file.
#pragma once

#include "camera/pose_metrics.h"
#include "core/json.h"
#include "core/json.h"
#include "models/pose_net.h"
#include "nets/optim.h"
#include "train/dataset.h"
#include "train/train_event.h"

#include <functional>
#include <map>
#include <memory>
#include <string>

namespace sdfkit {

struct PoseTrainSettings {
  std::string data;                   ///< prepared dataset folder
  std::string train_split = "train";  ///< split name or list file (DatasetSettings::split)
  std::string val_split = "val";      ///< "" = validate on training shapes
  std::string out;                    ///< model path; <out>.csv and <out>.svg beside it
  PoseNetSettings net;
  long steps = 2000;
  int batch = 16;
  int points = 512;        ///< sample points per item for L_cam
  double lr = 5e-4;        ///< Adam; cosine decay to lr_min over `steps`
  double lr_min = 1e-5;
  double beta1 = 0.5;      ///< DISN's Adam beta1
  double weight_decay = 0;
  double grad_clip = 5.0;  ///< gradient-norm clip (0 = off)
  int val_every = 200;     ///< validate + checkpoint every N steps (and at the end)
  int val_items = 48;      ///< (shape, view) items used for validation
  int max_shapes = 0;
  /// Photometric augmentation of the training images (the camera stays exact; train/dataset.h). Off by default in
  /// the struct; `sdfkit train pose` sets its measured defaults.
  ImageAugmentSettings augment;
  /// Zoom augmentation (train/dataset.h): images magnified about their centre, the camera distance divided by the
  /// magnification, so that the network reads the distance from the object's size. Applied before `augment`.
  ZoomAugmentSettings zoom;
  /// Reframing augmentation (train/dataset.h), after the zoom: images framed as recon frames photos, the principal
  /// point moved with the crop and the distance divided by the magnification (CameraFollow::kDistance, required).
  /// Needs the centre head (net.centre_head), which learns where the crop put the object-frame origin.
  ReframeAugmentSettings reframe = [] {
    ReframeAugmentSettings r;
    r.camera = ZoomAugmentSettings::CameraFollow::kDistance;
    return r;
  }();
  /// Segmentation-error augmentation (train/dataset.h, off by default), applied first: images with thin parts dropped,
  /// the outline moved and a blob added, as recon's composites of photos with an imperfect mask; the camera stays the
  /// true one.
  MaskErrorAugmentSettings mask_error;
  /// Weight of the centre head's loss (PoseLossOptions::centre_weight; used with net.centre_head).
  double centre_weight = 1;
  /// Weight of the azimuth head's cross-entropy (net.azimuth_bins > 0 required when positive).
  double azimuth_weight = 0;
  /// The object-frame rotations that map a training shape onto itself (e.g. sdf/symmetry.h from its gt mesh),
  /// called once per training shape at the start, in parallel; when set, L_cam and the azimuth target are taken
  /// modulo them (PoseLossOptions). `symmetry_tag` names the source in the resumable state (a resume must use the
  /// same one).
  std::function<std::vector<Mat3>(const ShapeEntry&)> symmetries;
  std::string symmetry_tag;
  /// Decay of the weights' exponential moving average (nets/optim.h WeightAverage; 0 = none, e.g. 0.999): when
  /// set, validation scores the average, the model file holds it, and the raw weights' validation goes to the
  /// curve's *_raw columns and PoseTrainResult::val_raw. The resumable state keeps both.
  double ema = 0;
  uint64_t seed = 1;
  /// Start from the parameters of this pose model (fine-tuning) instead of the seeded initialisation: same
  /// architecture, except that the distance range may differ (PoseNet::adopt_parameters re-expresses the distance
  /// head). Ignored when a resumable state is found (--resume).
  std::string init;
  bool resume = false;
  double time_limit_seconds = 0;  ///< stop (and save) after this much wall time (0 = none)
};

/// The shipped pose model's recipe (docs/results/pose.md): the struct's defaults (DISN's loss on the small network)
/// with 28,000 steps, width 32 and a 36-bin azimuth head of weight 0.1. `sdfkit train pose` starts from these; the
/// symmetry source is the command's (`--symmetry-tol`).
PoseTrainSettings shipped_pose_recipe();

struct PoseScores {
  double loss = 0;  ///< mean L_cam
  double d3d = 0;   ///< mean d3D (object-frame units)
  double d2d = 0;   ///< mean d2D (pixels)
  long items = 0;
  /// Modulo each shape's symmetries (pose_errors_modulo): only from evaluate_pose with a symmetry source, else
  /// equal to d3d / d2d.
  double d3d_sym = 0, d2d_sym = 0;
  /// Modulo each image's twins (PoseEvalSettings::twins): only from evaluate_pose with a twin source, else equal
  /// to d3d / d2d.
  double d3d_twin = 0, d2d_twin = 0;
  /// Share of the items whose d2D exceeds kLargePoseError px (whole-view flips and turns; evaluate_pose only).
  double large = 0;
  /// Mean distance (pixels of the network image) between the estimated and the true principal point, i.e. where
  /// each camera shows the object-frame origin (evaluate_pose only; 0 for renders read without a centre head).
  double centre_px = 0;
  /// Mean relative distance error |d_est / d_true - 1| (evaluate_pose only).
  double distance_error = 0;
};

/// d2D (pixels) above which evaluate_pose counts an estimate as a large error (PoseScores::large).
inline constexpr double kLargePoseError = 10.0;

using PoseTrainEvent = TrainEvent<PoseScores>;

struct PoseTrainResult {
  long steps = 0, start_step = 0;
  double seconds = 0;        ///< wall time of this run
  double total_seconds = 0;  ///< including earlier runs that were resumed
  PoseScores val;
  PoseScores val_raw;           ///< the raw weights' validation with --ema (else equal to val)
  double train_azimuth_ce = 0;  ///< mean azimuth cross-entropy of the last validation interval (0 without the head)
  double train_centre_loss = 0; ///< mean centre-head loss of the last validation interval (0 without the head)
  long symmetric_shapes = 0;    ///< training shapes with at least one symmetry (with a symmetry source)
  std::string model, csv, plot;
};

PoseTrainResult train_pose(const PoseTrainSettings& settings,
                           const std::function<void(const PoseTrainEvent&)>& on_event = {});

/// d3D / d2D (camera/pose_metrics.h) of the network on (shape, view) items, `points` seeded sample points per
/// shape (2048 as DISN). views < 0: every view of every shape. Per-category means in `per_category`.
struct PoseEvalSettings {
  int points = 2048;
  int views = -1;  ///< views per shape (first N), -1 = all
  int batch = 16;
  uint64_t seed = 1;
  /// The object-frame rotations that map a shape onto itself (e.g. sdf/symmetry.h from its gt mesh), called once
  /// per shape (a list naming a shape twice shares its group), for several shapes at once from different threads;
  /// when set, d3d_sym / d2d_sym score each estimate against the closest symmetric twin of the truth.
  std::function<std::vector<Mat3>(const ShapeEntry&)> symmetries;
  /// Magnify every image by this factor about its centre and divide the true distance by it (zoom_images with
  /// probability 1; lowered per image when the object would leave the frame): how well the network reads the
  /// distance from the object's size. 1 = the views as rendered.
  double zoom = 1;
  /// Then frame every image as recon frames a photo (reframe_images with probability 1, the distance divided by
  /// the magnification, the principal point moved with the crop): how well the network reads recon's inputs.
  bool reframe = false;
  /// The object-frame rotations g whose turned camera (R_t g, t_t) this image cannot be told from, given the
  /// estimate (e.g. turned renders that look like the view: `eval-pose --twins`); when set, d3d_twin / d2d_twin
  /// score each estimate against the closest of the truth and those twins. Called once per image, serially, in
  /// (shape, view) order, after the network has read every image; `truth` is the camera the image was scored
  /// against (after --zoom / --reframe).
  std::function<std::vector<Mat3>(size_t shape, int view, const Camera& truth, const Camera& predicted)> twins;
};
/// One image's scores (evaluate_pose's per_item, in (shape, view) order).
struct PoseItemScore {
  std::string id;        ///< "<category>/<shape>"
  int view = 0;
  PoseErrors plain, sym;  ///< sym = plain for a shape without symmetries
  PoseErrors twin;        ///< = plain without a twin source or when the image has no twin
  double rotation_deg = 0;  ///< geodesic angle between the estimated and the true rotation
  /// The turn about the object's vertical axis (+y) closest to the rotation error, in (-180, 180]: R_est ~
  /// R_true R_y(azimuth_deg); a whole-view flip reads about 180.
  double azimuth_deg = 0;
  double distance = 0, distance_est = 0;  ///< true and estimated camera distance |t|
  double centre_px = 0;  ///< distance between the estimated and the true principal point (network image pixels)
};

PoseScores evaluate_pose(PoseNet& net, const Dataset& data, const PoseEvalSettings& settings,
                         std::map<std::string, PoseScores>* per_category = nullptr,
                         const std::function<void(long, long)>& progress = {},
                         std::vector<PoseItemScore>* per_item = nullptr);

}  // namespace sdfkit
