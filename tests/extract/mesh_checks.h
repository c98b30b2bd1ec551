// Mesh invariants shared by the extract tests: closed + consistently oriented, Euler characteristic,
// degenerate triangles, duplicate vertices.
#pragma once

#include "core/types.h"

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

namespace sdfkit::test {

/// Number of directed edges that break "closed and consistently oriented": each directed edge (a, b) must occur
/// exactly once and its reverse (b, a) exactly once (so every undirected edge has exactly two triangles).
inline long bad_edges(const Mesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) directed[{m.F(f, k), m.F(f, (k + 1) % 3)}]++;
  long bad = 0;
  for (const auto& [e, n] : directed) {
    const auto it = directed.find({e.second, e.first});
    if (n != 1 || it == directed.end() || it->second != 1) ++bad;
  }
  return bad;
}

inline long euler_characteristic(const Mesh& m) {
  std::set<std::pair<int, int>> edges;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = m.F(f, k), b = m.F(f, (k + 1) % 3);
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  return static_cast<long>(m.V.rows()) - static_cast<long>(edges.size()) + static_cast<long>(m.F.rows());
}

/// Triangles with a repeated index or zero area.
inline long degenerate_faces(const Mesh& m) {
  long n = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const int a = m.F(f, 0), b = m.F(f, 1), c = m.F(f, 2);
    if (a == b || b == c || a == c) {
      ++n;
      continue;
    }
    const Vec3 pa = m.V.row(a), pb = m.V.row(b), pc = m.V.row(c);
    if ((pb - pa).cross(pc - pa).norm() == 0.0) ++n;
  }
  return n;
}

/// Vertices whose position equals another vertex's exactly.
inline long duplicate_vertices(const Mesh& m) {
  std::set<std::tuple<double, double, double>> seen;
  long dup = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (!seen.insert({m.V(v, 0), m.V(v, 1), m.V(v, 2)}).second) ++dup;
  return dup;
}

/// Vertices referenced by no triangle.
inline long unreferenced_vertices(const Mesh& m) {
  std::vector<char> used(m.V.rows(), 0);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[m.F(f, k)] = 1;
  return static_cast<long>(std::count(used.begin(), used.end(), 0));
}

/// Same vertices (bitwise) and same faces in the same order.
inline bool identical(const Mesh& a, const Mesh& b) {
  return a.V.rows() == b.V.rows() && a.F.rows() == b.F.rows() && a.V == b.V && a.F == b.F;
}

}  // namespace sdfkit::test
