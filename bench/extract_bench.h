// `sdfkit bench extract`: dense vs sparse (OpenVDB band) vs adaptive marching cubes (distance bound, and the
// sign-change rule of Occupancy Networks' MISE for comparison), on an analytic sphere and an analytic chair (union
// of box SDFs: seat, four thin legs, a back of two posts, a top rail and slats), at several resolutions. Reports
// evaluations, median wall times, whether the meshes are identical, the Chamfer distance between them and their
// distance to the analytic surface. Results: docs/benchmarks/extract.md.
#pragma once

#include "core/json_fwd.h"

#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

struct ExtractBenchSettings {
  std::vector<int> resolutions = {129, 257};              ///< final grid points per axis (2^k + 1)
  std::vector<std::string> shapes = {"sphere", "chair"};  ///< analytic shapes: "sphere", "chair"
  int coarse = 17;          ///< coarse grid points per axis of the adaptive method (capped at the resolution)
  int runs = 3;             ///< timed runs per method (the median is reported)
  double band = 3.0;        ///< half width (voxels) of the sparse band grid
  long samples = 100000;    ///< surface samples per mesh for the distance to the analytic surface
  std::string out;          ///< when set, the folder the meshes are written to (<shape>_<res>_<method>.ply)
};

/// One method at one (shape, resolution). Times are medians in seconds; NaN where the method has no such stage.
struct ExtractBenchRow {
  std::string shape;
  int resolution = 0;
  std::string method;             ///< "dense", "sparse", "adaptive" or "signchange"
  double evaluations = 0;         ///< field evaluations (sparse: active band voxels)
  double dense_evaluations = 0;   ///< resolution^3
  double eval_seconds = 0, mc_seconds = 0, total_seconds = 0;
  bool identical = false;         ///< the same mesh as dense (vertices within 1e-9 voxel for sparse; exact else)
  double cd_to_dense_x1000 = 0;   ///< NaN when either mesh is empty
  double mean_abs_sdf = 0;        ///< mean |analytic SDF| at area samples of the mesh; NaN without faces
  long faces = 0, vertices = 0;
  int runs = 0;
  double band_build_seconds = 0;  ///< sparse only
  std::vector<long> level_cells, level_evaluations;  ///< adaptive and signchange only
  int coarse_resolution = 0;      ///< adaptive only
  double speedup_vs_dense = 0;    ///< adaptive only
  double area_ratio_to_dense = 0; ///< signchange only
};

struct ExtractBenchResult {
  std::vector<ExtractBenchRow> rows;  ///< per shape, per resolution: dense, sparse, adaptive, signchange
};

/// Runs the benchmark; `on_row` (may be empty) sees each row as soon as it is measured.
ExtractBenchResult run_extract_bench(const ExtractBenchSettings& settings,
                                     const std::function<void(const ExtractBenchRow&)>& on_row = {});

/// The text table: its header line, one line per row, and both together.
std::string extract_bench_header();
std::string extract_bench_row_text(const ExtractBenchRow& row);
std::string extract_bench_text(const ExtractBenchResult& result);
/// The JSON array `sdfkit bench extract --json` prints: one object per row.
Json extract_bench_row_json(const ExtractBenchRow& row);
Json extract_bench_json(const ExtractBenchResult& result);

}  // namespace sdfkit
