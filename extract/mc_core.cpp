#include "extract/mc_core.h"

#include "core/error.h"
#include "core/union_find.h"

#include <algorithm>
#include <cassert>
#include <limits>
#include <iterator>
#include <map>
#include <set>
#include <unordered_map>

namespace sdfkit::detail {
namespace {

// ---- cube geometry ------------------------------------------------------------------------------------------

Vec3 corner_pos(int c) { return Vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

// The two axes other than `a`, in increasing order.
void other_axes(int a, int& u, int& v) {
  u = a == 0 ? 1 : 0;
  v = a == 2 ? 1 : 2;
}

// Edge e = 4 * axis + m; m's bit 0 / bit 1 give the edge's position along the other two axes.
int edge_axis(int e) { return e / 4; }
int edge_base(int e) {
  int u, v;
  other_axes(edge_axis(e), u, v);
  return ((e & 1) << u) | (((e >> 1) & 1) << v);
}
int edge_end(int e) { return edge_base(e) | (1 << edge_axis(e)); }
int edge_between(int c1, int c2) {
  const int diff = c1 ^ c2;
  const int a = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int base = std::min(c1, c2);
  int u, v;
  other_axes(a, u, v);
  return 4 * a + ((base >> u) & 1) + 2 * ((base >> v) & 1);
}
Vec3 edge_mid(int e) { return corner_pos(edge_base(e)) + 0.5 * Vec3::Unit(edge_axis(e)); }

// Face f = 2 * axis + side. Corners in cyclic order (u, v) = (0,0), (1,0), (1,1), (0,1) of the other axes;
// this order depends only on the global axes, so both cells sharing a face see it identically.
std::array<int, 4> face_corners(int f) {
  const int a = f / 2, side = f % 2;
  int u, v;
  other_axes(a, u, v);
  const int c00 = side << a;
  return {c00, c00 | (1 << u), c00 | (1 << u) | (1 << v), c00 | (1 << v)};
}

bool edges_share_face(int e1, int e2) {
  auto faces_of = [](int e) {
    int u, v;
    other_axes(edge_axis(e), u, v);
    return std::array<int, 2>{2 * u + (e & 1), 2 * v + ((e >> 1) & 1)};
  };
  for (int f1 : faces_of(e1))
    for (int f2 : faces_of(e2))
      if (f1 == f2) return true;
  return false;
}

// ---- case table ---------------------------------------------------------------------------------------------

struct Table {
  std::array<uint8_t, 256> ambiguous_faces{};  // bit f set when face f is ambiguous in this case
  std::vector<uint32_t> offset;                // (case * 64 + face bits) -> first triangle, size 256*64 + 1
  std::vector<std::array<uint8_t, 3>> tris;    // edge triples
  // Loops that cannot be triangulated without a diagonal lying in a cube face are fanned around an extra
  // vertex at their centroid: per entry, [length, edges...] records.
  std::vector<uint32_t> centre_offset;  // size 256*64 + 1
  std::vector<uint8_t> centre_loops;
  TableStats stats;
};

constexpr double kFaceDiagonalPenalty = 1000.0;

// Triangulates one boundary loop (edge ids in orientation order) by dynamic programming: minimum total squared
// diagonal length on the unit cube's edge midpoints, with diagonals that lie in a cube face penalised (they would
// put a triangle flat into the face shared with the neighbour cell).
double triangulate_loop(const std::vector<int>& loop, std::vector<std::array<uint8_t, 3>>& out) {
  const int k = static_cast<int>(loop.size());
  if (k == 3) {
    out.push_back({uint8_t(loop[0]), uint8_t(loop[1]), uint8_t(loop[2])});
    return 0;
  }
  auto side_cost = [&](int a, int b) {
    if (b - a == 1 || (a == 0 && b == k - 1)) return 0.0;
    if (edges_share_face(loop[a], loop[b])) return kFaceDiagonalPenalty;
    return (edge_mid(loop[a]) - edge_mid(loop[b])).squaredNorm();
  };
  std::vector<double> cost(k * k, 0.0);
  std::vector<int> split(k * k, -1);
  for (int len = 2; len < k; ++len)
    for (int i = 0; i + len < k; ++i) {
      const int j = i + len;
      double best = std::numeric_limits<double>::infinity();
      for (int m = i + 1; m < j; ++m) {
        const double c = cost[i * k + m] + cost[m * k + j] + side_cost(i, m) + side_cost(m, j) + side_cost(i, j);
        if (c < best - 1e-12) {
          best = c;
          split[i * k + j] = m;
        }
      }
      cost[i * k + j] = best;
    }
  // Emit in order (orientation of the loop is kept: i < m < j).
  std::vector<std::pair<int, int>> stack = {{0, k - 1}};
  while (!stack.empty()) {
    auto [i, j] = stack.back();
    stack.pop_back();
    if (j - i < 2) continue;
    const int m = split[i * k + j];
    out.push_back({uint8_t(loop[i]), uint8_t(loop[m]), uint8_t(loop[j])});
    stack.push_back({m, j});
    stack.push_back({i, m});
  }
  return cost[k - 1];
}

// Triangles of one (case, face decisions) entry. `inside_connected` bit f: on ambiguous face f, the two inside
// corners are joined across the face (the outside corners are cut off); otherwise the inside corners are.
void build_entry(int cube, int inside_connected, Table& t, bool& face_diagonal, int& max_loop) {
  auto inside = [&](int c) { return ((cube >> c) & 1) != 0; };
  std::array<int, 12> next;
  next.fill(-1);
  auto add_segment = [&](int f, int ea, int eb, int inside_corner) {
    // Orient so that (outward face normal) x (direction) points away from the inside corner.
    const int a = f / 2;
    const Vec3 n = (f % 2 ? 1.0 : -1.0) * Vec3::Unit(a);
    const Vec3 d = edge_mid(eb) - edge_mid(ea);
    const Vec3 mid = 0.5 * (edge_mid(ea) + edge_mid(eb));
    if (n.cross(d).dot(corner_pos(inside_corner) - mid) > 0) std::swap(ea, eb);
    if (next[ea] != -1) throw std::logic_error("marching cubes table: inconsistent segment orientation");
    next[ea] = eb;
  };
  for (int f = 0; f < 6; ++f) {
    const auto q = face_corners(f);
    std::array<int, 4> fe;
    for (int i = 0; i < 4; ++i) fe[i] = edge_between(q[i], q[(i + 1) % 4]);
    std::vector<int> crossed;
    for (int i = 0; i < 4; ++i)
      if (inside(q[i]) != inside(q[(i + 1) % 4])) crossed.push_back(i);
    if (crossed.size() == 2) {
      int qin = -1;
      for (int i = 0; i < 4; ++i)
        if (inside(q[i])) qin = q[i];
      add_segment(f, fe[crossed[0]], fe[crossed[1]], qin);
    } else if (crossed.size() == 4) {
      const bool join_inside = ((inside_connected >> f) & 1) != 0;
      for (int i = 0; i < 4; ++i) {
        // Cut off corner i when it is on the side that is not joined.
        if (inside(q[i]) == join_inside) continue;
        const int qin = inside(q[i]) ? q[i] : q[(i + 1) % 4];
        add_segment(f, fe[(i + 3) % 4], fe[i], qin);
      }
    }
  }
  std::array<bool, 12> used{};
  for (int e = 0; e < 12; ++e) {
    if (next[e] == -1 || used[e]) continue;
    std::vector<int> loop;
    for (int x = e; !used[x]; x = next[x]) {
      if (next[x] == -1) throw std::logic_error("marching cubes table: open loop");
      used[x] = true;
      loop.push_back(x);
    }
    max_loop = std::max(max_loop, static_cast<int>(loop.size()));
    std::vector<std::array<uint8_t, 3>> tris;
    if (triangulate_loop(loop, tris) >= kFaceDiagonalPenalty) {
      face_diagonal = true;
      t.centre_loops.push_back(static_cast<uint8_t>(loop.size()));
      for (int e : loop) t.centre_loops.push_back(static_cast<uint8_t>(e));
    } else {
      t.tris.insert(t.tris.end(), tris.begin(), tris.end());
    }
  }
}

Table make_table() {
  Table t;
  t.offset.assign(256 * 64 + 1, 0);
  t.centre_offset.assign(256 * 64 + 1, 0);
  for (int cube = 0; cube < 256; ++cube) {
    uint8_t amb = 0;
    for (int f = 0; f < 6; ++f) {
      const auto q = face_corners(f);
      const bool i0 = (cube >> q[0]) & 1, i1 = (cube >> q[1]) & 1, i2 = (cube >> q[2]) & 1, i3 = (cube >> q[3]) & 1;
      if (i0 == i2 && i1 == i3 && i0 != i1) amb |= uint8_t(1 << f);
    }
    t.ambiguous_faces[cube] = amb;
  }
  for (int cube = 0; cube < 256; ++cube)
    for (int bits = 0; bits < 64; ++bits) {
      const int idx = cube * 64 + bits;
      t.offset[idx] = static_cast<uint32_t>(t.tris.size());
      t.centre_offset[idx] = static_cast<uint32_t>(t.centre_loops.size());
      if ((bits & ~t.ambiguous_faces[cube]) != 0) continue;  // never looked up
      bool face_diagonal = false;
      build_entry(cube, bits, t, face_diagonal, t.stats.max_loop_length);
      ++t.stats.entries;
      if (face_diagonal) ++t.stats.entries_with_centre_vertex;
    }
  t.offset[256 * 64] = static_cast<uint32_t>(t.tris.size());
  t.centre_offset[256 * 64] = static_cast<uint32_t>(t.centre_loops.size());
  return t;
}

const Table& table() {
  static const Table kTable = make_table();
  return kTable;
}

// ---- keys ---------------------------------------------------------------------------------------------------

constexpr int kKeyBits = 20;
constexpr int kKeyOffset = 1 << (kKeyBits - 1);

uint64_t pack_key(int i, int j, int k, int kind) {
  return (uint64_t(i + kKeyOffset) << (2 * kKeyBits + 2)) | (uint64_t(j + kKeyOffset) << (kKeyBits + 2)) |
         (uint64_t(k + kKeyOffset) << 2) | uint64_t(kind);
}

constexpr uint64_t kEmpty = ~uint64_t(0);
constexpr uint64_t kNoSnap = ~uint64_t(0);
// Fraction of the way towards its neighbours' centroid by which a coincident vertex is moved apart.
constexpr double kNudge = 1e-3;

uint64_t hash64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace

// ---- KeyMap -------------------------------------------------------------------------------------------------

KeyMap::KeyMap(size_t expected) {
  size_t cap = 16;
  while (cap < 2 * expected) cap *= 2;
  keys_.assign(cap, kEmpty);
  ids_.assign(cap, -1);
  mask_ = cap - 1;
}

int32_t KeyMap::find_or_insert(uint64_t key, int32_t next_id, bool& inserted) {
  if (2 * (size_ + 1) > keys_.size()) grow();
  size_t h = hash64(key) & mask_;
  while (true) {
    if (keys_[h] == key) {
      inserted = false;
      return ids_[h];
    }
    if (keys_[h] == kEmpty) {
      keys_[h] = key;
      ids_[h] = next_id;
      ++size_;
      inserted = true;
      return next_id;
    }
    h = (h + 1) & mask_;
  }
}

void KeyMap::grow() {
  std::vector<uint64_t> old_keys = std::move(keys_);
  std::vector<int32_t> old_ids = std::move(ids_);
  keys_.assign(old_keys.size() * 2, kEmpty);
  ids_.assign(old_keys.size() * 2, -1);
  mask_ = keys_.size() - 1;
  for (size_t s = 0; s < old_keys.size(); ++s) {
    if (old_keys[s] == kEmpty) continue;
    size_t h = hash64(old_keys[s]) & mask_;
    while (keys_[h] != kEmpty) h = (h + 1) & mask_;
    keys_[h] = old_keys[s];
    ids_[h] = old_ids[s];
  }
}

// ---- McBuilder ----------------------------------------------------------------------------------------------

McBuilder::McBuilder() : map_(1 << 14) { (void)table(); }

bool McBuilder::has_crossing(const double s[kCorners], uint32_t pad) {
  int inside = 0;
  for (int c = 0; c < kCorners; ++c) inside += (!((pad >> c) & 1) && s[c] < 0) ? 1 : 0;
  return inside != 0 && inside != kCorners;
}

int32_t McBuilder::vertex_for_edge(int i, int j, int k, int edge, const double s[kCorners], uint32_t pad) {
  const int ca = edge_base(edge), cb = edge_end(edge), axis = edge_axis(edge);
  const int ai = i + (ca & 1), aj = j + ((ca >> 1) & 1), ak = k + ((ca >> 2) & 1);
  const int bi = i + (cb & 1), bj = j + ((cb >> 1) & 1), bk = k + ((cb >> 2) & 1);
  const bool pad_a = (pad >> ca) & 1, pad_b = (pad >> cb) & 1;
  // One vertex per crossed edge. A vertex that lands exactly on a grid point remembers that point: vertices of
  // the same point joined by a (zero-length) mesh edge are merged in finish().
  const uint64_t key = pack_key(ai, aj, ak, axis);
  uint64_t snap = kNoSnap;
  Vec3 pos(ai, aj, ak);
  if (pad_a || pad_b) {
    // Closing cap: the vertex sits on the grid point that is inside.
    if (pad_a) pos = Vec3(bi, bj, bk);
    snap = pad_a ? pack_key(bi, bj, bk, 3) : pack_key(ai, aj, ak, 3);
  } else {
    const double sa = s[ca], sb = s[cb];
    const double t = sa / (sa - sb);
    if (t <= 0.0) {
      snap = pack_key(ai, aj, ak, 3);
    } else if (t >= 1.0) {
      pos = Vec3(bi, bj, bk);
      snap = pack_key(bi, bj, bk, 3);
    } else {
      pos[axis] += t;
    }
  }
  bool inserted = false;
  const int32_t id = map_.find_or_insert(key, static_cast<int32_t>(vertices_.size()), inserted);
  if (inserted) {
    vertices_.push_back(pos);
    snap_.push_back(snap);
    key_.push_back(key);
    if (snap != kNoSnap) ++stats_.snapped_vertices;
  }
  return id;
}

void McBuilder::add_cell(int i, int j, int k, const double s_in[kCorners], uint32_t pad) {
  double s[kCorners];
  int cube = 0;
  for (int c = 0; c < kCorners; ++c) {
    const bool is_pad = (pad >> c) & 1;
    s[c] = is_pad ? kPadValue : s_in[c];
    if (!is_pad && s[c] < 0) cube |= 1 << c;
  }
  if (cube == 0 || cube == 255) return;
  const Table& t = table();
  int bits = 0;
  const uint8_t amb = t.ambiguous_faces[cube];
  if (amb) {
    for (int f = 0; f < 6; ++f) {
      if (!((amb >> f) & 1)) continue;
      const auto q = face_corners(f);
      // Asymptotic decider: the bilinear saddle is inside iff the inside diagonal's product of |s| is the larger.
      const double p02 = s[q[0]] * s[q[2]], p13 = s[q[1]] * s[q[3]];
      const bool q0_inside = (cube >> q[0]) & 1;
      const double p_in = q0_inside ? p02 : p13, p_out = q0_inside ? p13 : p02;
      if (p_in > p_out) bits |= 1 << f;
    }
  }
  const int idx = cube * 64 + bits;
  const uint32_t begin = t.offset[idx], end = t.offset[idx + 1];
  const uint32_t cbegin = t.centre_offset[idx], cend = t.centre_offset[idx + 1];
  if (begin == end && cbegin == cend) return;
  ++stats_.cells_with_surface;
  std::array<int32_t, 12> vid;
  vid.fill(-1);
  auto vertex = [&](int e) {
    if (vid[e] < 0) vid[e] = vertex_for_edge(i, j, k, e, s, pad);
    return vid[e];
  };
  for (uint32_t n = begin; n < end; ++n) faces_.push_back({vertex(t.tris[n][0]), vertex(t.tris[n][1]), vertex(t.tris[n][2])});
  for (uint32_t n = cbegin; n < cend;) {
    const int len = t.centre_loops[n++];
    std::vector<int32_t> loop(len);
    Vec3 centre = Vec3::Zero();
    for (int m = 0; m < len; ++m) {
      loop[m] = vertex(t.centre_loops[n + m]);
      centre += vertices_[loop[m]];
    }
    n += len;
    const int32_t c = static_cast<int32_t>(vertices_.size());
    vertices_.push_back(centre / double(len));
    snap_.push_back(kNoSnap);
    key_.push_back(kNoSnap);
    ++stats_.centre_vertices;
    for (int m = 0; m < len; ++m) faces_.push_back({c, loop[m], loop[(m + 1) % len]});
  }
}

void McBuilder::append(const McBuilder& other) {
  std::vector<int32_t> remap(other.vertices_.size());
  for (size_t v = 0; v < other.vertices_.size(); ++v) {
    const int32_t next = static_cast<int32_t>(vertices_.size());
    bool inserted = true;
    if (other.key_[v] != kNoSnap) remap[v] = map_.find_or_insert(other.key_[v], next, inserted);
    if (!inserted) continue;
    remap[v] = next;
    vertices_.push_back(other.vertices_[v]);
    snap_.push_back(other.snap_[v]);
    key_.push_back(other.key_[v]);
    if (other.snap_[v] != kNoSnap) ++stats_.snapped_vertices;
  }
  faces_.reserve(faces_.size() + other.faces_.size());
  for (const auto& f : other.faces_) faces_.push_back({remap[f[0]], remap[f[1]], remap[f[2]]});
  stats_.cells_with_surface += other.stats_.cells_with_surface;
  stats_.centre_vertices += other.stats_.centre_vertices;
}

Mesh McBuilder::finish(const Vec3& origin, double voxel, MarchingCubesStats* stats) const {
  return finish([&](const Vec3& p) -> Vec3 { return origin + voxel * p; }, stats);
}

Mesh McBuilder::finish(const std::function<Vec3(const Vec3&)>& index_to_world, MarchingCubesStats* stats) const {
  const size_t nv = vertices_.size();
  UnionFind reps(nv);  // merged vertices; the smallest id represents its set
  auto find = [&reps](int32_t v) { return reps.find(v); };
  std::vector<Vec3> positions = vertices_;
  long collapsed = 0;
  if (stats_.snapped_vertices > 0) {
    // 1. Vertices that snapped to the same grid point and are joined by a mesh edge (a zero-length edge) are
    //    merged, one edge at a time in face order, when the merge keeps the mesh manifold (link condition: the
    //    common neighbours of the two vertices are exactly the apexes of the triangles on their edge). Where it
    //    would not -- the zero set touches itself at that point -- the vertices stay apart.
    std::unordered_map<int32_t, std::vector<size_t>> incident;  // snapped vertex -> faces
    std::unordered_map<int32_t, std::vector<int32_t>> members;  // representative -> snapped vertices
    for (size_t f = 0; f < faces_.size(); ++f)
      for (int32_t v : faces_[f])
        if (snap_[v] != kNoSnap) incident[v].push_back(f);
    for (const auto& [v, fs] : incident) members[v] = {v};
    auto neighbours = [&](int32_t r) {
      std::set<int32_t> out;
      for (int32_t m : members[r])
        for (size_t f : incident[m])
          for (int32_t v : faces_[f]) {
            const int32_t rv = find(v);
            if (rv != r) out.insert(rv);
          }
      return out;
    };
    auto apexes = [&](int32_t ra, int32_t rb) {
      std::set<int32_t> out;
      for (int32_t m : members[ra])
        for (size_t f : incident[m]) {
          const std::array<int32_t, 3> t = {find(faces_[f][0]), find(faces_[f][1]), find(faces_[f][2])};
          if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
          for (int e = 0; e < 3; ++e)
            if (t[e] == ra && (t[(e + 1) % 3] == rb || t[(e + 2) % 3] == rb))
              out.insert(t[(e + 1) % 3] == rb ? t[(e + 2) % 3] : t[(e + 1) % 3]);
        }
      return out;
    };
    for (const auto& f : faces_)
      for (int e = 0; e < 3; ++e) {
        const int32_t a = f[e], b = f[(e + 1) % 3];
        if (snap_[a] == kNoSnap || snap_[a] != snap_[b]) continue;
        const int32_t ra = find(a), rb = find(b);
        if (ra == rb) continue;
        const std::set<int32_t> na = neighbours(ra), nb = neighbours(rb), ap = apexes(ra, rb);
        std::vector<int32_t> common;
        std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
        if (common.size() != ap.size() || !std::equal(common.begin(), common.end(), ap.begin())) continue;
        const int32_t keep = std::min(ra, rb), gone = std::max(ra, rb);  // smallest id represents
        reps.unite(ra, rb);
        auto& mk = members[keep];
        auto& mg = members[gone];
        mk.insert(mk.end(), mg.begin(), mg.end());
        mg.clear();
      }
    // 2. Representatives of one grid point that stayed apart would coincide: move each a tiny step (kNudge of
    //    the way) towards the centroid of its neighbours, i.e. into its own sheet.
    std::map<uint64_t, std::vector<int32_t>> at_point;
    for (const auto& [v, fs] : incident)
      if (find(v) == v) at_point[snap_[v]].push_back(v);
    std::vector<std::pair<int32_t, Vec3>> moves;
    for (auto& [key, reps] : at_point) {
      if (reps.size() < 2) continue;
      std::sort(reps.begin(), reps.end());
      for (int32_t r : reps) {
        const std::set<int32_t> nb = neighbours(r);
        Vec3 centroid = Vec3::Zero();
        for (int32_t v : nb) centroid += vertices_[v];
        if (!nb.empty()) centroid /= double(nb.size());
        moves.push_back({r, vertices_[r] + kNudge * (centroid - vertices_[r])});
      }
    }
    for (const auto& [r, p] : moves) positions[r] = p;
  }
  std::vector<std::array<int32_t, 3>> faces;
  faces.reserve(faces_.size());
  for (const auto& f : faces_) {
    const std::array<int32_t, 3> t = {find(f[0]), find(f[1]), find(f[2])};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++collapsed;
      continue;
    }
    faces.push_back(t);
  }
  // Merging can still turn two triangles into one with opposite orientations (a zero-volume fin); remove
  // such pairs. Only faces with a snapped vertex can be involved.
  std::vector<char> drop(faces.size(), 0);
  if (collapsed > 0) {
    std::map<std::array<int32_t, 3>, std::vector<size_t>> groups;
    for (size_t f = 0; f < faces.size(); ++f) {
      const auto& t = faces[f];
      if (snap_[t[0]] == kNoSnap && snap_[t[1]] == kNoSnap && snap_[t[2]] == kNoSnap) continue;
      std::array<int32_t, 3> key = t;
      std::sort(key.begin(), key.end());
      groups[key].push_back(f);
    }
    auto even = [](const std::array<int32_t, 3>& t) {
      const int m = int(std::min_element(t.begin(), t.end()) - t.begin());
      return t[(m + 1) % 3] < t[(m + 2) % 3];
    };
    for (auto& [key, fs] : groups) {
      if (fs.size() < 2) continue;
      std::vector<size_t> pos, neg;
      for (size_t f : fs) (even(faces[f]) ? pos : neg).push_back(f);
      const size_t pairs = std::min(pos.size(), neg.size());
      for (size_t n = 0; n < pairs; ++n) drop[pos[n]] = drop[neg[n]] = 1;
    }
  }
  // 3. Keep only referenced vertices, numbered in creation order (deterministic).
  std::vector<int32_t> remap(nv, -1);
  size_t kept = 0;
  for (size_t f = 0; f < faces.size(); ++f) {
    if (drop[f]) continue;
    ++kept;
    for (int32_t v : faces[f]) remap[v] = 0;
  }
  int32_t n = 0;
  for (auto& r : remap)
    if (r == 0) r = n++;
  Mesh m;
  m.V.resize(n, 3);
  for (size_t v = 0; v < nv; ++v)
    if (remap[v] >= 0) m.V.row(remap[v]) = index_to_world(positions[v]).transpose();
  m.F.resize(static_cast<Eigen::Index>(kept), 3);
  Eigen::Index row = 0;
  for (size_t f = 0; f < faces.size(); ++f)
    if (!drop[f]) m.F.row(row++) << remap[faces[f][0]], remap[faces[f][1]], remap[faces[f][2]];
  if (stats) {
    stats->cells_with_surface = stats_.cells_with_surface;
    stats->collapsed_triangles = collapsed;
    stats->snapped_vertices = stats_.snapped_vertices;
    stats->centre_vertices = stats_.centre_vertices;
  }
  return m;
}

TableStats table_stats() { return table().stats; }

}  // namespace sdfkit::detail
