// Sub-command registry of the `sdfkit` executable and the helpers every command shares.
// A command is one file apps/cmd_<name>.cpp that ends with SDFKIT_REGISTER_COMMAND.
#pragma once

#include "camera/image.h"
#include "core/json.h"
#include "recon/framing.h"
#include "train/dataset.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace sdfkit::app {

/// Exit codes of the CLI contract (docs/DESIGN.md, "Errors and exit codes").
enum ExitCode : int { kOk = 0, kUserError = 1, kPartialFailure = 2 };

struct Command {
  std::string name;
  std::string summary;
  /// Adds the command's options to `app` and returns the function that runs it after parsing.
  std::function<std::function<int()>(CLI::App& app)> setup;
};

std::vector<Command>& registry();
bool register_command(Command command);

/// The folder of the shipped models: $SDFKIT_MODEL_DIR when set, else <the executable's folder>/../share/sdfkit/models
/// (an installed sdfkit; in the build tree CMake links it to the source's data/models). Empty when neither exists.
std::string default_model_dir();
/// default_model_dir()/file, or "" when there is no model folder (commands then ask for --model).
std::string default_model_path(const std::string& file);
/// `path`, or an InvalidInput saying how to name a model when it is empty (no default model folder).
std::string require_model_path(const std::string& path, const std::string& flag);

/// Numeric checks of flags whose messages read "--jobs: must be > 0 (got 0)" rather than CLI11's range text
/// (which prints the bounds of a double: "not in range 0.000000 to 1797693...").
CLI::Validator positive();
CLI::Validator non_negative();
CLI::Validator in_range(double lo, double hi);

/// "MIN,MAX" with 0 < MIN <= MAX (finite) as {MIN, MAX}; InvalidInput naming `what` (e.g. "train sdf: --zoom-range")
/// otherwise.
std::pair<double, double> parse_positive_range(const std::string& text, const std::string& what);
/// "K1,K2,..." of magnifications in [0.5, 2] other than 1 (a zoom TTA), or "none" = {}; InvalidInput naming `what`
/// otherwise.
std::vector<double> parse_zoom_list(const std::string& text, const std::string& what);
/// The inverse of parse_zoom_list ("none" for an empty list).
std::string zoom_list(const std::vector<double>& zooms);
/// "A,B,C,..." of positive integers (layer widths) as a list; InvalidInput naming `what` (e.g. "--encoder")
/// otherwise.
std::vector<int> parse_widths(const std::string& text, const std::string& what);
/// The inverse of parse_widths: "16,32,64" (the default text of a width-list flag).
std::string join_widths(const std::vector<int>& widths);

/// Mesh formats the commands write (core/mesh_io.h write_mesh), as extensions without the dot.
extern const std::vector<std::string> kMeshOutExtensions;
/// True when `path` ends in one of kMeshOutExtensions (case-insensitive): a mesh file rather than a folder.
bool is_mesh_out_path(const std::string& path);

/// "1 image", "3 images": a count of input images in a message.
std::string image_count(size_t n);

/// Extensions (lower case, no dot) of the image files a folder input contributes: the still-image formats this
/// OpenImageIO reads (PNG, JPEG, EXR, TIFF, BMP, WebP, HEIC/HEIF/AVIF, GIF, PNM, Targa, Radiance HDR, JPEG 2000).
extern const std::vector<std::string> kImageExtensions;
/// True when `path` ends in one of kImageExtensions (case-insensitive).
bool is_image_path(const std::string& path);
/// True when `path` is a list file of images (.txt or .lst).
bool is_list_path(const std::string& path);
/// The images of an input argument: IMAGE (any file that is not a list file, whatever its extension: OpenImageIO
/// decides when it is read), a folder of images (files with an extension of kImageExtensions, sorted, not
/// recursive; *_mask.*, *.mask.* and *.preview.* files skipped), or a .txt/.lst list file (one path per line,
/// relative to the list's folder; blank lines and # comments skipped). IoError / InvalidInput naming `input` when
/// it is missing or holds no image.
std::vector<std::string> collect_inputs(const std::string& input);

/// The segmenter network of `model_path` (models/seg_net.h) as framing.segmenter and framing.segmenter_batch: one
/// network shared by both and by every thread, each call holding a lock (the network keeps its activations).
void use_shared_segmenter(sdfkit::FramingSettings& framing, const std::string& model_path);

