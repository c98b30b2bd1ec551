// Vertex clustering (report/decimate.h).
#include "report/decimate.h"

#include "core/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <unordered_map>
#include <vector>

namespace sdfkit {

Mesh cluster_vertices(const Mesh& mesh, int cells) {
  if (cells < 1) throw InvalidInput("cluster_vertices: cells must be at least 1");
  Box3 box;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) box.extend(mesh.V.row(i).transpose());
  if (!box.valid()) return mesh;
  const double side = std::max(box.extent().maxCoeff(), 1e-12);
  const double h = side / cells;
  const bool colored = mesh.has_colors();
  // Cell key -> cluster index, in the order clusters are first met (vertex order): deterministic numbering.
  std::unordered_map<uint64_t, int32_t> cluster_of_cell;
  std::vector<int32_t> cluster(static_cast<size_t>(mesh.V.rows()));
  std::vector<Vec3> sum;
  std::vector<Eigen::Vector3d> color_sum;
  std::vector<int> count;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      const auto c = static_cast<uint64_t>(std::clamp(std::floor((mesh.V(i, k) - box.lo[k]) / h), 0.0, 2097151.0));
      key = (key << 21) | c;
    }
    const auto [it, inserted] = cluster_of_cell.emplace(key, static_cast<int32_t>(sum.size()));
    if (inserted) {
      sum.emplace_back(Vec3::Zero());
      color_sum.emplace_back(Eigen::Vector3d::Zero());
      count.push_back(0);
    }
    const int32_t c = it->second;
    cluster[static_cast<size_t>(i)] = c;
    sum[static_cast<size_t>(c)] += mesh.V.row(i).transpose();
    if (colored) color_sum[static_cast<size_t>(c)] += mesh.colors.row(i).transpose().cast<double>();
    ++count[static_cast<size_t>(c)];
  }
  Mesh out;
  out.V.resize(static_cast<Eigen::Index>(sum.size()), 3);
  if (colored) out.colors.resize(out.V.rows(), 3);
  for (size_t c = 0; c < sum.size(); ++c) {
    out.V.row(static_cast<Eigen::Index>(c)) = (sum[c] / count[c]).transpose();
    if (colored) out.colors.row(static_cast<Eigen::Index>(c)) = (color_sum[c] / count[c]).cast<float>().transpose();
  }
  std::vector<std::array<int32_t, 3>> faces;
  std::set<std::array<int32_t, 3>> seen;  // a face's three clusters, rotated to start at the smallest
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    std::array<int32_t, 3> t{};
    for (int k = 0; k < 3; ++k) t[static_cast<size_t>(k)] = cluster[static_cast<size_t>(mesh.F(f, k))];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    while (t[0] > t[1] || t[0] > t[2]) std::rotate(t.begin(), t.begin() + 1, t.end());
    if (!seen.insert(t).second) continue;
    faces.push_back(t);
  }
  out.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) out.F(static_cast<Eigen::Index>(f), k) = faces[f][static_cast<size_t>(k)];
  return out;
}

Mesh decimate_to(const Mesh& mesh, long max_faces) {
  if (max_faces < 1) throw InvalidInput("decimate_to: max_faces must be at least 1");
  if (mesh.F.rows() <= max_faces) return mesh;
  for (double cells = 256; cells >= 2; cells /= std::sqrt(2.0)) {
    Mesh out = cluster_vertices(mesh, static_cast<int>(std::lround(cells)));
    if (out.F.rows() <= max_faces) return out;
  }
  return cluster_vertices(mesh, 1);
}

}  // namespace sdfkit
