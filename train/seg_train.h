// Training of the foreground segmenter (`sdfkit train seg`): (shape, view) renders of a prepared dataset composited
// onto backgrounds (train/seg_data.h), per-pixel binary cross-entropy + a soft-IoU term (segmentation_loss), Adam on a
// cosine learning rate, periodic validation (mean mask IoU at threshold 0.5 on a fixed seeded set of validation
// composites), CSV + SVG loss curves, a resumable training state that continues bit for bit, and the model file.
//
// Determinism: item b of step k is the global item g = k * batch + b: its (shape, view) is entry g mod N of the
// seeded permutation of epoch g / N of the N (shape, view) pairs, and its composite draws from (seed, g) only. Items
// run in parallel, one per replica of the network (sharing the master's parameters, owning their gradients), and
// the step's gradient is the sum of the item gradients in item order: the same bytes for any thread count.
#pragma once

#include "core/json.h"
#include "models/seg_net.h"
#include "train/dataset.h"
#include "train/seg_data.h"
#include "train/train_event.h"

#include <functional>
#include <string>

namespace sdfkit {

struct SegTrainSettings {
  std::string data;                   ///< prepared dataset folder (views/NN.png RGBA renders)
  std::string backgrounds;            ///< folder or list of background photos ("" = procedural backgrounds only)
  int background_side = 256;          ///< backgrounds are shrunk to this longer side when loaded
  /// Cut-out objects (RGBA images: a folder or list, as `backgrounds`) of composite.cutouts; shrunk as the
  /// backgrounds. Training composites only: the validation composites have none.
  std::string cutouts;
  std::string train_split = "train";  ///< split name or list file (DatasetSettings::split)
  std::string val_split = "val";      ///< "" = validate on (other composites of) the training shapes
  /// Background photos of the validation composites, kept out of training (a folder or list, as `backgrounds`);
  /// "" = the training backgrounds. Validation only reads them: the training bytes do not depend on them.
  std::string val_backgrounds;
  std::string out;                    ///< model path; MODEL_STEM.loss.csv/.svg and MODEL.train.ckpt beside it
  SegNetConfig net;
  SegCompositeSettings composite;     ///< composite.size is taken from net.size
  long steps = 20000;
  int batch = 16;
  double lr = 1e-3;  ///< Adam; cosine decay to lr_min over `steps`
  double lr_min = 1e-5;
  double beta1 = 0.9;
  double weight_decay = 0;
  double grad_clip = 5.0;   ///< gradient-norm clip (0 = off)
  double iou_weight = 0.5;  ///< weight of the soft-IoU term (0 = cross-entropy alone)
  /// The cross-entropy of the label's thin parts (thin_part_weights: what an opening by a disc of thin_radius px
  /// removes) weighs thin_weight times a pixel's; 1 = off. Validation losses stay unweighted.
  double thin_weight = 1.0;
  int thin_radius = 2;
  int val_every = 250;      ///< validate + checkpoint every N steps (and at the end / time limit)
  int val_items = 128;      ///< validation composites
  int max_shapes = 0;       ///< first N shapes of the training split (0 = all)
  uint64_t seed = 1;
  std::string init;         ///< start from this segmenter model (same architecture, or the same without the fine
                            ///< branch: SegNetT::start_from_coarse); ignored when resuming
  bool resume = false;
  double time_limit_seconds = 0;  ///< stop (and save) after this much wall time (0 = none)
};

struct SegScores {
  double loss = 0;  ///< mean segmentation_loss
  double iou = 0;   ///< mean mask IoU at threshold 0.5 over the canvas (the letterbox's padding excluded)
  long items = 0;
};

using SegTrainEvent = TrainEvent<SegScores>;

struct SegTrainResult {
  long steps = 0, start_step = 0;
  double seconds = 0, total_seconds = 0;
  SegScores val;
  long train_items = 0;  ///< (shape, view) pairs of the training split
  long backgrounds = 0;  ///< background photos loaded
  long val_backgrounds = 0;  ///< validation background photos loaded (0 = validation used the training ones)
  long cutouts = 0;          ///< cut-out objects loaded
  std::string model, csv, plot;
};

SegTrainResult train_seg(const SegTrainSettings& settings, const std::function<void(const SegTrainEvent&)>& on_event = {});

/// Mask IoU of probabilities against labels, both thresholded at 0.5, over the rectangle [x0, x0 + w) x [y0, y0 + h)
/// of S x S maps (1 when both masks are empty there).
double mask_iou(const float* prob, const float* label, int size, int x0, int y0, int w, int h);

/// The (shape, view) pair index of global item g among n pairs: entry g mod n of epoch g / n's seeded permutation.
long seg_item_pair(uint64_t seed, long n, long g);

}  // namespace sdfkit
