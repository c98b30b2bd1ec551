// Checkpoint files: one JSON header + one flat float32 buffer (nets/layer.h ParamStore) + a checksum (docs/nets.md).
//
// Binary layout (little endian):
//   8 bytes  magic "SDFKITCK"
//   4 bytes  uint32 format version (kCheckpointVersion)
//   8 bytes  uint64 header length L
//   L bytes  header, JSON text: the caller's fields (architecture, hyper-parameters, training state, ...) plus
//            "blocks": [{"name", "offset", "count"}] describing the payload (offsets/counts in floats)
//   4*F bytes payload: the float32 blocks back to back (parameters, optimiser moments, ...)
//   8 bytes  uint64 FNV-1a 64 of every preceding byte
// Loading checks magic, version, sizes (truncation), the checksum (any corrupted byte), then the JSON and the
// block table; every failure is an IoError naming the file and the problem.
#pragma once

#include "core/files.h"
#include "core/json.h"
#include "nets/optim.h"

#include <string>
#include <utility>
#include <vector>

namespace sdfkit {

inline constexpr uint32_t kCheckpointVersion = 1;

struct Checkpoint {
  Json header = Json::object();
  std::vector<std::pair<std::string, std::vector<float>>> blocks;

  /// The block called name (IoError when missing, or when expected_count >= 0 and its size differs).
  [[nodiscard]] const std::vector<float>& block(const std::string& name, long expected_count = -1) const;
  [[nodiscard]] bool has_block(const std::string& name) const;
  void set_block(const std::string& name, std::vector<float> values);

  /// Store / restore an optimiser's state (header["optimizer"] + its buffers as blocks).
  void put_optimizer(const Optimizer& opt);
  void get_optimizer(Optimizer& opt) const;
  /// Store / restore a weight average (header["weight_average"] + block "ema"); get_average throws IoError when
  /// the checkpoint has none or its decay or size differs.
  void put_average(const WeightAverage& average);
  void get_average(WeightAverage& average) const;
};

/// Atomic write (temporary file + rename). Non-finite values in a block are refused (InvalidInput).
void save_checkpoint(const std::string& path, const Checkpoint& checkpoint);
/// IoError naming the file on a missing, truncated, corrupt or foreign file.
Checkpoint load_checkpoint(const std::string& path);

/// The progress a resumable training state records beside its parameters and optimiser.
struct TrainingProgress {
  long step = 0;
  double seconds = 0;            ///< training time so far
  Json curve = Json::array();    ///< the loss curve's rows so far
};

/// A resumable training state: header kind, architecture, settings, step, seconds and curve; blocks "params" (the
/// n values) and the optimiser's.
Checkpoint training_state_checkpoint(const std::string& kind, const Json& architecture, const Json& settings,
                                     const TrainingProgress& progress, const float* params, size_t n,
                                     const Optimizer& opt);
/// Restore what training_state_checkpoint stored (after the caller's header checks): the n parameters, the
/// optimiser, and the progress. IoError naming the file when the parameter count differs.
TrainingProgress restore_training_state(const Checkpoint& checkpoint, float* params, size_t n, Optimizer& opt);

/// InvalidInput unless header[key] equals expected (e.g. the architecture the caller is about to build);
/// the message names the file and the first differing JSON path.
void require_header_match(const Checkpoint& checkpoint, const std::string& key, const Json& expected,
                          const std::string& path);

}  // namespace sdfkit
