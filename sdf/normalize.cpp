#include "sdf/normalize.h"

#include "core/error.h"
#include "core/json.h"

#include <cmath>
#include <vector>

namespace sdfkit {

Normalization unit_sphere_normalization(const Mesh& mesh) {
  require(!mesh.empty(), "normalisation: empty mesh");
  double area = 0;
  Vec3 weighted = Vec3::Zero();
  std::vector<char> used(static_cast<size_t>(mesh.V.rows()), 0);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)).transpose();
    const Vec3 b = mesh.V.row(mesh.F(f, 1)).transpose();
    const Vec3 c = mesh.V.row(mesh.F(f, 2)).transpose();
    const double t = 0.5 * (b - a).cross(c - a).norm();
    area += t;
    weighted += t * (a + b + c) / 3.0;
    for (int k = 0; k < 3; ++k) used[static_cast<size_t>(mesh.F(f, k))] = 1;
  }
  require(area > 0 && std::isfinite(area), "normalisation: the mesh has zero surface area");
  Normalization n;
  n.center = weighted / area;
  double r2 = 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (used[static_cast<size_t>(i)]) r2 = std::max(r2, (mesh.V.row(i).transpose() - n.center).squaredNorm());
  n.radius = std::sqrt(r2);
  require(n.radius > 0 && std::isfinite(n.radius), "normalisation: the mesh has zero extent");
  return n;
}

Mesh apply_normalization(const Mesh& mesh, const Normalization& norm) {
  Mesh out = mesh;
  out.V = (mesh.V.rowwise() - norm.center.transpose()) / norm.radius;
  return out;
}

Mesh undo_normalization(const Mesh& mesh, const Normalization& norm) {
  Mesh out = mesh;
  out.V = (mesh.V * norm.radius).rowwise() + norm.center.transpose();
  return out;
}

Json normalization_to_json(const Normalization& norm) {
  return Json{{"norm", {norm.center.x(), norm.center.y(), norm.center.z(), norm.radius}}};
}

Normalization normalization_from_json(const Json& j) {
  if (!j.is_object() || !j.contains("norm") || !j["norm"].is_array() || j["norm"].size() != 4)
    throw InvalidInput("norm.json: expected \"norm\": [cx, cy, cz, r]");
  for (const auto& v : j["norm"])
    if (!v.is_number()) throw InvalidInput("norm.json: \"norm\" must hold 4 numbers");
  Normalization n;
  n.center = Vec3(j["norm"][0].get<double>(), j["norm"][1].get<double>(), j["norm"][2].get<double>());
  n.radius = j["norm"][3].get<double>();
  if (!(n.radius > 0) || !n.center.allFinite()) throw InvalidInput("norm.json: radius must be positive and finite");
  return n;
}

}  // namespace sdfkit
