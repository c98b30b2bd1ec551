#include "core/mesh_components.h"

#include "core/mesh_io.h"
#include "core/union_find.h"

#include <algorithm>
#include <numeric>
#include <string>

namespace sdfkit {

std::vector<int> face_components(const Mesh& mesh, int* count) {
  check_face_indices(mesh, "face_components");
  // Union by smaller root (core/union_find.h): the labels below follow face order whatever the unions.
  UnionFind sets(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 1; k < 3; ++k) sets.unite(mesh.F(f, 0), mesh.F(f, k));
  std::vector<int> label(static_cast<size_t>(mesh.V.rows()), -1), component(static_cast<size_t>(mesh.F.rows()));
  int n = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int32_t root = sets.find(mesh.F(f, 0));
    if (label[static_cast<size_t>(root)] < 0) label[static_cast<size_t>(root)] = n++;
    component[static_cast<size_t>(f)] = label[static_cast<size_t>(root)];
  }
  if (count) *count = n;
  return component;
}

}  // namespace sdfkit
