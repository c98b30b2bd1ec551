#include "sdf/sheets.h"

#include "core/error.h"
#include "core/union_find.h"
#include "sdf/winding.h"

#include <tbb/parallel_for.h>

#include <algorithm>
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

  const Eigen::Index kept = mesh.F.rows();
  Mesh out;
  out.V.resize(mesh.V.rows() + 6 * rep.sheet_faces, 3);
  out.V.topRows(mesh.V.rows()) = mesh.V;
  out.F.resize(kept + 16 * rep.sheet_faces, 3);
  const bool colored = mesh.has_colors();
  if (colored) {
    out.colors.resize(out.V.rows(), 3);
    out.colors.topRows(mesh.V.rows()) = mesh.colors;
  }
  Eigen::Index nf = 0, nv = mesh.V.rows();
  out.F.topRows(kept) = mesh.F;
  nf = kept;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    if (!sheet[static_cast<size_t>(f)]) continue;
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Vec3 offset = half_thickness * (b - a).cross(c - a).normalized();
    // Vertices: top a+ b+ c+ (nv .. nv+2), bottom a- b- c- (nv+3 .. nv+5).
    const Vec3 corners[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      out.V.row(nv + k) = corners[k] + offset;
      out.V.row(nv + 3 + k) = corners[k] - offset;
      if (colored) {
        out.colors.row(nv + k) = mesh.colors.row(mesh.F(f, 0));
        out.colors.row(nv + 3 + k) = mesh.colors.row(mesh.F(f, 0));
      }
    }
    const auto top = [&](int k) { return static_cast<int>(nv + k); };
    const auto bot = [&](int k) { return static_cast<int>(nv + 3 + k); };
    for (int twice = 0; twice < 2; ++twice) {
      out.F.row(nf++) << top(0), top(1), top(2);  // normal +n
      out.F.row(nf++) << bot(0), bot(2), bot(1);  // normal -n
      for (int k = 0; k < 3; ++k) {
        // Side wall of the directed edge k -> k+1: (a-, b-, b+), (a-, b+, a+) faces away from the face's interior.
        const int j = (k + 1) % 3;
        out.F.row(nf++) << bot(k), bot(j), top(j);
        out.F.row(nf++) << bot(k), top(j), top(k);
      }
    }
    nv += 6;
  }
  return out;
}

}  // namespace sdfkit
