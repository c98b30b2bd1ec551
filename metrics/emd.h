// Earth mover's distance between two equal-size point sets: the minimum over one-to-one matchings of the summed
// Euclidean distances of matched points.
//
// exact (default): a minimum-cost perfect matching. The solver works on a sparse candidate graph (each point's k
// nearest neighbours in the other set, both directions) with successive shortest augmenting paths
// (metrics/assignment.h), then CERTIFIES optimality for the full dense problem: with the solver's duals (u, v),
// every one of the n^2 pairs is checked for reduced cost c_ij - u_i - v_j >= -tol. Pairs that fail are added to
// the graph, their rows re-augmented, until none fails. Then for any matching m,
// cost(m) >= sum(u) + sum(v) - n tol, so the returned total is optimal to within `gap_bound` (reported; n tol at
// most, with tol = settings.tolerance x the diagonal of the two sets' bounding box). With the default 1e-9 the
// relative error is far below float precision of the inputs.
//
// approx: the approximate matcher of Fan et al. (PointSetGeneration's "approxmatch", used by DISN): 11 rounds of
// soft assignment at decreasing sharpness, exp(-4^k d^2) for k = 8..-1 and finally uniform weights, each round
// spending the mass both sides still have left. Its result is a fractional transport plan whose cost (sum of
// w_ij d_ij) is an estimate of the EMD, typically somewhat above it; it is what DISN's numbers are computed with.
#pragma once

#include "core/types.h"

#include <string>
#include <vector>

namespace sdfkit::metrics {

enum class EmdMethod { exact, approx };
/// "exact" / "approx" <-> EmdMethod; InvalidInput on anything else.
EmdMethod parse_emd_method(const std::string& name);
std::string to_string(EmdMethod m);

struct EmdSettings {
  EmdMethod method = EmdMethod::exact;
  int candidates = 8;        ///< exact: nearest neighbours per point and direction in the first candidate graph
  double tolerance = 1e-9;   ///< exact: certificate tolerance, relative to the bounding-box diagonal
};

struct EmdResult {
  double total = 0;            ///< sum of matched distances (approx: sum of w_ij d_ij)
  long n = 0;                  ///< points per set
  [[nodiscard]] double mean() const { return n > 0 ? total / static_cast<double>(n) : 0.0; }
  std::vector<int> match;      ///< exact: match[i] = index in b of a's point i; empty for approx
  double gap_bound = 0;        ///< exact: certified bound on total - optimum
  long edges = 0;              ///< exact: candidate edges in the final graph
  int rounds = 0;              ///< exact: certificate rounds (1 = the first candidate graph was enough)
  EmdMethod method = EmdMethod::exact;
};

/// EMD of a and b. Throws InvalidInput (naming both sizes) if the sets differ in size — resample first, e.g.
/// with sample_with_replacement (metrics/sampling.h) — or if either is empty or non-finite.
EmdResult emd(const Points& a, const Points& b, const EmdSettings& settings = {});
EmdResult emd_exact(const Points& a, const Points& b, const EmdSettings& settings = {});
EmdResult emd_approx(const Points& a, const Points& b);
/// The dense O(n^3) Hungarian method on the full distance matrix (reference and benchmark baseline).
EmdResult emd_hungarian(const Points& a, const Points& b);

}  // namespace sdfkit::metrics
