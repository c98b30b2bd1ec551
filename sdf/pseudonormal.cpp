#include "sdf/pseudonormal.h"

#include "core/error.h"
#include "core/mesh_components.h"
#include "core/random.h"
#include "sdf/bvh.h"
#include "sdf/orientation.h"
#include "sdf/winding.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace sdfkit {

PseudoNormals::PseudoNormals(const Mesh& mesh) : F_(mesh.F) {
  // The face across each edge (empty unless closed and consistently oriented).
  const std::vector<std::array<int32_t, 3>> across = closed_edge_neighbours(mesh);
  require(!across.empty(), "pseudo-normals: the mesh is not closed and consistently oriented");
  const auto nf = static_cast<size_t>(mesh.F.rows());
  face_normal_.resize(nf);
  vertex_normal_.assign(static_cast<size_t>(mesh.V.rows()), Vec3::Zero());
  edge_normal_.resize(nf);
  for (size_t f = 0; f < nf; ++f) {
    const auto fi = static_cast<Eigen::Index>(f);
    const Vec3 a = mesh.V.row(mesh.F(fi, 0)), b = mesh.V.row(mesh.F(fi, 1)), c = mesh.V.row(mesh.F(fi, 2));
    const Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    face_normal_[f] = len > 0 ? Vec3(n / len) : Vec3::Zero();
    const Vec3 corner[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      const Vec3 e1 = corner[(k + 1) % 3] - corner[k], e2 = corner[(k + 2) % 3] - corner[k];
      const double l = e1.norm() * e2.norm();
      const double angle = l > 0 ? std::acos(std::clamp(e1.dot(e2) / l, -1.0, 1.0)) : 0.0;
      vertex_normal_[static_cast<size_t>(mesh.F(fi, k))] += angle * face_normal_[f];
    }
  }
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      edge_normal_[f][k] = face_normal_[f] + face_normal_[static_cast<size_t>(across[f][static_cast<size_t>(k)])];
}

Vec3 PseudoNormals::normal(int32_t face, int region) const {
  const auto f = static_cast<size_t>(face);
  switch (region) {
    case kVertexA: case kVertexB: case kVertexC:
      return vertex_normal_[static_cast<size_t>(F_(face, region))];
    case kEdgeAB: return edge_normal_[f][0];
    case kEdgeBC: return edge_normal_[f][1];
    case kEdgeCA: return edge_normal_[f][2];
    default: return face_normal_[f];
  }
}

bool pseudo_normal_sign_applies(const Mesh& mesh) {
  if (mesh.F.rows() == 0 || !is_closed_oriented(mesh)) return false;
  // One part: faces connected through shared vertices (closed + oriented makes that the same as through edges,
  // except for parts touching at a vertex, which are two parts: conservative).
  int parts = 0;
  face_components(mesh, &parts);
  if (parts != 1) return false;
  // Any vertex used by the faces sits in one fan: count, for each vertex, how many faces use it vs. how many
  // faces its fan walk visits would be the full test; closed + oriented + edge-manifold + one part is what we
  // require here (pinched vertices keep exact pseudo-normals as long as the surface does not self-intersect).
  return true;
}

bool pseudo_normal_agrees_with_winding(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                       double spacing, int count) {
  return pseudo_normal_agrees_with_winding(mesh, dist, normals, spacing, WindingNumber(mesh), count);
}

namespace {
/// The agreement guard with winding numbers from `wn(p)`; the test points do not depend on `wn`.
template <typename WindingFn>
bool agrees(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals, double spacing, int count,
            const WindingFn& wn) {
  Rng rng(0x70736e);
  std::vector<double> cdf(static_cast<size_t>(mesh.F.rows()));
  double total = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    total += (mesh.V.row(mesh.F(f, 1)) - mesh.V.row(mesh.F(f, 0))).cross(mesh.V.row(mesh.F(f, 2)) - mesh.V.row(mesh.F(f, 0))).norm();
    cdf[static_cast<size_t>(f)] = total;
  }
  for (int i = 0; i < count; ++i) {
    const auto f = static_cast<Eigen::Index>(std::min<size_t>(
        cdf.size() - 1, static_cast<size_t>(std::lower_bound(cdf.begin(), cdf.end(), rng.uniform() * total) - cdf.begin())));
    double a = rng.uniform(), b = rng.uniform();
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Vec3 x = mesh.V.row(mesh.F(f, 0)).transpose() * (1 - a - b) + mesh.V.row(mesh.F(f, 1)).transpose() * a +
                   mesh.V.row(mesh.F(f, 2)).transpose() * b;
    const Vec3 dir = Vec3(rng.normal(), rng.normal(), rng.normal()).normalized();
    const Vec3 p = x + dir * (spacing * rng.uniform(0.5, 4.0));
    const ClosestPoint cp = dist.closest(p);
    if (cp.face < 0 || cp.distance < 1e-9) continue;
    const double w = wn(p, i);
    if (std::abs(w - 0.5) < 0.25) return false;  // a closed, non-intersecting surface has w in {0, 1}
    if ((w > 0.5) != normals.inside(p, cp)) return false;
  }
  return true;
}
}  // namespace

bool pseudo_normal_agrees_with_winding(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                       double spacing, const WindingNumber& wn, int count) {
  return agrees(mesh, dist, normals, spacing, count, [&](const Vec3& p, int) { return wn(p); });
}

bool pseudo_normal_agrees_with_rays(const Mesh& mesh, const MeshDistance& dist, const PseudoNormals& normals,
                                    double spacing, const std::function<const WindingNumber&()>& fallback, int count) {
  return agrees(mesh, dist, normals, spacing, count, [&](const Vec3& p, int i) {
    // Random directions (deterministic per test point): a ray grazing an edge is rare and then retried.
    Rng rng = Rng::derived(0x72617973, static_cast<uint64_t>(i));
    for (int attempt = 0; attempt < 4; ++attempt) {
      const Vec3 dir(rng.normal(), rng.normal(), rng.normal());
      int w = 0;
      if (dist.ray_winding(p, dir, &w)) return static_cast<double>(w);
    }
    return fallback()(p);
  });
}

}  // namespace sdfkit
