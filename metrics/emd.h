// Earth mover's distance between two equal-size point sets: the minimum over one-to-one matchings of the summed
// Euclidean distances of matched points.
//
// exact (default): a minimum-cost perfect matching, optimal to within a certified bound.
//  1. Candidate graph: each point's k nearest neighbours in the other set (both directions; between distinct
//     locations, with the copies of repeated points spread over each other) plus the pairs of equal rank along a
//     Morton curve through both sets (a permutation: the graph always holds a perfect matching, with edges that
//     cross between regions of unequal mass).
//  2. Coarse prices: Bertsekas' auction with epsilon scaling on the graph down to eps = 1e-4 x diagonal, one
//     dense check at that eps adds the pairs the graph missed, and the auction settles them.
//  3. Exact successive shortest augmenting paths (Dijkstra on reduced costs, as in Jonker-Volgenant) on the
//     graph, started from the auction's prices, and the CERTIFICATE on the full dense problem: with the final
//     prices p, u_i = min over all j of (c_ij + p_j) and v_j = -p_j are feasible duals, so no matching costs less
//     than sum(u) + sum(v), and
//       gap_bound = sum_i [c_i,m(i) + p_m(i) - min_j (c_ij + p_j)]  >=  total - optimum.
//     Rows where a pair outside the graph undercuts the matched one by more than tolerance x diagonal / n get
//     those pairs and are re-augmented, until no row has one. So gap_bound <= tolerance x (diagonal of the
//     two sets' bounding box), and in practice it is at the level of double rounding (1e-14 on totals ~100).
//     The n^2 check runs vectorised in float with a rigorous error margin; pairs within the margin are
//     re-evaluated in double, so the bound is that of double arithmetic.
// approx: the approximate matcher of Fan et al. (PointSetGeneration's "approxmatch", used by DISN): 11 rounds of
// soft assignment at decreasing sharpness, exp(-4^k d^2) for k = 8..-1 and finally uniform weights, each round
// spending the mass both sides still have left. Its result is a fractional transport plan whose cost (sum of
// w_ij d_ij) is an estimate of the EMD, typically somewhat above it; it is what DISN's numbers are computed with.
#pragma once

#include "core/types.h"

#include <string>
#include <vector>

namespace sdfkit {

enum class EmdMethod { kExact, kApprox };
/// "exact" / "approx" <-> EmdMethod; InvalidInput on anything else.
EmdMethod parse_emd_method(const std::string& name);
std::string to_string(EmdMethod m);

struct EmdSettings {
  EmdMethod method = EmdMethod::kExact;
  int candidates = 24;        ///< exact: nearest neighbours per point and direction in the first candidate graph
  double tolerance = 1e-9;   ///< exact: bound on total - optimum, relative to the bounding-box diagonal
};

struct EmdResult {
  double total = 0;            ///< sum of matched distances (approx: sum of w_ij d_ij)
  long n = 0;                  ///< points per set
  [[nodiscard]] double mean() const { return n > 0 ? total / static_cast<double>(n) : 0.0; }
  std::vector<int> match;      ///< exact: match[i] = index in b of a's point i; empty for approx
  double gap_bound = 0;        ///< exact: certified bound on total - optimum
  long edges = 0;              ///< exact: candidate edges in the final graph
  int rounds = 0;              ///< exact: certificate rounds (1 = the first candidate graph was enough)
  long bids = 0;               ///< exact: auction bids (coarse prices)
  long path_scans = 0;         ///< exact: columns settled by the shortest-path searches
  EmdMethod method = EmdMethod::kExact;
};

/// EMD of a and b. Throws InvalidInput (naming both sizes) if the sets differ in size — resample first, e.g.
/// with sample_with_replacement (metrics/sampling.h) — or if either is empty or non-finite.
EmdResult emd(const Points& a, const Points& b, const EmdSettings& settings = {});
EmdResult emd_exact(const Points& a, const Points& b, const EmdSettings& settings = {});
EmdResult emd_approx(const Points& a, const Points& b);
/// The dense O(n^3) Hungarian method on the full distance matrix (reference and benchmark baseline).
EmdResult emd_hungarian(const Points& a, const Points& b);

}  // namespace sdfkit
