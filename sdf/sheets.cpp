#include "sdf/sheets.h"

#include "core/error.h"
#include "core/union_find.h"
#include "sdf/winding.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>

namespace sdfkit {

namespace {

/// Per face: does its part (faces connected through shared edges) have a rim, an edge of exactly one face? A
/// single-sided sheet always does; a closed part, even a non-manifold soup of touching boxes, does not.
std::vector<char> faces_of_rimmed_parts(const Mesh& mesh) {
  const auto n = static_cast<size_t>(mesh.F.rows());
  std::unordered_map<uint64_t, std::pair<int32_t, int32_t>> edges;  // (min, max) -> (faces, first face)
  edges.reserve(n * 3 / 2 + 1);
  UnionFind parts(n);
  for (size_t f = 0; f < n; ++f)
    for (int k = 0; k < 3; ++k) {
      const auto i = static_cast<Eigen::Index>(f);
      const auto a = static_cast<uint64_t>(mesh.F(i, k)), b = static_cast<uint64_t>(mesh.F(i, (k + 1) % 3));
      if (a == b) continue;
      auto [it, fresh] = edges.try_emplace((std::min(a, b) << 32) | std::max(a, b), 0, static_cast<int32_t>(f));
      ++it->second.first;
      if (!fresh) parts.unite(it->second.second, static_cast<int32_t>(f));
    }
  std::vector<char> rimmed_root(n, 0);
  for (const auto& [key, e] : edges)
    if (e.first == 1) rimmed_root[static_cast<size_t>(parts.find(e.second))] = 1;
  std::vector<char> out(n, 0);
  for (size_t f = 0; f < n; ++f) out[f] = rimmed_root[static_cast<size_t>(parts.find(static_cast<int32_t>(f)))];
  return out;
}

}  // namespace

std::vector<char> open_sheet_faces(const Mesh& mesh, double probe, double winding_beta) {
  require(probe > 0 && std::isfinite(probe), "open sheets: the probe distance must be positive");
  const auto n = static_cast<size_t>(mesh.F.rows());
  std::vector<char> sheet(n, 0);
  if (mesh.empty()) return sheet;
  const std::vector<char> rimmed = faces_of_rimmed_parts(mesh);
  if (std::none_of(rimmed.begin(), rimmed.end(), [](char c) { return c != 0; })) return sheet;
  const WindingNumber wn(mesh, winding_beta);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const auto& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) {
      if (!rimmed[f]) continue;
      const auto i = static_cast<Eigen::Index>(f);
      const Vec3 a = mesh.V.row(mesh.F(i, 0)), b = mesh.V.row(mesh.F(i, 1)), c = mesh.V.row(mesh.F(i, 2));
      const Vec3 cross = (b - a).cross(c - a);
      const double len = cross.norm();
      if (!(len > 1e-14)) continue;
      const Vec3 centre = (a + b + c) / 3.0, nrm = cross / len;
      sheet[f] = std::max(wn(centre + probe * nrm), wn(centre - probe * nrm)) <= 0.5 ? 1 : 0;
    }
  });
  return sheet;
}

