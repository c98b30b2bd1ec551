// DISN training samples: continuous points stratified on d = sdf - offset over four bins in [-0.1, 0.1],
// each stored with its exact signed distance (exact closest-triangle distance, winding-number sign).
#pragma once

#include "core/files.h"
#include "core/types.h"
#include "sdf/sparse_sdf.h"

#include <array>
#include <cstdint>

namespace sdfkit {

struct SampleSettings {
  long count = 32768;              ///< total samples per shape (DISN: 32768)
  double offset = 0.003;           ///< stratify on d = sdf - offset (DISN's iso level); 0 = on sdf itself
  /// Bin edges on d: [e0,e1) [e1,e2) [e2,e3) [e3,e4] (DISN's bins).
  std::array<double, 5> edges{-0.1, -0.03, 0.0, 0.03, 0.1};
  double uniform_share = 0.0;      ///< fraction drawn uniformly in the box [-box, box]^3 (far field), not binned
  double box = 1.2;                ///< half-size of the uniform box (DISN's 1.2 x the unit sphere's box)
  uint64_t seed = 0;
  double winding_beta = 2.0;
  /// How the sign of a sample is decided (Auto: pseudo-normals for closed one-part meshes, else winding numbers;
  /// see resolve_sign_method in sdf/sparse_sdf.h).
  SignMethod sign = SignMethod::kAuto;
  long max_candidates_per_bin = 0;  ///< give up on a bin after this many tries (0 = 64 x its quota)
};

struct SampleReport {
  std::array<long, 4> bin_counts{};   ///< samples stored per bin
  std::array<long, 4> bin_quota{};    ///< what was asked per bin
  long uniform_count = 0;
  long candidates = 0;                ///< exact distance evaluations spent
  /// Bins that the shape cannot fill (e.g. no inside deeper than 0.03 for a thin plate): their shortfall
  /// is redistributed to the other bins, nearest bin first, and reported here.
  long redistributed = 0;
  SignMethod sign = SignMethod::kNone;  ///< the sign method used (Auto resolved)
};

/// N x 4 float32 rows (x, y, z, sdf) in the frame of `mesh` (the object frame in a prepared dataset): bins
/// first (bin 0..3, in generation order), then the uniform share. Candidates come from cells that can hold
/// each bin (exact distances at cell centres, the grid's band values near the surface), so the grid's band may
/// be narrower than the bins. `sdf` is the grid built from the same mesh: with winding-number signs it gives
/// the sign of a point whose nearest voxel has no surface in between (the point is farther than 0.9 voxel
/// from the surface, or no triangle touches the segment between them); other points take the sign of their
/// own winding number. Candidates whose grid bounds miss the wanted bin are dropped before the exact query
/// (SampleReport::candidates counts exact queries). With pseudo-normals (closed
/// meshes) every sample takes the sign of its closest feature. `mesh` should be oriented consistently
/// (sdf/orientation.h) as it was for the grid. The stored sdf is the exact distance of the float32-rounded
/// point. Deterministic for a seed whatever the thread count. Throws InvalidInput for bad settings.
MatrixXfR disn_samples(const Mesh& mesh, const SparseSdf& sdf, const SampleSettings& settings,
                       SampleReport* report = nullptr);
/// Same, with the mesh's query structures already built (sdf/mesh_queries.h, shared with the grid): the sign
/// method is the one `queries` resolved (None: winding numbers), settings.sign is not used.
MatrixXfR disn_samples(const MeshQueries& queries, const SparseSdf& sdf, const SampleSettings& settings,
                       SampleReport* report = nullptr);

}  // namespace sdfkit
