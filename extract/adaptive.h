// Surface extraction from any scalar field given as a batch functor (an analytic SDF, a sparse grid, the SDF
// network): adaptive refinement by the distance bound, and the dense baseline.
//
// Adaptive: the box is cut into coarse cells; a cell is kept (split into 8, down to the final resolution) unless
// |f(centre) - iso| > safety * half-diagonal, in which case no point of the cell can be on the surface when f is
// `safety`-Lipschitz (safety = 1 for a true SDF; > 1 for an approximate SDF such as a network). Unlike a sign-change
// test (Occupancy Networks' MISE) this cannot lose parts thinner than a coarse cell. Marching cubes then runs on the
// final cells kept, with each fine grid point evaluated at most once (block-sparse storage, never a dense array of
// the fine grid). For a field that satisfies the bound, the mesh is identical (same vertices, same faces, same
// order) to dense_extract's at the same resolution. docs/extract.md has the details and measurements.
#pragma once

#include "core/types.h"
#include "extract/marching_cubes.h"

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace sdfkit {

/// Evaluates the field at `points` (#P by 3): `values` must be resized to #P and filled. Called with batches of
/// at most max_batch points, from one thread at a time (the functor may parallelise inside).
using BatchField = std::function<void(const Points& points, Eigen::VectorXd& values)>;

/// How adaptive_extract decides that a cell may hold the surface.
enum class RefineRule {
  kDistanceBound,  ///< |f(centre) - iso| <= safety * half-diagonal (default; keeps thin parts)
  kSignChange,     ///< the cell's 8 corner values straddle iso (Occupancy Networks' MISE rule; for comparison:
                   ///< parts thinner than a coarse cell that miss every coarse grid point are lost)
};

struct ExtractSettings {
  /// Final grid points per axis (cells = resolution - 1), e.g. 65, 129, 257.
  int resolution = 129;
  /// Grid points per axis of the first (coarse) level; (resolution - 1) / (coarse_resolution - 1) must be a power
  /// of two. Ignored by dense_extract.
  int coarse_resolution = 17;
  /// The sampled cube: [box_min, box_min + box_size]^3. Default: the object-frame unit sphere's box padded by
  /// 5%, [-1.05, 1.05]^3.
  Vec3 box_min = Vec3::Constant(-1.05);
  double box_size = 2.1;
  double iso = 0.0;
  /// Lipschitz bound of the field: 1 for a true SDF, > 1 for an approximate one (larger = safer, more work).
  double safety = 1.0;
  /// Largest number of points per functor call.
  int max_batch = 65536;
  /// Points beyond the box count as outside, so surfaces that leave the box are capped and stay closed.
  bool close_boundary = true;
  /// Refinement test of adaptive_extract.
  RefineRule refine = RefineRule::kDistanceBound;
  /// adaptive_extract only: after the refinement, follow the surface from the final cells kept. A final cell whose
  /// face has corners on both sides of iso shares the surface with its neighbour across that face, which is added
  /// (its corners evaluated) until no crossing face leads out of the set. Every surface component that touches a
  /// kept cell is then extracted whole, exactly as dense_extract extracts it, even for a field the refinement test
  /// misjudges (a pruned cell can no longer leave a hole); components no kept cell touches are still missed.
  bool follow_surface = false;
};

struct ExtractResult {
  Mesh mesh;
  long evaluations = 0;                 ///< field evaluations (distinct points)
  std::vector<long> level_cells;        ///< cells examined per level (level 0 = coarse; last = final cells)
  std::vector<long> level_evaluations;  ///< evaluations made per level (the last: final cells' corners, then
                                        ///< the cells surface following added)
  long followed_cells = 0;              ///< final cells added by surface following (ExtractSettings::follow_surface)
  double seconds = 0;                   ///< wall time including field evaluation
  MarchingCubesStats mc;
};

/// Adaptive extraction (see above). Throws InvalidInput on bad settings, or if the functor returns the wrong
/// number of values or a non-finite value (naming the point).
ExtractResult adaptive_extract(const BatchField& field, const ExtractSettings& settings = {});

/// Baseline: evaluate every grid point, then marching cubes. Same output conventions as adaptive_extract.
ExtractResult dense_extract(const BatchField& field, const ExtractSettings& settings = {});

/// The dense grid dense_extract samples (values are field - iso, as float), for callers that want the grid.
DenseGrid sample_dense(const BatchField& field, const ExtractSettings& settings, long* evaluations = nullptr);

}  // namespace sdfkit
