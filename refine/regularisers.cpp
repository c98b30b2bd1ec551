#include "refine/regularisers.h"

#include "core/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

namespace sdfkit {

MeshTopology mesh_topology(const Faces& F, Eigen::Index nv) {
  MeshTopology t;
  require(F.rows() == 0 || (F.minCoeff() >= 0 && F.maxCoeff() < nv),
          "mesh topology: a face uses a vertex outside the " + std::to_string(nv) + " vertices");
  // Directed edge occurrences per undirected edge: (face, direction a -> b with a < b).
  std::map<std::array<int32_t, 2>, std::vector<std::pair<int32_t, bool>>> uses;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = F(f, k), b = F(f, (k + 1) % 3);
      if (a == b) continue;
      uses[{std::min(a, b), std::max(a, b)}].emplace_back(static_cast<int32_t>(f), a < b);
    }
  std::vector<std::vector<int32_t>> nb(static_cast<size_t>(nv));
  for (const auto& [e, list] : uses) {
    t.edges.push_back(e);
    nb[static_cast<size_t>(e[0])].push_back(e[1]);
    nb[static_cast<size_t>(e[1])].push_back(e[0]);
    if (list.size() == 2) t.face_pairs.push_back({list[0].first, list[1].first, list[0].second == list[1].second});
  }
  t.offsets.assign(static_cast<size_t>(nv) + 1, 0);
  for (Eigen::Index v = 0; v < nv; ++v) {
    std::sort(nb[static_cast<size_t>(v)].begin(), nb[static_cast<size_t>(v)].end());
    t.offsets[static_cast<size_t>(v) + 1] = t.offsets[static_cast<size_t>(v)] + static_cast<int64_t>(nb[static_cast<size_t>(v)].size());
    t.neighbours.insert(t.neighbours.end(), nb[static_cast<size_t>(v)].begin(), nb[static_cast<size_t>(v)].end());
  }
  return t;
}

double edge_length_loss(const Points& V, const MeshTopology& topo, double weight, Points& grad) {
  if (topo.edges.empty()) return 0;
  const double inv = 1.0 / static_cast<double>(topo.edges.size());
  double loss = 0;
  for (const auto& e : topo.edges) {
    const Vec3 d = V.row(e[0]) - V.row(e[1]);
    loss += d.squaredNorm();
    grad.row(e[0]) += (weight * 2 * inv) * d.transpose();
    grad.row(e[1]) -= (weight * 2 * inv) * d.transpose();
  }
  return loss * inv;
}

namespace {

/// Unit normal n = c / |c| of face f, c = (v1 - v0) x (v2 - v0); false for a degenerate face.
bool unit_normal(const Points& V, const Faces& F, int32_t f, Vec3& n, double& len) {
  const Vec3 v0 = V.row(F(f, 0)), v1 = V.row(F(f, 1)), v2 = V.row(F(f, 2));
  const Vec3 c = (v1 - v0).cross(v2 - v0);
  len = c.norm();
  if (!(len > 1e-300)) return false;
  n = c / len;
  return true;
}

/// Adds to grad the gradient of g . n(face f) for the face's unit normal n.
void add_normal_gradient(const Points& V, const Faces& F, int32_t f, const Vec3& n, double len, const Vec3& g,
                         Points& grad) {
  // dn = (I - n n^T) dc / |c|; g . dn = gc . dc with gc = (I - n n^T) g / |c|.
  const Vec3 gc = (g - n * n.dot(g)) / len;
  const Vec3 v0 = V.row(F(f, 0)), v1 = V.row(F(f, 1)), v2 = V.row(F(f, 2));
  const Vec3 e1 = v1 - v0, e2 = v2 - v0;
  // c = e1 x e2: gc . (de1 x e2) = de1 . (e2 x gc); gc . (e1 x de2) = de2 . (gc x e1).
  const Vec3 g1 = e2.cross(gc), g2 = gc.cross(e1);
  grad.row(F(f, 1)) += g1.transpose();
  grad.row(F(f, 2)) += g2.transpose();
  grad.row(F(f, 0)) -= (g1 + g2).transpose();
}

}  // namespace

double normal_consistency_loss(const Points& V, const Faces& F, const MeshTopology& topo, double weight,
                               Points& grad) {
  if (topo.face_pairs.empty()) return 0;
  const double inv = 1.0 / static_cast<double>(topo.face_pairs.size());
  double loss = 0;
  for (const auto& p : topo.face_pairs) {
    Vec3 n0, n1;
    double l0 = 0, l1 = 0;
    const bool ok0 = unit_normal(V, F, p.f0, n0, l0), ok1 = unit_normal(V, F, p.f1, n1, l1);
    if (!ok0 || !ok1) {
      loss += 1;  // no normal to compare: the loss of perpendicular faces, without gradient
      continue;
    }
    const double s = p.flip ? -1.0 : 1.0;
    loss += 1 - s * n0.dot(n1);
    add_normal_gradient(V, F, p.f0, n0, l0, (-weight * inv * s) * n1, grad);
    add_normal_gradient(V, F, p.f1, n1, l1, (-weight * inv * s) * n0, grad);
  }
  return loss * inv;
}

double laplacian_loss(const Points& V, const MeshTopology& topo, double weight, Points& grad) {
  const Eigen::Index nv = V.rows();
  if (nv == 0) return 0;
  const double inv = 1.0 / static_cast<double>(nv);
  double loss = 0;
  for (Eigen::Index v = 0; v < nv; ++v) {
    const int64_t a = topo.offsets[static_cast<size_t>(v)], b = topo.offsets[static_cast<size_t>(v) + 1];
    if (a == b) continue;
    Vec3 mean = Vec3::Zero();
    for (int64_t k = a; k < b; ++k) mean += V.row(topo.neighbours[static_cast<size_t>(k)]).transpose();
    const double deg = static_cast<double>(b - a);
    const Vec3 l = mean / deg - V.row(v).transpose();
    const double len = l.norm();
    loss += len;
    if (!(len > 1e-12)) continue;  // |l| is not differentiable at 0: its subgradient 0
    const Vec3 g = (weight * inv / len) * l;
    grad.row(v) -= g.transpose();
    for (int64_t k = a; k < b; ++k) grad.row(topo.neighbours[static_cast<size_t>(k)]) += (g / deg).transpose();
  }
  return loss * inv;
}

}  // namespace sdfkit
