// `sdfkit bench recon`: seconds per image against reconstruction error for the adaptive and the dense extraction
// at several effective resolutions (65^3, 129^3, 257^3), on prepared test shapes with their GT meshes.
#pragma once

#include "core/json_fwd.h"

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

struct ReconBenchSettings {
  std::string data;                         ///< prepared dataset with views and gt.obj
  std::string split = "test";               ///< split name or list file
  int shapes = 4;                           ///< shapes (view 0 of each) to reconstruct
  std::string model;                        ///< SDF network model
  std::string pose_model;                   ///< pose network (used with cam "est")
  std::string cam = "gt";                   ///< "gt" = the view's true camera, "est" = the pose network's estimate
  std::vector<int> resolutions{65, 129, 257};  ///< effective resolutions (grid points per axis)
  int dense_max = 257;                      ///< run the dense baseline only up to this resolution
  double safety = 0;                        ///< safety factor of the adaptive extraction (0 = the model's default)
  int repeats = 1;                          ///< timed runs per (shape, setting); the median is reported
};

/// One (resolution, extraction): one value per shape (seconds: the median over the repeats).
struct ReconBenchRow {
  int resolution = 0;
  bool dense = false;
  std::vector<double> seconds, field_seconds, evaluations, cd, iou, f1;
};

struct ReconBenchResult {
  std::string data, split, cam;  ///< as set
  double safety = 0;             ///< the safety factor used (the model's default when none was set)
  size_t shapes = 0;             ///< shapes reconstructed
  std::vector<ReconBenchRow> rows;  ///< per resolution: adaptive, then dense (up to dense_max)
};

/// Runs the benchmark. `on_progress(done, total)` (may be empty) is called with 0 before the first
/// reconstruction and after each (shape, row). Throws InvalidInput for a `cam` other than gt or est.
ReconBenchResult run_recon_bench(const ReconBenchSettings& settings,
                                 const std::function<void(long done, long total)>& on_progress = {});

/// The heading and Markdown table `sdfkit bench recon` prints, its JSON array, and its CSV.
std::string recon_bench_text(const ReconBenchResult& result);
Json recon_bench_json(const ReconBenchResult& result);
std::string recon_bench_csv(const ReconBenchResult& result);
/// Writes recon_bench_csv to OUT.csv and the plot of CD against seconds per image to OUT.svg.
void write_recon_bench_files(const ReconBenchResult& result, const std::string& out);

}  // namespace sdfkit
