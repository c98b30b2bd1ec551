// Earth mover's distance between two equal-size point sets: the minimum over one-to-one matchings of the summed
// Euclidean distances of matched points.
//
// exact (default): a minimum-cost perfect matching, optimal to within a certified bound. The solver runs
// Bertsekas' auction with epsilon scaling (metrics/assignment.h) on a sparse candidate graph (each point's k
// nearest neighbours in the other set, both directions, completed so that a perfect matching exists), then
// CERTIFIES the result on the full dense problem: from the final prices p, u_i = min over all j of (c_ij + p_j)
// and v_j = -p_j are feasible duals, so no matching costs less than sum(u) + sum(v), and
//   gap_bound = sum_i [c_i,m(i) + p_m(i) - min_j (c_ij + p_j)]  >=  total - optimum.
// Rows where a pair outside the graph breaks eps-complementary slackness get those pairs and bid again, so at
// the end gap_bound <= 2 n eps_final = 2 x tolerance x (diagonal of the two sets' bounding box). With the default
// tolerance 1e-9 the total is exact to far below the float precision of the input coordinates.
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
  int candidates = 16;        ///< exact: nearest neighbours per point and direction in the first candidate graph
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
  long bids = 0;               ///< exact: auction bids
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
