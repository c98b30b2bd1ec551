// What a training loop (train_pose, train_sdf) reports to its caller after every step, and the names of the files
// both loops write beside the model.
#pragma once

#include <filesystem>
#include <string>

namespace sdfkit {

/// The loss curve's files beside a model: MODEL_STEM.loss.csv and MODEL_STEM.loss.svg (models/sdf.ckpt ->
/// models/sdf.loss.csv), for `train sdf` and `train pose` alike.
inline std::string loss_curve_path(const std::string& model, const char* extension) {
  const std::filesystem::path p(model);
  return (p.parent_path() / p.stem()).string() + ".loss." + extension;
}

/// The step just taken; `validated` and `val` on the steps that ran a validation. `Scores` is the loop's own
/// validation record (PoseScores, SdfValidation).
template <typename Scores>
struct TrainEvent {
  TrainEvent() = default;
  TrainEvent(long at_step, long total_steps, double step_loss, double step_lr, double elapsed)
      : step(at_step), total(total_steps), loss(step_loss), lr(step_lr), seconds(elapsed) {}
  long step = 0, total = 0;
  double loss = 0, lr = 0, seconds = 0;  ///< the step's training loss and rate; wall seconds including resumed runs
  bool validated = false;
  Scores val;
  /// With a weight average (`--ema`): `val` scores the average (what the model file holds) and val_raw the weights
  /// the optimiser updates.
  bool averaged = false;
  Scores val_raw;
};

}  // namespace sdfkit
