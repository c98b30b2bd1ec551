// Training of the SDF network on a prepared dataset (`sdfkit train sdf`): seeded batches (train/dataset.h),
// DISN's weighted L1 on 10 x (sdf - 0.003) (BCE on occupancy for the binary variant), Adam, periodic validation,
// a CSV loss curve + SVG plot, atomic checkpoints that a resumed run continues bit for bit, and the model file.
#pragma once

#include "camera/field_silhouette.h"
#include "core/json.h"
#include "models/patch_critic.h"
#include "models/sdf_net.h"
#include "train/context.h"
#include "train/dataset.h"
#include "train/train_event.h"

#include <functional>
#include <memory>
#include <string>

namespace sdfkit {

/// Adversarial fine-tuning (the occlusion paper's conditional patch critic, `train sdf --adversarial W`). Each step,
/// every item's predicted field is rendered through the item's camera as a soft silhouette (camera/field_silhouette.h:
/// the network evaluated at each pixel ray's point of smallest predicted value, alpha = sigmoid(-pred / temperature);
/// a binary network's value is -logit / 10, which is the SDF network's prediction it starts from);
/// the critic (models/patch_critic.h) sees the input image (as the network saw it, occlusion included, resized to the
/// render's size) stacked with either that render (fake) or the object's silhouette in the unoccluded image (real:
/// its non-white pixels). The SDF network's loss becomes  mean item loss + weight * BCE(critic(fake), real), whose
/// gradient reaches the network through the rays' points; the critic is updated once per step on BCE(real, 1) +
/// BCE(fake, 0). The critic's state is saved in the training checkpoint; a run resumed from a checkpoint without one
/// (a model trained without the critic) starts a fresh critic.
struct SdfAdversarialSettings {
  double weight = 0;  ///< weight of the generator's adversarial loss (0 = off)
  PatchCriticSettings critic;
  FieldSilhouetteSettings render;  ///< render.size must equal critic.size
  double temperature = 0.15;       ///< in network output units (10 x sdf): 0.015 in SDF units

