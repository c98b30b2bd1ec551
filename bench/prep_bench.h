// `sdfkit bench prep`: seconds per shape of the full preparation (sparse grid + samples + gt mesh) at 1 and 2
// threads, grid memory and active voxels against a dense 257^3 grid computed in the same run (exact distance +
// winding-number sign at every grid point), and the grid's error against a brute-force exact SDF at random band
// points. Results: docs/benchmarks/prep.md.
#pragma once

#include "core/json_fwd.h"
#include "sdf/prepare.h"
#include "sdf/sparse_sdf.h"

#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

struct PrepBenchSettings {
  /// Meshes to time after the built-in 50k closed mesh and soup; when empty, every file of `example_meshes`.
  std::vector<std::string> meshes;
  std::string example_meshes;   ///< folder of example meshes (`sdfkit bench prep`: data/examples/meshes); may be ""
  int repeats = 3;              ///< timed runs per shape and thread count (median reported)
  int dense_res = 257;          ///< resolution of the dense baseline grid over [-1.2, 1.2]^3
  long band_points = 10000;     ///< random band points for the error against brute force
  bool dense_baseline = true;   ///< compute the dense baseline
  double band = 0.0;            ///< grid band half-width as in `sdfkit prep --band` (0 = 3 voxels)
  SignMethod sign = SignMethod::kAuto;  ///< kAuto or kWindingNumber, as `sdfkit prep --sign`
  bool seal = false;                    ///< sealed cavities inside (`sdfkit prep --sign flood`)
  std::string only;             ///< time only the shapes whose name contains this text (empty = all)
  /// Also measure the memory of the same active voxels in non-standard OpenVDB trees with 4^3 leaves.
  bool tree_memory = false;
};

/// One shape. Times in seconds; memory in bytes or MB as named.
struct PrepBenchRow {
  std::string shape;
  long triangles = 0;
  std::vector<double> seconds_1_thread, seconds_2_threads;          ///< wall, one per repeat
  std::vector<double> cpu_seconds_1_thread, cpu_seconds_2_threads;  ///< process CPU, one per repeat
  PrepareStatus status;        ///< of the last 1-thread run (its stage times are the ones reported)
  long lattice_voxels = 0;     ///< the dense lattice at the grid's own voxel size (257^3 by default)
  long dense_voxels = 0;       ///< dense_res^3
  double dense_seconds = 0, dense_cpu_seconds = 0;  ///< the dense baseline (2 threads); 0 when not computed
  bool tree_memory = false;    ///< whether the two tree sizes below were measured
  double tree_542_mb = 0, tree_432_mb = 0;
  long band_points = 0;
  double band_points_max_abs_sdf = 0;  ///< the band points lie within this distance of the surface
  double mean_abs_error = 0, max_abs_error = 0;  ///< grid against brute force at the band points
  long sign_ok = 0;            ///< band points whose grid sign agrees (or |exact| < a voxel)
  double peak_rss_mb_after_sparse = 0, peak_rss_mb_after_dense = 0;
  double band = 0;             ///< the band half-width used
};

struct PrepBenchResult {
  std::vector<PrepBenchRow> rows;
  double band = 0;       ///< the setting (0 = 3 voxels)
  int dense_res = 0;
  double peak_rss_mb = 0;  ///< of the process at the end
};

/// Runs the benchmark; `on_row` (may be empty) sees each shape's row as soon as it is measured. Throws when a
/// mesh cannot be read, before any shape is timed.
PrepBenchResult run_prep_bench(const PrepBenchSettings& settings,
                               const std::function<void(const PrepBenchRow&)>& on_row = {});

/// The text table: header line, a row's lines (with its stage times), the closing line, and all together.
std::string prep_bench_header();
std::string prep_bench_row_text(const PrepBenchRow& row);
std::string prep_bench_footer(const PrepBenchResult& result);
std::string prep_bench_text(const PrepBenchResult& result);
/// The JSON array `sdfkit bench prep --json` prints: one object per shape.
Json prep_bench_row_json(const PrepBenchRow& row);
Json prep_bench_json(const PrepBenchResult& result);

}  // namespace sdfkit