/// Help text of --seg-scan (recon, segment), and its setting: "on" / "off"; --seg-scan on with --seg-zoom 0 is an
/// InvalidInput (the scan zooms in on each window's answer).
extern const char* const kSegScanHelp;
bool seg_scan_setting(const CLI::App& app, const std::string& value, int zoom_rounds);

/// Help text of --seg-agreement (recon, segment: FramingSettings::grabcut_min_agreement).
extern const char* const kSegAgreementHelp;

/// Help text of --seg-sure (recon, segment: FramingSettings::grabcut_sure_object, grabcut_sure_background), its
/// default text from the settings, and the settings from its value when given ("P,F" or "none"; InvalidInput for
/// another).
extern const char* const kSegSureHelp;

/// `--aug-mask-error` and `--mask-error-edge`, the segmentation-error augmentation of `train sdf` and `train pose`.
void add_mask_error_options(CLI::App& app, MaskErrorAugmentSettings& settings);
/// `--ema`, the weights' moving average of `train sdf` and `train pose` (0 = off, else a decay in (0, 1)).
void add_ema_option(CLI::App& app, double& decay);
std::string seg_sure_default(const FramingSettings& framing);
void seg_sure_setting(const CLI::App& app, const std::string& value, FramingSettings& framing);

/// recon's and segment's segmenter flags: --seg-model, --seg-zoom and --seg-scan are errors with --segment grabcut or
/// none, --seg-agreement and --seg-sure with any but auto; sets framing.segmenter_scan (seg_scan_setting), the sure
/// labels (seg_sure_setting) and, when `load` (recon: no --mask) and the segmentation reads the network (net, or
/// auto with its model named or present), framing.segmenter and segmenter_batch (use_shared_segmenter).
void configure_segmenter(const CLI::App& app, FramingSettings& framing, const std::string& seg_model,
                         const std::string& seg_scan, const std::string& seg_sure, bool load);

class ProgressBar;

/// The output files of a batch: `out` itself for one image (many = false), else out/<input's stem><suffix>. Fixed
/// before any work: two inputs with one stem (a.png and a.jpg in a folder, or one name in two listed folders) would
/// write the same file, so the later one gets a clash message ("...; not <verb>") and fails as an item. The folder
/// the outputs go to is created first; IoError (with the system's reason) when it cannot be, or cannot be written.
struct BatchOutputs {
  std::vector<std::string> paths, clash;  ///< per input; clash empty when the path is its own
};
BatchOutputs batch_outputs(const std::vector<std::string>& inputs, bool many, const std::string& out,
                           const std::string& suffix, const std::string& verb);

/// Runs item(i, record, bar) for every input (`jobs` at a time) under a progress bar labelled `label`. The record
/// starts as {"input": inputs[i]}; an input with a clash, or whose item throws, gets "error" (the message on one
/// line, also printed as "sdfkit: error: ..."), and counts in *failed. Returns the records in input order.
std::vector<Json> run_batch(const std::string& label, const std::vector<std::string>& inputs,
                            const std::vector<std::string>& clash, int jobs,
                            const std::function<void(size_t i, Json& record, ProgressBar& bar)>& item, long* failed);

/// The exit code of a batch of `items` with `failed` failures: kOk, kUserError when its only item failed, else
/// kPartialFailure.
int batch_exit_code(long failed, size_t items);

/// True when stderr is a terminal (progress bars are drawn only then).
bool stderr_is_tty();

/// A progress bar on stderr, drawn only on a terminal; thread-safe `update(done)`.
class ProgressBar {
 public:
  ProgressBar(std::string label, long total);
  ~ProgressBar();
  void update(long done);
  void tick();  ///< done + 1
  /// Prints `line` (and a newline) to `stream` above the bar: on a terminal the bar's line is cleared first and
  /// the bar drawn again below. Thread-safe, so that parallel items can report without tearing the bar.
  void print_line(std::FILE* stream, const std::string& line);
  void finish();

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace sdfkit::app

#define SDFKIT_CONCAT_INNER(a, b) a##b
#define SDFKIT_CONCAT(a, b) SDFKIT_CONCAT_INNER(a, b)
/// Register a sub-command: SDFKIT_REGISTER_COMMAND("prep", "prepare a dataset", setup_function).
#define SDFKIT_REGISTER_COMMAND(NAME, SUMMARY, SETUP) \
  static const bool SDFKIT_CONCAT(sdfkit_registered_, __LINE__) = ::sdfkit::app::register_command({NAME, SUMMARY, SETUP})
