#include "extract/cleanup.h"

#include "core/error.h"
#include "core/mesh_io.h"

#include <algorithm>
#include <string>

namespace sdfkit {

std::vector<double> component_sizes(const Mesh& mesh, const std::vector<int>& component, int count,
                                    ComponentMeasure measure) {
  require(component.size() == size_t(mesh.F.rows()), "component_sizes: one component id per face expected");
  std::vector<double> size(count, 0.0);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    double s = 1.0;
    if (measure == ComponentMeasure::kArea) {
      const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
      s = 0.5 * (b - a).cross(c - a).norm();
    }
    size[component[f]] += s;
  }
  return size;
}

Mesh remove_unreferenced_vertices(const Mesh& mesh, std::vector<int32_t>* old_to_new) {
  check_face_indices(mesh, "remove_unreferenced_vertices");
  std::vector<int32_t> map(mesh.V.rows(), -1);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) map[mesh.F(f, k)] = 0;
  int32_t n = 0;
  for (auto& m : map)
    if (m == 0) m = n++;
  Mesh out;
  out.V.resize(n, 3);
  if (mesh.has_colors()) out.colors.resize(n, 3);
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    if (map[v] < 0) continue;
    out.V.row(map[v]) = mesh.V.row(v);
    if (mesh.has_colors()) out.colors.row(map[v]) = mesh.colors.row(v);
  }
  out.F.resize(mesh.F.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) out.F(f, k) = map[mesh.F(f, k)];
  if (old_to_new) *old_to_new = std::move(map);
  return out;
}

Mesh cleanup(const Mesh& mesh, const CleanupSettings& settings, CleanupReport* report) {
  require(settings.min_component_fraction >= 0 && settings.min_component_fraction <= 1,
          "cleanup: min_component_fraction must be in [0, 1]");
  int count = 0;
  const std::vector<int> component = face_components(mesh, &count);
  const std::vector<double> size = component_sizes(mesh, component, count, settings.measure);
  const double largest = size.empty() ? 0.0 : *std::max_element(size.begin(), size.end());
  std::vector<char> keep(count, 0);
  int kept = 0;
  for (int c = 0; c < count; ++c)
    if (size[c] >= settings.min_component_fraction * largest) {
      keep[c] = 1;
      ++kept;
    }
  Mesh filtered;
  filtered.V = mesh.V;
  filtered.colors = mesh.colors;
  Eigen::Index nf = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) nf += keep[component[f]];
  filtered.F.resize(nf, 3);
  Eigen::Index row = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    if (keep[component[f]]) filtered.F.row(row++) = mesh.F.row(f);
  Mesh out = remove_unreferenced_vertices(filtered);
  if (report) {
    report->components = count;
    report->kept_components = kept;
    report->removed_faces = static_cast<long>(mesh.F.rows() - out.F.rows());
    report->removed_vertices = static_cast<long>(mesh.V.rows() - out.V.rows());
  }
  return out;
}

}  // namespace sdfkit
