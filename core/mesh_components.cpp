#include "core/mesh_components.h"

#include "core/mesh_io.h"

#include <algorithm>
#include <numeric>
#include <string>

namespace sdfkit {

std::vector<int> face_components(const Mesh& mesh, int* count) {
  check_face_indices(mesh, "face_components");
  // Union-find over the vertices with path halving; the smaller index becomes the root.
  std::vector<int32_t> parent(static_cast<size_t>(mesh.V.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  const auto up = [&](int32_t v) -> int32_t& { return parent[static_cast<size_t>(v)]; };
  auto find = [&](int32_t v) {
    while (up(v) != v) v = up(v) = up(up(v));
    return v;
  };
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 1; k < 3; ++k) {
      const int32_t a = find(mesh.F(f, 0)), b = find(mesh.F(f, k));
      if (a != b) up(std::max(a, b)) = std::min(a, b);
    }
  std::vector<int> label(static_cast<size_t>(mesh.V.rows()), -1), component(static_cast<size_t>(mesh.F.rows()));
  int n = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int32_t root = find(mesh.F(f, 0));
    if (label[static_cast<size_t>(root)] < 0) label[static_cast<size_t>(root)] = n++;
    component[static_cast<size_t>(f)] = label[static_cast<size_t>(root)];
  }
  if (count) *count = n;
  return component;
}

}  // namespace sdfkit
