// What a training loop (train_pose, train_sdf) reports to its caller after every step.
#pragma once

namespace sdfkit {

/// The step just taken; `validated` and `val` on the steps that ran a validation. `Scores` is the loop's own
/// validation record (PoseScores, SdfValidation).
template <typename Scores>
struct TrainEvent {
  TrainEvent() = default;
  TrainEvent(long step_, long total_, double loss_, double lr_, double seconds_)
      : step(step_), total(total_), loss(loss_), lr(lr_), seconds(seconds_) {}
  long step = 0, total = 0;
  double loss = 0, lr = 0, seconds = 0;  ///< the step's training loss and rate; wall seconds including resumed runs
  bool validated = false;
  Scores val;
};

}  // namespace sdfkit
