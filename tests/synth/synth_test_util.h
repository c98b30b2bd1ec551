// Shared checks for the synth tests: closed and consistently oriented parts, part widths.
#pragma once

#include "core/primitives.h"
#include "core/types.h"

#include <map>
#include <utility>

namespace sdfkit::test {

/// True when every directed edge occurs exactly once and its reverse exactly once: the part is closed
/// (every edge shared by two faces) and consistently oriented.
inline bool closed_and_oriented(const Mesh& m) {
  std::map<std::pair<int, int>, int> count;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++count[{m.F(f, k), m.F(f, (k + 1) % 3)}];
  for (const auto& [e, n] : count) {
    if (n != 1) return false;
    const auto it = count.find({e.second, e.first});
    if (it == count.end() || it->second != 1) return false;
  }
  return true;
}

/// Smallest extent of the vertices along any face normal: the exact thickness of a box, about the
/// diameter of a cylinder.
inline double min_width(const Mesh& m) {
  double best = 1e300;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-15) continue;
    const Eigen::VectorXd d = m.V * n.normalized();
    best = std::min(best, d.maxCoeff() - d.minCoeff());
  }
  return best;
}

}  // namespace sdfkit::test