  [[nodiscard]] bool enabled() const { return weight > 0; }
  [[nodiscard]] Json to_json() const;
};

struct SdfTrainSettings {
  std::string data;                 ///< prepared dataset folder
  std::string train_split = "train";  ///< split name or list file (see DatasetSettings::split)
  std::string val_split = "val";    ///< "" = validate on the first training shapes
  std::string out;                  ///< model checkpoint path; <stem>.loss.csv / <stem>.loss.svg beside it
  SdfNetConfig net;
  long steps = 20000;
  int batch = 8;                    ///< (shape, view) items per step
  int points = 1024;                ///< SDF samples per item per step
  double lr = 1e-4;                 ///< Adam (beta1 0.5 as DISN)
  double lr_min = 0.0;              ///< cosine decay to this value over `steps` (lr_min = lr: constant)
  long lr_steps = 0;                ///< steps over which the cosine decays (0 = `steps`; more: stop mid-decay)
  double weight_decay = 1e-5;
  double grad_clip = 0.0;           ///< clip the gradient norm (0 = off)
  int val_every = 500;              ///< validate + checkpoint every N steps (and at the end)
  int val_shapes = 8;               ///< shapes (view 0) used for validation
  int val_points = 4096;            ///< samples per validation shape
  int max_shapes = 0;               ///< use only the first N training shapes (0 = all)
  uint64_t seed = 1;
  /// Decay of the weights' exponential moving average (nets/optim.h WeightAverage; 0 = none, e.g. 0.999): when set,
  /// validation scores the average and the model's parameters are the average (block "params"; the raw weights,
  /// which a resume continues, are block "raw_params"); the raw weights' validation goes to the curve's *_raw columns
  /// and SdfTrainResult::val_raw.
  double ema = 0;
  bool resume = false;              ///< continue from `out` if it exists
  /// Start from this model's weights (same configuration, or the same one without the mask channel and/or the
  /// mirror features this network has: SdfNet::adopt_parameters) instead of the seeded initialisation; fresh
  /// optimiser.
  std::string init;
  /// Camera jitter (degrees, 0 = off): each training item's camera is turned about the object's vertical axis by
  /// a Gaussian angle of this standard deviation before the local features are sampled (the SDF targets stay), so
  /// that the network tolerates the azimuth errors of an estimated camera. Seeded per (seed, step) (jitter_cameras).
  double camera_jitter_deg = 0;
  /// Zoom augmentation (train/dataset.h, off by default): images magnified about their centre with the cameras'
  /// intrinsics magnified with them (CameraFollow::kFocal, exact), so that the network meets objects at other scales
  /// and focal lengths than the renders', as recon's framing of real inputs produces. Seeded per (seed, item).
  ZoomAugmentSettings zoom = [] {
    ZoomAugmentSettings z;
    z.camera = ZoomAugmentSettings::CameraFollow::kFocal;
    return z;
  }();
  /// Reframing augmentation (train/dataset.h, off by default), applied after the zoom: images brought to the framing
  /// recon gives real inputs (the object's box at a fixed size and place, the principal point moved with it), so
  /// that the network meets off-centre cameras. Seeded per (seed, item).
  ReframeAugmentSettings reframe;
  /// Segmentation-error augmentation (train/dataset.h, off by default), applied before the zoom: images with thin parts
  /// dropped, the outline moved and a blob added, as recon's composites of photos with an imperfect mask; the camera
  /// and the shape stay the true ones.
  MaskErrorAugmentSettings mask_error;
  /// Occlusion augmentation (train/dataset.h, off by default), applied after the zoom and the reframing. With an RGB + mask network
  /// (net.input_channels = 4) the network also reads the removed pixels' mask; an RGB network sees white there.
  OcclusionAugmentSettings occlusion;
  /// Unmasked inputs (train/context.h), for a network whose fourth channel is the object's mask
  /// (net.mask_channel = kObject; needed): applied last, every image gets its object's mask as that channel, some a
  /// drawn background and a mask error. Excludes the occlusion and the image-side mask-error augmentations.
  ContextAugmentSettings context;
  /// The photographs of the drawn backgrounds (a folder or a list file, train/seg_data.h BackgroundSet); empty =
  /// procedural backgrounds only.
  std::string context_backgrounds;
  SdfAdversarialSettings adversarial;  ///< off by default; single-process training only
  double time_limit_seconds = 0;    ///< stop (and save) once this much time has passed (0 = no limit)
};

struct SdfValidation {
  double loss = 0;           ///< training loss on the validation samples
  double sign_accuracy = 0;  ///< fraction of samples whose predicted sign (of sdf - offset) is right
  double sample_iou = 0;     ///< IoU of the inside sets (sdf < offset) over the validation samples
  int shapes = 0;
};

using SdfTrainEvent = TrainEvent<SdfValidation>;

struct SdfTrainResult {
  long steps = 0;           ///< final step count
  long start_step = 0;      ///< > 0 when resumed
  double seconds = 0;       ///< wall time of this run
  double final_loss = 0;    ///< mean training loss of the last validation interval
  SdfValidation val;        ///< last validation
  SdfValidation val_raw;    ///< the raw weights' last validation with a weight average (else equal to val)
  std::string model, csv, plot;
};

/// Train (or resume) and write the model. InvalidInput/IoError on bad settings or data.
SdfTrainResult train_sdf(const SdfTrainSettings& settings,
                         const std::function<void(const SdfTrainEvent&)>& on_event = {});

/// Validation metrics of a network on `data` items (shape i, view 0), val_points samples each (seeded).
SdfValidation validate_sdf(const SdfNet& net, const Dataset& data, int shapes, int points, uint64_t seed);

/// The camera jitter of SdfTrainSettings::camera_jitter_deg: turns every camera about the object's vertical axis
/// (R' = R rot_y(a), the look-at orbit's azimuth change; t kept) by a Gaussian angle a of standard deviation
/// `sigma_deg`, drawn in order from a generator derived from (seed, step). `cameras` are the batch's items from
/// `first_item` on (a rank's share): item b always gets the b-th draw.
void jitter_cameras(std::vector<Camera>& cameras, double sigma_deg, uint64_t seed, long step, int first_item = 0);

}  // namespace sdfkit