Mesh thicken_open_sheets(const Mesh& mesh, double half_thickness, double probe, SheetReport* report,
                         double winding_beta) {
  require(half_thickness > 0 && std::isfinite(half_thickness), "open sheets: the half-thickness must be positive");
  SheetReport rep;
  const std::vector<char> sheet = open_sheet_faces(mesh, probe, winding_beta);
  for (const char s : sheet) rep.sheet_faces += s;
  if (report) *report = rep;
  if (rep.sheet_faces == 0) return mesh;

  const Eigen::Index nv0 = mesh.V.rows(), nf0 = mesh.F.rows();
  std::vector<Vec3> unit(static_cast<size_t>(nf0), Vec3::Zero());
  // Angle-weighted normal of each vertex over its sheet faces.
  std::vector<Vec3> vnormal(static_cast<size_t>(nv0), Vec3::Zero());
  for (Eigen::Index f = 0; f < nf0; ++f) {
    if (!sheet[static_cast<size_t>(f)]) continue;
    const Vec3 p[3] = {mesh.V.row(mesh.F(f, 0)), mesh.V.row(mesh.F(f, 1)), mesh.V.row(mesh.F(f, 2))};
    unit[static_cast<size_t>(f)] = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
    for (int k = 0; k < 3; ++k) {
      const Vec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
      const double angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
      vnormal[static_cast<size_t>(mesh.F(f, k))] += angle * unit[static_cast<size_t>(f)];
    }
  }
  for (Vec3& n : vnormal)
    if (n.norm() > 0) n.normalize();
  // A face shares its corners' offset vertices with its neighbours when its normal agrees with each corner's
  // (creases up to about 60 degrees); otherwise (a fold, an inconsistently oriented neighbour) it gets offset
  // vertices of its own along its normal, a prism.
  std::vector<char> shared(static_cast<size_t>(nf0), 0);
  std::unordered_map<uint64_t, int> directed;  // directed edge (a, b) of a shared face -> count
  for (Eigen::Index f = 0; f < nf0; ++f) {
    const auto fi = static_cast<size_t>(f);
    if (!sheet[fi]) continue;
    bool ok = true;
    for (int k = 0; k < 3; ++k) ok = ok && vnormal[static_cast<size_t>(mesh.F(f, k))].dot(unit[fi]) >= 0.5;
    shared[fi] = ok;
    if (ok)
      for (int k = 0; k < 3; ++k)
        ++directed[(static_cast<uint64_t>(mesh.F(f, k)) << 32) | static_cast<uint32_t>(mesh.F(f, (k + 1) % 3))];
  }
  // Offset vertices: top (+normal) and bottom of every vertex of a shared face, in vertex order; then 6 per prism.
  std::vector<int32_t> top_of(static_cast<size_t>(nv0), -1);
  Eigen::Index nv = nv0;
  for (Eigen::Index f = 0; f < nf0; ++f)
    if (shared[static_cast<size_t>(f)])
      for (int k = 0; k < 3; ++k) top_of[static_cast<size_t>(mesh.F(f, k))] = 0;
  for (Eigen::Index v = 0; v < nv0; ++v)
    if (top_of[static_cast<size_t>(v)] == 0) top_of[static_cast<size_t>(v)] = static_cast<int32_t>(nv), nv += 2;
  // Per shared face and edge: a wall unless the edge is shared with one other such face in the opposite direction.
  std::vector<std::array<bool, 3>> wall(static_cast<size_t>(nf0), {true, true, true});
  long prisms = 0, walls = 0;
  for (Eigen::Index f = 0; f < nf0; ++f) {
    const auto fi = static_cast<size_t>(f);
    if (sheet[fi] && !shared[fi]) ++prisms;
    if (!shared[fi]) continue;
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<uint64_t>(mesh.F(f, k)), b = static_cast<uint64_t>(mesh.F(f, (k + 1) % 3));
      const auto fwd = directed.find((a << 32) | b), back = directed.find((b << 32) | a);
      wall[fi][static_cast<size_t>(k)] = !(fwd->second == 1 && back != directed.end() && back->second == 1);
      walls += wall[fi][static_cast<size_t>(k)];
    }
  }
  const Eigen::Index slab_faces = 2 * (rep.sheet_faces - prisms) + 2 * walls + 8 * prisms;

  Mesh out;
  out.V.resize(nv + 6 * prisms, 3);
  out.V.topRows(nv0) = mesh.V;
  out.F.resize(nf0 + 2 * slab_faces, 3);
  out.F.topRows(nf0) = mesh.F;
  const bool colored = mesh.has_colors();
  if (colored) {
    out.colors.resize(out.V.rows(), 3);
    out.colors.topRows(nv0) = mesh.colors;
  }
  for (Eigen::Index v = 0; v < nv0; ++v) {
    const int32_t t = top_of[static_cast<size_t>(v)];
    if (t < 0) continue;
    const Vec3 offset = half_thickness * vnormal[static_cast<size_t>(v)];
    out.V.row(t) = mesh.V.row(v) + offset.transpose();
    out.V.row(t + 1) = mesh.V.row(v) - offset.transpose();
    if (colored) out.colors.row(t) = out.colors.row(t + 1) = mesh.colors.row(v);
  }
  Eigen::Index nf = nf0;
  // Top (+n) and bottom (-n) of a face with corner offset vertices top(k)/bot(k); the side wall of its directed
  // edge k -> k+1, (a-, b-, b+), (a-, b+, a+), faces away from the face's interior.
  const auto emit = [&](const auto& top, const auto& bot, const std::array<bool, 3>& walls_of) {
    out.F.row(nf++) << top(0), top(1), top(2);
    out.F.row(nf++) << bot(0), bot(2), bot(1);
    for (int k = 0; k < 3; ++k) {
      if (!walls_of[static_cast<size_t>(k)]) continue;
      const int j = (k + 1) % 3;
      out.F.row(nf++) << bot(k), bot(j), top(j);
      out.F.row(nf++) << bot(k), top(j), top(k);
    }
  };
  for (int twice = 0; twice < 2; ++twice) {
    Eigen::Index pv = nv;
    for (Eigen::Index f = 0; f < nf0; ++f) {
      const auto fi = static_cast<size_t>(f);
      if (!sheet[fi]) continue;
      if (shared[fi]) {
        emit([&](int k) { return top_of[static_cast<size_t>(mesh.F(f, k))]; },
             [&](int k) { return top_of[static_cast<size_t>(mesh.F(f, k))] + 1; }, wall[fi]);
      } else {
        if (twice == 0) {
          const Vec3 offset = half_thickness * unit[fi];
          for (int k = 0; k < 3; ++k) {
            out.V.row(pv + k) = mesh.V.row(mesh.F(f, k)) + offset.transpose();
            out.V.row(pv + 3 + k) = mesh.V.row(mesh.F(f, k)) - offset.transpose();
            if (colored) out.colors.row(pv + k) = out.colors.row(pv + 3 + k) = mesh.colors.row(mesh.F(f, k));
          }
        }
        emit([&](int k) { return static_cast<int32_t>(pv + k); }, [&](int k) { return static_cast<int32_t>(pv + 3 + k); },
             wall[fi]);  // a prism: every edge a wall
        pv += 6;
      }
    }
  }
  return out;
}

}  // namespace sdfkit
