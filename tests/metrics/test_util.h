// Shared helpers of the metrics tests: random clouds and brute-force nearest neighbours.
#pragma once

#include "core/random.h"
#include "core/types.h"

#include <limits>
#include <utility>

namespace sdfkit::testing {

inline Points random_cloud(long n, uint64_t seed, double scale = 1.0) {
  Rng rng(seed);
  Points p(n, 3);
  for (long i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) p(i, d) = rng.uniform(-scale, scale);
  return p;
}

/// Nearest row of `set` to `q` by scanning every row: (index, squared distance).
inline std::pair<int, double> brute_nearest(const Points& set, const Eigen::RowVector3d& q) {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (Eigen::Index j = 0; j < set.rows(); ++j) {
    const double d2 = (set.row(j) - q).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = static_cast<int>(j);
    }
  }
  return {best, best_d2};
}

}  // namespace sdfkit::testing
