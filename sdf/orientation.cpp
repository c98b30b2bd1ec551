#include "sdf/orientation.h"

#include "sdf/winding.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace sdfkit {
namespace {

struct HalfEdge {
  uint64_t key;   ///< (min vertex, max vertex)
  int32_t face;
  int8_t forward;  ///< 1 when the face traverses min -> max
  int8_t corner;   ///< the face's edge: corner -> corner + 1
  bool operator<(const HalfEdge& o) const { return key < o.key || (key == o.key && face < o.face); }
};

/// Half-edges in (key, face) order. A counting sort on the smaller vertex (stable: faces stay in increasing
/// order), then an insertion sort on the larger vertex inside each vertex's short list: linear time, the same
/// order as a comparison sort on (key, face).
std::vector<HalfEdge> sorted_half_edges(const Mesh& mesh) {
  const auto nf = static_cast<size_t>(mesh.F.rows());
  const auto nv = static_cast<size_t>(mesh.V.rows());
  if (nf > 0 && (mesh.F.minCoeff() < 0 || static_cast<size_t>(mesh.F.maxCoeff()) >= nv)) {
    // Indices outside the vertex range (an unvalidated mesh): a comparison sort, which needs no range.
    std::vector<HalfEdge> h;
    h.reserve(3 * nf);
    for (size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const auto a = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), k));
        const auto b = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), (k + 1) % 3));
        h.push_back({(static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b), static_cast<int32_t>(f),
                     static_cast<int8_t>(a < b), static_cast<int8_t>(k)});
      }
    std::sort(h.begin(), h.end());
    return h;
  }
  std::vector<uint32_t> start(nv + 1, 0);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), k));
      const auto b = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), (k + 1) % 3));
      ++start[std::min(a, b) + 1];
    }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<HalfEdge> h(3 * nf);
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), k));
      const auto b = static_cast<uint32_t>(mesh.F(static_cast<Eigen::Index>(f), (k + 1) % 3));
      const uint32_t lo = std::min(a, b), hi = std::max(a, b);
      h[fill[lo]++] = {(static_cast<uint64_t>(lo) << 32) | hi, static_cast<int32_t>(f), static_cast<int8_t>(a < b),
                       static_cast<int8_t>(k)};
    }
  for (size_t v = 0; v < nv; ++v) {
    // Stable insertion sort by key: equal keys keep their (increasing) face order.
    for (uint32_t i = start[v] + 1; i < start[v + 1]; ++i) {
      const HalfEdge x = h[i];
      uint32_t j = i;
      for (; j > start[v] && h[j - 1].key > x.key; --j) h[j] = h[j - 1];
      h[j] = x;
    }
  }
  return h;
}

}  // namespace

Mesh orient_consistently(const Mesh& mesh, OrientationReport* report) {
  OrientationReport r;
  const auto nf = static_cast<int32_t>(mesh.F.rows());
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  // Adjacency through manifold edges: (neighbour face, same_direction) per face, up to 3.
  std::vector<std::array<std::pair<int32_t, bool>, 3>> adj(nf);
  std::vector<int8_t> nadj(nf, 0);
  std::vector<char> boundary(nf, 0);  // face touches a boundary or non-manifold edge
  for (size_t i = 0; i < h.size();) {
    size_t j = i;
    while (j < h.size() && h[j].key == h[i].key) ++j;
    if (j - i == 2) {
      const bool same = h[i].forward == h[i + 1].forward;
      const int32_t a = h[i].face, b = h[i + 1].face;
      if (a != b && nadj[a] < 3 && nadj[b] < 3) {
        adj[a][nadj[a]++] = {b, same};
        adj[b][nadj[b]++] = {a, same};
      }
    } else {
      for (size_t k = i; k < j; ++k) boundary[h[k].face] = 1;
    }
    i = j;
  }
  std::vector<char> flip(nf, 0);
  std::vector<int32_t> component(nf, -1);
  std::vector<int32_t> queue;
  std::vector<std::vector<int32_t>> members;
  for (int32_t seed = 0; seed < nf; ++seed) {
    if (component[seed] >= 0) continue;
    const auto c = static_cast<int32_t>(members.size());
    members.emplace_back();
    queue.assign(1, seed);
    component[seed] = c;
    for (size_t q = 0; q < queue.size(); ++q) {
      const int32_t f = queue[q];
      members[c].push_back(f);
      for (int k = 0; k < nadj[f]; ++k) {
        const auto [g, same] = adj[f][k];
        if (component[g] >= 0) continue;
        component[g] = c;
        // Two faces sharing an edge in the same direction disagree: the neighbour takes the opposite flip.
        flip[g] = static_cast<char>(same ? !flip[f] : flip[f]);
        queue.push_back(g);
      }
    }
  }
  Mesh out = mesh;
  for (int32_t f = 0; f < nf; ++f)
    if (flip[f]) std::swap(out.F(f, 1), out.F(f, 2));
  r.components = static_cast<long>(members.size());

  // Signed volume per part (about the part's vertex mean, which makes it independent of placement for
  // closed parts and a sensible orientation vote for open ones).
  std::vector<double> volume(members.size(), 0.0);
  std::vector<char> closed(members.size(), 1);
  for (size_t c = 0; c < members.size(); ++c) {
    Vec3 o = Vec3::Zero();
    for (int32_t f : members[c])
      for (int k = 0; k < 3; ++k) o += out.V.row(out.F(f, k)).transpose();
    o /= 3.0 * static_cast<double>(members[c].size());
    double v = 0;
    for (int32_t f : members[c]) {
      const Vec3 a = out.V.row(out.F(f, 0)).transpose() - o, b = out.V.row(out.F(f, 1)).transpose() - o,
                 cc = out.V.row(out.F(f, 2)).transpose() - o;
      v += a.dot(b.cross(cc)) / 6.0;
      if (boundary[f] || nadj[f] != 3) closed[c] = 0;
    }
    volume[c] = v;
    r.closed_components += closed[c];
  }
  // Parts with negative volume: inside-out, unless they bound a cavity of the other (positive) parts.
  std::vector<size_t> negative;
  for (size_t c = 0; c < members.size(); ++c)
    if (volume[c] < 0) negative.push_back(c);
  if (!negative.empty()) {
    Mesh positive;
    positive.V = out.V;
    long count = 0;
    for (size_t c = 0; c < members.size(); ++c)
      if (volume[c] >= 0) count += static_cast<long>(members[c].size());
    positive.F.resize(count, 3);
    long row = 0;
    for (size_t c = 0; c < members.size(); ++c)
      if (volume[c] >= 0)
        for (int32_t f : members[c]) positive.F.row(row++) = out.F.row(f);
    const bool any_positive = count > 0;
    const WindingNumber w_positive(positive);
    for (size_t c : negative) {
      const Vec3 probe = out.V.row(out.F(members[c][0], 0)).transpose();
      const bool cavity = any_positive && w_positive(probe) > 0.5;
      if (cavity) continue;
      r.inverted_components += closed[c];
      for (int32_t f : members[c]) {
        std::swap(out.F(f, 1), out.F(f, 2));
        flip[f] = static_cast<char>(!flip[f]);
      }
    }
  }
  for (int32_t f = 0; f < nf; ++f) r.flipped_faces += flip[f];
  r.closed = is_closed_oriented(out);
  if (report) *report = r;
  return out;
}

bool is_closed_oriented(const Mesh& mesh) {
  if (mesh.F.rows() == 0) return false;
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  for (size_t i = 0; i < h.size(); i += 2) {
    if (i + 1 >= h.size() || h[i].key != h[i + 1].key) return false;
    if (i + 2 < h.size() && h[i + 2].key == h[i].key) return false;
    if (h[i].forward == h[i + 1].forward) return false;
  }
  return true;
}

std::vector<std::array<int32_t, 3>> closed_edge_neighbours(const Mesh& mesh) {
  if (mesh.F.rows() == 0) return {};
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  std::vector<std::array<int32_t, 3>> out(static_cast<size_t>(mesh.F.rows()));
  for (size_t i = 0; i < h.size(); i += 2) {
    // Exactly two half-edges per key, in opposite directions (is_closed_oriented).
    if (i + 1 >= h.size() || h[i].key != h[i + 1].key) return {};
    if (i + 2 < h.size() && h[i + 2].key == h[i].key) return {};
    if (h[i].forward == h[i + 1].forward) return {};
    out[static_cast<size_t>(h[i].face)][static_cast<size_t>(h[i].corner)] = h[i + 1].face;
    out[static_cast<size_t>(h[i + 1].face)][static_cast<size_t>(h[i + 1].corner)] = h[i].face;
  }
  return out;
}

bool edges_balanced(const Mesh& mesh) {
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  for (size_t i = 0; i < h.size();) {
    int sum = 0;
    size_t j = i;
    for (; j < h.size() && h[j].key == h[i].key; ++j) sum += h[j].forward ? 1 : -1;
    // Edges from a vertex to itself (degenerate faces) cross nothing.
    if (sum != 0 && (h[i].key >> 32) != (h[i].key & 0xffffffffULL)) return false;
    i = j;
  }
  return true;
}

}  // namespace sdfkit
