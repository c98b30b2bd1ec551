#include "sdf/sparse_sdf.h"

#include "core/error.h"
#include "core/union_find.h"
#include "sdf/band_triangle.h"
#include "sdf/distance.h"
#include "sdf/mesh_queries.h"
#include "sdf/orientation.h"
#include "sdf/pseudonormal.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Prune.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>
#include <unordered_map>
#include <utility>
#include <unistd.h>

namespace sdfkit {

void ensure_openvdb_initialized() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

namespace {

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using LeafT = FloatTree::LeafNodeType;

// The stages of SparseSdf::from_mesh and their constants.

/// Faces per task when the band triangles are prepared and binned to leaves.
constexpr size_t kFacesPerChunk = 4096;
/// A leaf scans its triangles voxel row by voxel row unless that costs more than this many triangle-voxel tests
/// per voxel; then it makes one bounded BVH query per voxel (about 50 triangle tests each) instead.
constexpr long kScanTestsPerVoxel = 48;
/// Two voxels a voxel apart whose distances sum to more than h cannot have a surface point between them; the 2%
/// absorbs the rounding of the stored float distances.
constexpr double kNoSurfaceBetween = 1.02;
/// Inside iff the inside measure (winding number, or 1/0 from the pseudo-normal) exceeds this.
constexpr double kInsideThreshold = 0.5;
/// A component's probes decide it only when every one is at least this far from kInsideThreshold and they agree.
constexpr double kClearProbe = 0.25;
/// Components of at most this many voxels or blocks are decided member by member.
constexpr size_t kSmallComponent = 4;

/// Components of items connected by "no surface between them" edges; for each, decide inside/outside by
/// probing the winding number at a few members, falling back to every member when the probes disagree or
/// are ambiguous (open meshes, where the w = 0.5 set is not tied to the surface).
/// `position(i)` gives the item's world position, `inside_out` receives the decision per item.
template <typename PosFn, typename Oracle>
long classify_components(UnionFind& uf, int32_t n, const std::vector<int32_t>& preferred_probe, const PosFn& position,
                         const Oracle& wn, double threshold, std::vector<char>& inside) {
  long evaluations = 0;
  std::map<int32_t, std::vector<int32_t>> groups;  // root -> members in index order (deterministic)
  for (int32_t i = 0; i < n; ++i) groups[uf.find(i)].push_back(i);
  for (const auto& group : groups) {
    const int32_t root = group.first;
    const std::vector<int32_t>& members = group.second;  // a named reference: lambdas may not capture bindings
    auto decide_all = [&] {
      for (int32_t m : members) {
        inside[m] = wn(position(m)) > threshold;
        ++evaluations;
      }
    };
    if (members.size() <= kSmallComponent) {
      decide_all();
      continue;
    }
    std::array<int32_t, 3> probes{preferred_probe[root], members.front(), members.back()};
    bool first = true, agreed = true, verdict = false;
    for (int32_t p : probes) {
      const double w = wn(position(p));
      ++evaluations;
      const bool in = w > threshold;
      if (std::abs(w - threshold) < kClearProbe) agreed = false;
      if (first) verdict = in;
      else if (in != verdict) agreed = false;
      first = false;
    }
    if (agreed) {
      for (int32_t m : members) inside[m] = static_cast<char>(verdict);
    } else {
      decide_all();
    }
  }
  return evaluations;
}

struct Progress {
  const ProgressFn& fn;
  void operator()(double f) const {
    if (fn && !fn(f)) throw Error("cancelled");
  }
};

/// The grid under construction: voxel index i sits at (i - kGridIndexOffset) * h; the band holds every voxel within
/// `width` of the surface, `background` (= width) beyond it.
struct BandGrid {
  double h = 0, width = 0;
  float background = 0;
  [[nodiscard]] Vec3 position(const Coord& c) const {
    constexpr int32_t O = kGridIndexOffset;
    return Vec3((c.x() - O) * h, (c.y() - O) * h, (c.z() - O) * h);
  }
  [[nodiscard]] Vec3 voxel_position(const LeafT& leaf, int32_t i) const {
    return position(leaf.origin() + LeafT::offsetToLocalCoord(static_cast<openvdb::Index>(i)));
  }
  /// Voxels a and b (neighbours) with these distances have no surface between them.
  [[nodiscard]] float no_surface_sum() const { return static_cast<float>(h * kNoSurfaceBetween); }
  /// With sealed cavities, the band's wall voxels (|distance| <= this) join no component: the flood's exterior and a
  /// cavity meet across them without a surface in between. -1: no sealing.
  float wall = -1.f;
  /// Neighbour voxels with unsigned distances a and b share a sign.
  [[nodiscard]] bool joinable(float a, float b, float safe) const { return a + b > safe && a > wall && b > wall; }
};

using InsideMeasure = std::function<double(const Vec3&)>;

/// Stage 1, the exact unsigned band, built per 8^3 leaf: every voxel closer than `width` to the surface has its
/// closest triangle within `width`, so the triangle's bounding box grown by `width` contains the voxel. Triangles
/// are binned to the leaves their grown boxes touch; each leaf then takes, per voxel, the minimum distance over its
/// triangles (exact closest-point distances, order-independent: deterministic for any thread count). Returns the
/// leaves holding at least one band voxel (others null), in leaf-key order.
std::vector<std::unique_ptr<LeafT>> exact_band_leaves(const Mesh& mesh, const MeshDistance& exact, const BandGrid& g) {
  constexpr int32_t O = kGridIndexOffset;
  const double h = g.h, width = g.width;
  const float background = g.background;
  constexpr int32_t D = LeafT::DIM;
  const auto nf = static_cast<size_t>(mesh.F.rows());
  std::vector<BandTriangle> tris(nf);
  std::vector<std::pair<Coord, Coord>> tri_box(nf);  ///< voxel index box of each grown bounding box
  auto leaf_key = [](const Coord& c) {
    // Leaf coordinates (voxel >> 3) in 21 bits each.
    return (static_cast<uint64_t>((c.x() >> 3) + (1 << 20)) << 42) |
           (static_cast<uint64_t>((c.y() >> 3) + (1 << 20)) << 21) | static_cast<uint64_t>((c.z() >> 3) + (1 << 20));
  };
  auto key_origin = [](uint64_t k) {
    const auto part = [](uint64_t v) { return (static_cast<int32_t>(v & ((1u << 21) - 1)) - (1 << 20)) * 8; };
    return Coord(part(k >> 42), part(k >> 21), part(k));
  };
  std::vector<std::vector<std::pair<uint64_t, int32_t>>> chunk_pairs((nf + kFacesPerChunk - 1) / kFacesPerChunk);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, chunk_pairs.size()), [&](const auto& r) {
    for (size_t ch = r.begin(); ch != r.end(); ++ch) {
      auto& out = chunk_pairs[ch];
      for (size_t f = ch * kFacesPerChunk; f < std::min(nf, (ch + 1) * kFacesPerChunk); ++f) {
        const auto fi = static_cast<Eigen::Index>(f);
        const Vec3 a = mesh.V.row(mesh.F(fi, 0)), b = mesh.V.row(mesh.F(fi, 1)), c = mesh.V.row(mesh.F(fi, 2));
        tris[f] = BandTriangle::make(a, b, c);
        const Vec3 lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
        auto& t = tri_box[f];
        for (int k = 0; k < 3; ++k) {
          t.first[k] = static_cast<int32_t>(std::ceil((lo[k] - width) / h)) + O;
          t.second[k] = static_cast<int32_t>(std::floor((hi[k] + width) / h)) + O;
        }
        for (int32_t x = t.first.x() & ~(D - 1); x <= t.second.x(); x += D)
          for (int32_t y = t.first.y() & ~(D - 1); y <= t.second.y(); y += D)
            for (int32_t z = t.first.z() & ~(D - 1); z <= t.second.z(); z += D)
              out.emplace_back(leaf_key(Coord(x, y, z)), static_cast<int32_t>(f));
      }
    }
  });
  std::vector<std::pair<uint64_t, int32_t>> pairs;
  for (auto& c : chunk_pairs) pairs.insert(pairs.end(), c.begin(), c.end());
  chunk_pairs.clear();
  std::sort(pairs.begin(), pairs.end());
  std::vector<size_t> starts;
  for (size_t i = 0; i < pairs.size(); ++i)
    if (i == 0 || pairs[i].first != pairs[i - 1].first) starts.push_back(i);
  starts.push_back(pairs.size());
  const size_t nleaves = starts.size() - 1;
  std::vector<std::unique_ptr<LeafT>> built(nleaves);
  const double width2 = width * width;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nleaves, 8), [&](const auto& r) {
    std::array<double, LeafT::SIZE> best;
    std::vector<std::pair<double, int32_t>> order;
    for (size_t li = r.begin(); li != r.end(); ++li) {
      const Coord origin = key_origin(pairs[starts[li]].first);
      best.fill(width2);
      // Wide bands (or large triangles) make the per-triangle scan cost more than one bounded BVH query per
      // voxel (~50 triangle tests); then query the BVH instead, each query started from the previous face.
      long scan_cost = 0;
      for (size_t pi = starts[li]; pi < starts[li + 1]; ++pi) {
        const auto& t = tri_box[static_cast<size_t>(pairs[pi].second)];
        const Coord lo = Coord::maxComponent(t.first, origin);
        const Coord hi = Coord::minComponent(t.second, origin.offsetBy(D - 1));
        scan_cost += static_cast<long>(std::max(0, hi.x() - lo.x() + 1)) * std::max(0, hi.y() - lo.y() + 1) *
                     std::max(0, hi.z() - lo.z() + 1);
      }
      if (scan_cost > kScanTestsPerVoxel * static_cast<long>(LeafT::SIZE)) {
        int32_t hint = -1;
        for (size_t i = 0; i < LeafT::SIZE; ++i) {
          const Coord c = origin + LeafT::offsetToLocalCoord(static_cast<openvdb::Index>(i));
          const ClosestPoint cp = exact.closest(Vec3((c.x() - O) * h, (c.y() - O) * h, (c.z() - O) * h), width, hint);
          if (cp.face >= 0) {
            best[i] = cp.distance * cp.distance;
            hint = cp.face;
          }
        }
      } else {
        // Nearest triangles first (distance to the leaf's centre): the voxels' best values then drop early
        // and the later triangles' voxels mostly end at the first (plane) test. The minimum does not depend
        // on the order.
        const Vec3 centre((origin.x() + 0.5 * (D - 1) - O) * h, (origin.y() + 0.5 * (D - 1) - O) * h,
                          (origin.z() + 0.5 * (D - 1) - O) * h);
        order.clear();
        for (size_t pi = starts[li]; pi < starts[li + 1]; ++pi)
          order.emplace_back(tris[static_cast<size_t>(pairs[pi].second)].squared_distance(centre), pairs[pi].second);
        std::sort(order.begin(), order.end());
        for (const auto& [unused, f] : order) {
          const BandTriangle& t = tris[static_cast<size_t>(f)];
          const auto& box = tri_box[static_cast<size_t>(f)];
          const Coord lo = Coord::maxComponent(box.first, origin);
          const Coord hi = Coord::minComponent(box.second, origin.offsetBy(D - 1));
          const int32_t count = hi.z() - lo.z() + 1;
          for (int32_t x = lo.x(); x <= hi.x(); ++x)
            for (int32_t y = lo.y(); y <= hi.y(); ++y) {
              const size_t i =
                  static_cast<size_t>(((x - origin.x()) * D + (y - origin.y())) * D + (lo.z() - origin.z()));
              t.row_min((x - O) * h, (y - O) * h, lo.z(), count, O, h, &best[i], width2);
            }
        }
      }
      bool any = false;
      for (double b : best) any = any || b < width2;
      if (!any) continue;
      auto leaf = std::make_unique<LeafT>(origin, background, false);
      for (size_t i = 0; i < LeafT::SIZE; ++i)
        if (best[i] < width2) leaf->setValueOn(static_cast<openvdb::Index>(i), static_cast<float>(std::sqrt(best[i])));
      built[li] = std::move(leaf);
    }
  });
  return built;
}

/// Calls unite(i, j) for every pair of face-adjacent voxels of one leaf (leaf-local indices, x-major) between which
/// no surface can pass (BandGrid::joinable). Both sign stages join a leaf's voxels by this rule, in this order.
template <class Unite>
void unite_inside_leaf(const float* v, const BandGrid& g, Unite&& unite) {
  constexpr int32_t D = LeafT::DIM;
  const float safe = g.no_surface_sum();
  for (int32_t x = 0; x < D; ++x)
    for (int32_t y = 0; y < D; ++y)
      for (int32_t z = 0; z < D; ++z) {
        const int32_t i = (x * D + y) * D + z;
        if (z + 1 < D && g.joinable(v[i], v[i + 1], safe)) unite(i, i + 1);
        if (y + 1 < D && g.joinable(v[i], v[i + D], safe)) unite(i, i + D);
        if (x + 1 < D && g.joinable(v[i], v[i + D * D], safe)) unite(i, i + D * D);
      }
}

/// Stage 2a, signs leaf by leaf for the leaves `which`: the components of voxels with no surface between them
/// inside the leaf, each probed (classify_components). Robust where the w = 0.5 set is not tied to the surface
/// (open meshes), at the price of probes in every leaf. Writes inside_all[leaf * 512 + voxel].
void signs_per_leaf(const std::vector<LeafT*>& leaves, const std::vector<int32_t>& which, const BandGrid& g,
                    const InsideMeasure& wn, std::vector<char>& inside_all, std::atomic<long>& evaluations) {
  constexpr auto S = static_cast<int32_t>(LeafT::SIZE);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, which.size(), 4), [&](const auto& range) {
    UnionFind uf(LeafT::SIZE);
    std::vector<int32_t> best(LeafT::SIZE);
    std::vector<char> inside(LeafT::SIZE);
    for (size_t wi = range.begin(); wi != range.end(); ++wi) {
      const auto li = static_cast<size_t>(which[wi]);
      const LeafT& leaf = *leaves[li];
      uf.reset(LeafT::SIZE);
      const float* v = leaf.buffer().data();
      unite_inside_leaf(v, g, [&uf](int32_t i, int32_t j) { uf.unite(i, j); });
      // Preferred probe per component: the member farthest from the surface (most robust).
      for (int32_t i = 0; i < S; ++i) best[i] = -1;
      for (int32_t i = 0; i < S; ++i) {
        const int32_t r = uf.find(i);
        if (best[r] < 0 || v[i] > v[best[r]]) best[r] = i;
      }
      evaluations += classify_components(uf, S, best, [&](int32_t i) { return g.voxel_position(leaf, i); }, wn,
                                         kInsideThreshold, inside);
      std::copy(inside.begin(), inside.end(), inside_all.begin() + static_cast<std::ptrdiff_t>(li * S));
    }
  });
}

/// Stage 2b, signs of a band without boundary edges: across leaves, the same components over the whole band (voxel
/// pairs across leaf faces joined by the same rule), a few probes per component. A component whose probes all
/// agree clearly takes their verdict; small components take a decided neighbour's sign when no triangle lies
/// between them (winding numbers) or their own probe; the leaves of undecided components are decided leaf by leaf
/// (stage 2a). A closed shell's band then costs a handful of probes instead of a few per leaf. `sealed`: the sealed
/// cavities `wn` counts inside, or null.
void signs_by_band_components(const std::vector<LeafT*>& leaves, const BandGrid& band, const InsideMeasure& wn,
                              const MeshDistance& exact, bool winding, const SealedCavities* sealed,
                              std::vector<char>& inside_all, std::atomic<long>& evaluations) {
  constexpr int32_t D = LeafT::DIM;
  constexpr auto S = static_cast<int32_t>(LeafT::SIZE);
  const float safe = band.no_surface_sum();
  const double threshold = kInsideThreshold;
  const size_t nl = leaves.size();
  auto voxel_position = [&band](const LeafT& leaf, int32_t i) { return band.voxel_position(leaf, i); };
  // Union by smaller root: a set's root is its smallest index whatever the order of the unions.
  UnionFind sets(nl * static_cast<size_t>(S));
  auto find = [&sets](int32_t x) { return sets.find(x); };
  auto unite = [&sets](int32_t a, int32_t b) { sets.unite(a, b); };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 8), [&](const auto& range) {
    for (size_t li = range.begin(); li != range.end(); ++li) {
      const float* v = leaves[li]->buffer().data();
      const auto base = static_cast<int32_t>(li * S);
      unite_inside_leaf(v, band, [&unite, base](int32_t i, int32_t j) { unite(base + i, base + j); });
    }
  });
  std::unordered_map<uint64_t, int32_t> leaf_at;
  leaf_at.reserve(nl * 2);
  auto key = [](const Coord& c) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(c.x()) >> 3) << 42) ^
           (static_cast<uint64_t>(static_cast<uint32_t>(c.y()) >> 3) << 21) ^
           static_cast<uint64_t>(static_cast<uint32_t>(c.z()) >> 3);
  };
  for (size_t li = 0; li < nl; ++li) leaf_at[key(leaves[li]->origin())] = static_cast<int32_t>(li);
  for (size_t li = 0; li < nl; ++li) {
    const float* v = leaves[li]->buffer().data();
    for (int a = 0; a < 3; ++a) {
      Coord no = leaves[li]->origin();
      no[a] += D;
      const auto it = leaf_at.find(key(no));
      if (it == leaf_at.end() || leaves[static_cast<size_t>(it->second)]->origin() != no) continue;
      const float* w = leaves[static_cast<size_t>(it->second)]->buffer().data();
      const auto base = static_cast<int32_t>(li * S), nbase = it->second * S;
      const int32_t stride = a == 0 ? D * D : a == 1 ? D : 1;
      for (int32_t u = 0; u < D; ++u)
        for (int32_t t = 0; t < D; ++t) {
          // Voxel with coordinate a = D - 1 here, 0 in the neighbour; the other two coordinates (u, t).
          const int32_t j = a == 0 ? u * D + t : a == 1 ? u * D * D + t : (u * D + t) * D;
          const int32_t i = j + (D - 1) * stride;
          if (band.joinable(v[i], w[j], safe)) unite(base + i, nbase + j);
        }
    }
  }
  const auto n = static_cast<int32_t>(sets.size());
  // Components in order of their smallest voxel index; members listed in index order.
  std::vector<int32_t> comp(sets.size());
  std::vector<int32_t> starts;
  for (int32_t i = 0; i < n; ++i) {
    const int32_t r = find(i);
    if (r == i) {
      comp[i] = static_cast<int32_t>(starts.size());
      starts.push_back(0);
    } else {
      comp[i] = comp[r];
    }
    ++starts[comp[i]];
  }
  const auto nc = static_cast<int32_t>(starts.size());
  {
    int32_t total = 0;
    for (auto& c : starts) total += std::exchange(c, total);
    starts.push_back(total);
  }
  std::vector<int32_t> members(sets.size());
  {
    std::vector<int32_t> fill(starts.begin(), starts.end() - 1);
    for (int32_t i = 0; i < n; ++i) members[fill[comp[i]]++] = i;
  }
  sets = UnionFind();  // free the per-voxel table before the probes
  std::vector<char> undecided(static_cast<size_t>(nc), 0);
  auto position = [&](int32_t g) { return voxel_position(*leaves[static_cast<size_t>(g / S)], g % S); };
  auto value = [&](int32_t g) { return leaves[static_cast<size_t>(g / S)]->buffer().data()[g % S]; };
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, nc, 16), [&](const auto& range) {
    long local = 0;
    for (int32_t c = range.begin(); c != range.end(); ++c) {
      const int32_t* m = members.data() + starts[c];
      const int32_t count = starts[c + 1] - starts[c];
      if (count <= static_cast<int32_t>(kSmallComponent)) continue;  // below, once the large components are decided
      int32_t far = m[0];
      for (int32_t k = 1; k < count; ++k)
        if (value(m[k]) > value(far)) far = m[k];
      const int32_t probes[6] = {far, m[0], m[count / 4], m[count / 2], m[3 * count / 4], m[count - 1]};
      bool agreed = true, verdict = false;
      for (int k = 0; k < 6 && agreed; ++k) {
        const double w = wn(position(probes[k]));
        ++local;
        const bool in = w > threshold;
        if (std::abs(w - threshold) < kClearProbe || (k > 0 && in != verdict)) agreed = false;
        verdict = in;
      }
      if (!agreed) {
        undecided[static_cast<size_t>(c)] = 1;
        continue;
      }
      for (int32_t k = 0; k < count; ++k) inside_all[static_cast<size_t>(m[k])] = static_cast<char>(verdict);
    }
    evaluations += local;
  });
  // Small components (voxels within about half a voxel of the surface, cut off from their neighbours by the
  // distance rule): with winding numbers, a member takes the sign of a neighbour voxel of a decided large
  // component when no triangle lies on the segment between them (the grid's neighbour with the largest
  // distance first); else, and always with pseudo-normals (whose probe is one closest-point query), its own
  // probe. With sealed cavities (every wall voxel is a small component) a member in a cavity is inside at once;
  // another takes the exact sign, so it may copy a neighbour that is no cavity voxel (the flood reached it) under
  // the same rule: across a gap the sealed state changes where no triangle lies.
  auto decided = [&](int32_t g) {
    const int32_t c = comp[static_cast<size_t>(g)];
    return starts[c + 1] - starts[c] > static_cast<int32_t>(kSmallComponent) && !undecided[static_cast<size_t>(c)];
  };
  auto neighbour = [&](int32_t g, int a, int dir) -> int32_t {
    const auto li = static_cast<size_t>(g / S);
    const int32_t i = g % S;
    Coord local = LeafT::offsetToLocalCoord(static_cast<openvdb::Index>(i));
    local[a] += dir;
    if (local[a] >= 0 && local[a] < D) return static_cast<int32_t>(li * S) + static_cast<int32_t>(LeafT::coordToOffset(local));
    Coord no = leaves[li]->origin();
    no[a] += dir * D;
    const auto it = leaf_at.find(key(no));
    if (it == leaf_at.end() || leaves[static_cast<size_t>(it->second)]->origin() != no) return -1;
    local[a] = (local[a] + D) % D;
    return it->second * S + static_cast<int32_t>(LeafT::coordToOffset(local));
  };
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, nc, 64), [&](const auto& range) {
    long local = 0;
    for (int32_t c = range.begin(); c != range.end(); ++c) {
      const int32_t count = starts[c + 1] - starts[c];
      if (count > static_cast<int32_t>(kSmallComponent)) continue;
      for (int32_t k = starts[c]; k < starts[c + 1]; ++k) {
        const int32_t g = members[static_cast<size_t>(k)];
        const Vec3 p = position(g);
        if (sealed && sealed->contains(p, exact)) {
          inside_all[static_cast<size_t>(g)] = 1;
          continue;
        }
        int32_t from = -1;
        if (winding) {
          std::array<std::pair<float, int32_t>, 6> cand;
          int nc6 = 0;
          for (int a = 0; a < 3; ++a)
            for (int dir : {-1, 1}) {
              const int32_t j = neighbour(g, a, dir);
              // A large component's voxel is no wall: contains() reads its flood state.
              if (j >= 0 && decided(j) && !(sealed && sealed->contains(position(j), exact)))
                cand[static_cast<size_t>(nc6++)] = {-value(j), j};
            }
          // Insertion sort of at most 6 (std::sort here trips GCC 12's -Warray-bounds on its dead >16 branch).
          for (int q = 1; q < nc6; ++q)
            for (int r = q; r > 0 && cand[static_cast<size_t>(r)] < cand[static_cast<size_t>(r - 1)]; --r)
              std::swap(cand[static_cast<size_t>(r)], cand[static_cast<size_t>(r - 1)]);
          for (int q = 0; q < nc6 && from < 0; ++q)
            if (!exact.segment_may_cross(p, position(cand[static_cast<size_t>(q)].second)))
              from = cand[static_cast<size_t>(q)].second;
        }
        if (from >= 0) {
          inside_all[static_cast<size_t>(g)] = inside_all[static_cast<size_t>(from)];
        } else {
          inside_all[static_cast<size_t>(g)] = static_cast<char>(wn(p) > threshold);
          ++local;
        }
      }
    }
    evaluations += local;
  });
  std::vector<char> redo(nl, 0);
  for (int32_t c = 0; c < nc; ++c)
    if (undecided[static_cast<size_t>(c)])
      for (int32_t k = starts[c]; k < starts[c + 1]; ++k) redo[static_cast<size_t>(members[k] / S)] = 1;
  std::vector<int32_t> which;
  for (size_t li = 0; li < nl; ++li)
    if (redo[li]) which.push_back(static_cast<int32_t>(li));
  signs_per_leaf(leaves, which, band, wn, inside_all, evaluations);
}

/// Stage 4, beyond the band: the 8^3 blocks of the leaves' bounding box that hold no leaf. Blocks connected face to
/// face share a sign (the band separates inside from outside for closed surfaces); one probe set per component
/// (classify_components). Inside blocks become -background tiles. Returns the number of inside tiles.
long fill_inside_tiles(FloatTree& tree, const std::vector<LeafT*>& leaves, const BandGrid& g, const InsideMeasure& wn,
                       std::atomic<long>& evaluations) {
  constexpr int32_t D = LeafT::DIM;
  constexpr int32_t O = kGridIndexOffset;
  const double h = g.h, threshold = kInsideThreshold;
  const float background = g.background;
  long tiles = 0;
  openvdb::CoordBBox lb;
  for (const LeafT* leaf : leaves) lb.expand(leaf->origin());
  if (!leaves.empty()) {
    const Coord lo = lb.min(), hi = lb.max();
    const int32_t nx = (hi.x() - lo.x()) / D + 1, ny = (hi.y() - lo.y()) / D + 1, nz = (hi.z() - lo.z()) / D + 1;
    const auto nb = static_cast<size_t>(nx) * ny * nz;
    std::vector<char> has_leaf(nb, 0);
    auto block_index = [&](const Coord& o) {
      return (static_cast<size_t>((o.x() - lo.x()) / D) * ny + (o.y() - lo.y()) / D) * nz + (o.z() - lo.z()) / D;
    };
    for (const LeafT* leaf : leaves) has_leaf[block_index(leaf->origin())] = 1;
    std::vector<int32_t> empty_blocks;  // block index per item
    std::vector<int32_t> item_of(nb, -1);
    for (size_t b = 0; b < nb; ++b)
      if (!has_leaf[b]) {
        item_of[b] = static_cast<int32_t>(empty_blocks.size());
        empty_blocks.push_back(static_cast<int32_t>(b));
      }
    const auto n = static_cast<int32_t>(empty_blocks.size());
    UnionFind uf(static_cast<size_t>(n));
    for (int32_t bx = 0; bx < nx; ++bx)
      for (int32_t by = 0; by < ny; ++by)
        for (int32_t bz = 0; bz < nz; ++bz) {
          const size_t b = (static_cast<size_t>(bx) * ny + by) * nz + bz;
          if (has_leaf[b]) continue;
          if (bz + 1 < nz && !has_leaf[b + 1]) uf.unite(item_of[b], item_of[b + 1]);
          if (by + 1 < ny && !has_leaf[b + nz]) uf.unite(item_of[b], item_of[b + nz]);
          if (bx + 1 < nx && !has_leaf[b + static_cast<size_t>(ny) * nz])
            uf.unite(item_of[b], item_of[b + static_cast<size_t>(ny) * nz]);
        }
    std::vector<int32_t> first(static_cast<size_t>(n));
    for (int32_t i = 0; i < n; ++i) first[i] = uf.find(i);
    auto block_center = [&](int32_t i) {
      const int32_t b = empty_blocks[i];
      const int32_t bz = b % nz, by = (b / nz) % ny, bx = b / (nz * ny);
      return Vec3((lo.x() - O + bx * D + 0.5 * (D - 1)) * h, (lo.y() - O + by * D + 0.5 * (D - 1)) * h,
                  (lo.z() - O + bz * D + 0.5 * (D - 1)) * h);
    };
    std::vector<char> inside(static_cast<size_t>(n), 0);
    evaluations += classify_components(uf, n, first, block_center, wn, threshold, inside);
    for (int32_t i = 0; i < n; ++i) {
      if (!inside[i]) continue;
      const int32_t b = empty_blocks[i];
      const int32_t bz = b % nz, by = (b / nz) % ny, bx = b / (nz * ny);
      tree.addTile(1, Coord(lo.x() + bx * D, lo.y() + by * D, lo.z() + bz * D), -background, false);
      ++tiles;
    }
  }
  return tiles;
}

/// The sealed cavities of the unsigned band in `tree` (sdf/sealed.h): the box of its active voxels grown by one voxel
/// (so that the flood starts beyond the band), wall voxels where the band is within g.wall of the surface.
SealedCavities sealed_cavities(const FloatTree& tree, const BandGrid& g) {
  openvdb::CoordBBox bb;
  tree.evalActiveVoxelBoundingBox(bb);
  if (bb.empty()) return {};
  bb.expand(1);
  const Coord lo = bb.min(), dim = bb.dim();
  const auto ny = static_cast<size_t>(dim.y()), nz = static_cast<size_t>(dim.z());
  std::vector<uint8_t> wall(static_cast<size_t>(dim.x()) * ny * nz, 0);
  for (auto it = tree.cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue() || std::abs(*it) > g.wall) continue;
    const Coord c = it.getCoord() - lo;
    wall[(static_cast<size_t>(c.x()) * ny + static_cast<size_t>(c.y())) * nz + static_cast<size_t>(c.z())] = 1;
  }
  return SealedCavities(Eigen::Vector3i(lo.x(), lo.y(), lo.z()), Eigen::Vector3i(dim.x(), dim.y(), dim.z()),
                        kGridIndexOffset, g.h, std::move(wall));
}

/// Replace the random UUID OpenVDB writes into a file header with one derived from the content.
void make_uuid_deterministic(std::string& bytes) {
  // Header: int64 magic, uint32 file version, uint32 major, uint32 minor, char has_offsets, 36-char UUID.
  constexpr size_t kOffset = 8 + 4 + 4 + 4 + 1;
  if (bytes.size() < kOffset + 36) return;
  for (size_t dash : {8, 13, 18, 23})
    if (bytes[kOffset + dash] != '-') return;  // unknown layout: leave it alone
  // fnv1a_hex(rest) + fnv1a_hex(rest + "sdfkit"), without copying the bytes after the UUID.
  const uint64_t a = fnv1a(bytes.data() + kOffset + 36, bytes.size() - (kOffset + 36), kFnv1aHexStart);
  const uint64_t b = fnv1a("sdfkit", 6, a);
  char buf[33];
  std::snprintf(buf, sizeof buf, "%016llx%016llx", static_cast<unsigned long long>(a),
                static_cast<unsigned long long>(b));
  const std::string h = buf;
  std::string uuid = h.substr(0, 8) + "-" + h.substr(8, 4) + "-" + h.substr(12, 4) + "-" + h.substr(16, 4) + "-" +
                     h.substr(20, 12);
  bytes.replace(kOffset, 36, uuid);
}

}  // namespace

const char* sign_method_name(SignMethod m) {
  switch (m) {
    case SignMethod::kWindingNumber: return "winding_number";
    case SignMethod::kNone: return "none";
    case SignMethod::kPseudoNormal: return "pseudo_normal";
    case SignMethod::kAuto: return "auto";
  }
  return "auto";
}

SignMethod resolve_sign_method(const Mesh& mesh, SignMethod requested, double spacing) {
  if (requested != SignMethod::kAuto && requested != SignMethod::kPseudoNormal) return requested;
  if (!pseudo_normal_sign_applies(mesh)) return SignMethod::kWindingNumber;
  if (requested == SignMethod::kPseudoNormal) return requested;  // explicit: no agreement test
  return MeshQueries(mesh, requested, spacing).sign();
}

openvdb::Coord grid_index_offset(const FloatGrid& grid) {
  const double h = grid.voxelSize()[0];
  const openvdb::Vec3d t = grid.transform().indexToWorld(openvdb::Vec3d(0, 0, 0));
  return Coord(static_cast<int32_t>(std::lround(-t.x() / h)), static_cast<int32_t>(std::lround(-t.y() / h)),
               static_cast<int32_t>(std::lround(-t.z() / h)));
}

SparseSdf sparse_sdf_from_grid(FloatGrid::Ptr grid, std::shared_ptr<const SealedCavities> sealed) {
  require(grid != nullptr, "sparse SDF: null grid");
  require(grid->hasUniformVoxels(), "sparse SDF: the grid's voxels are not uniform");
  auto impl = std::make_shared<SparseSdf::Impl>();
  impl->grid = std::move(grid);
  impl->sealed = std::move(sealed);
  return SparseSdf(std::shared_ptr<const SparseSdf::Impl>(impl));
}

SparseSdf::SparseSdf() {
  ensure_openvdb_initialized();
  auto impl = std::make_shared<Impl>();
  impl->grid = FloatGrid::create(1.0f);
  impl->grid->setName("sdf");
  impl->grid->setGridClass(openvdb::GRID_LEVEL_SET);
  impl_ = impl;
}

SparseSdf SparseSdf::from_mesh(const Mesh& input, const SparseSdfSettings& s, SparseSdfStats* stats,
                               const ProgressFn& progress_fn) {
  ensure_openvdb_initialized();
  require(!input.empty(), "sparse SDF: empty mesh");
  require(input.V.allFinite(), "sparse SDF: non-finite vertex coordinates");
  require(s.voxel_size > 0 && std::isfinite(s.voxel_size), "sparse SDF: voxel size must be positive");
  require(s.band == 0 || (s.band >= s.voxel_size && std::isfinite(s.band)),
          "sparse SDF: band must be 0 (3 voxels) or at least one voxel wide");
  const auto t0 = std::chrono::steady_clock::now();
  Mesh mesh = input;
  long flipped = 0;
  if (s.orient_faces && s.sign != SignMethod::kNone) {
    OrientationReport orep;
    mesh = orient_consistently(input, &orep);
    flipped = orep.flipped_faces;
  }
  const MeshQueries queries(mesh, s.sign, s.voxel_size, s.winding_beta);
  const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  SparseSdf out = from_mesh(queries, s, stats, progress_fn);
  if (stats) {
    stats->flipped_faces = flipped;
    stats->seconds_setup += setup;
  }
  return out;
}

SparseSdf SparseSdf::from_mesh(const MeshQueries& queries, const SparseSdfSettings& s, SparseSdfStats* stats,
                               const ProgressFn& progress_fn) {
  ensure_openvdb_initialized();
  require(s.voxel_size > 0 && std::isfinite(s.voxel_size), "sparse SDF: voxel size must be positive");
  require(s.band == 0 || (s.band >= s.voxel_size && std::isfinite(s.band)),
          "sparse SDF: band must be 0 (3 voxels) or at least one voxel wide");
  const Progress progress{progress_fn};
  SparseSdfStats st;
  auto clock = std::chrono::steady_clock::now();
  auto lap = [&clock](double& out) {
    const auto now = std::chrono::steady_clock::now();
    out += std::chrono::duration<double>(now - clock).count();
    clock = now;
  };
  const Mesh& mesh = queries.mesh();
  const SignMethod method = queries.sign();
  st.sign = method;
  lap(st.seconds_setup);
  progress(0.05);

  BandGrid g;
  g.h = s.voxel_size;
  g.width = s.band > 0 ? std::ceil(s.band / g.h) * g.h : 3.0 * g.h;
  g.background = static_cast<float>(g.width);
  const auto xform = openvdb::math::Transform::createLinearTransform(g.h);
  constexpr int32_t O = kGridIndexOffset;  // index i sits at (i - O) * h
  xform->postTranslate(openvdb::Vec3d(-O * g.h, -O * g.h, -O * g.h));
  FloatGrid::Ptr grid = FloatGrid::create(g.background);
  grid->setTransform(xform);
  grid->setName("sdf");
  FloatTree& tree = grid->tree();
  const MeshDistance& exact = queries.distance();
  require(!s.seal || method != SignMethod::kNone, "sparse SDF: sealing cavities needs a sign method (not none)");

  // 1. The exact unsigned band.
  std::vector<std::unique_ptr<LeafT>> built = exact_band_leaves(mesh, exact, g);
  lap(st.seconds_topology);
  for (auto& leaf : built)
    if (leaf) tree.addLeaf(leaf.release());
  lap(st.seconds_exact);
  progress(0.5);

  std::shared_ptr<const SealedCavities> sealed;
  if (s.seal) {
    g.wall = static_cast<float>(SealedCavities::kWallWidth * g.h);
    sealed = std::make_shared<const SealedCavities>(sealed_cavities(tree, g));
    st.sealed_voxels = sealed->sealed_voxels();
  }
  if (method != SignMethod::kNone) {
    // Inside measure: the winding number, or 1/0 from the pseudo-normal at the closest feature (closed meshes); with
    // `seal`, 1 in the sealed cavities.
    const PseudoNormals* normals = queries.pseudo_normals();
    const WindingNumber* winding = normals ? nullptr : &queries.winding();
    const InsideMeasure wn = [&](const Vec3& p) -> double {
      if (sealed && sealed->contains(p, exact)) return 1.0;
      if (winding) return (*winding)(p);
      const ClosestPoint cp = exact.closest(p);
      return cp.face >= 0 && normals->inside(p, cp) ? 1.0 : 0.0;
    };
    std::vector<LeafT*> leaves;
    leaves.reserve(tree.leafCount());
    tree.getNodes(leaves);
    std::atomic<long> evaluations{0};
    constexpr auto S = static_cast<size_t>(LeafT::SIZE);
    std::vector<char> inside_all(leaves.size() * S, 0);
    // 2. The band's signs. Open meshes (boundary edges): w is not an integer off the surface and may cross 0.5
    //    anywhere, so every leaf is decided on its own.
    if (!queries.boundary_free()) {
      std::vector<int32_t> all(leaves.size());
      std::iota(all.begin(), all.end(), 0);
      signs_per_leaf(leaves, all, g, wn, inside_all, evaluations);
    } else {
      signs_by_band_components(leaves, g, wn, exact, winding != nullptr, sealed.get(), inside_all, evaluations);
    }
    // 3. Signs applied.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size(), 16), [&](const auto& range) {
      for (size_t li = range.begin(); li != range.end(); ++li) {
        float* out = leaves[li]->buffer().data();
        for (size_t i = 0; i < S; ++i)
          if (inside_all[li * S + i]) out[i] = -out[i];
      }
    });
    st.band_voxels = static_cast<long>(tree.activeVoxelCount());
    progress(0.8);
    // 4. Inside tiles beyond the band.
    st.inside_tiles = fill_inside_tiles(tree, leaves, g, wn, evaluations);
    st.winding_evaluations = evaluations;
    openvdb::tools::pruneLevelSet(tree);
  }
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  lap(st.seconds_sign);
  progress(1.0);
  if (stats) *stats = st;
  return sparse_sdf_from_grid(grid, std::move(sealed));
}

double SparseSdf::value(const Vec3& p) const {
  const FloatGrid& g = *impl_->grid;
  const openvdb::Vec3d ip = g.transform().worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z()));
  auto acc = g.getConstAccessor();
  return openvdb::tools::BoxSampler::sample(acc, ip);
}

Eigen::VectorXd SparseSdf::values(const Points& P) const {
  Eigen::VectorXd out(P.rows());
  const FloatGrid& g = *impl_->grid;
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows(), 1024), [&](const auto& r) {
    auto acc = g.getConstAccessor();
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
      const openvdb::Vec3d ip = g.transform().worldToIndex(openvdb::Vec3d(P(i, 0), P(i, 1), P(i, 2)));
      out[i] = openvdb::tools::BoxSampler::sample(acc, ip);
    }
  });
  return out;
}

double SparseSdf::voxel(int i, int j, int k) const {
  return impl_->grid->tree().getValue(Coord(i, j, k) + grid_index_offset(*impl_->grid));
}
double SparseSdf::voxel_size() const { return impl_->grid->voxelSize()[0]; }
double SparseSdf::background() const { return impl_->grid->background(); }
long SparseSdf::active_voxel_count() const { return static_cast<long>(impl_->grid->activeVoxelCount()); }
size_t SparseSdf::memory_bytes() const { return static_cast<size_t>(impl_->grid->memUsage()); }

const SealedCavities* SparseSdf::sealed() const { return impl_->sealed.get(); }

Box3 SparseSdf::active_index_bounds() const {
  Box3 b;
  if (impl_->grid->activeVoxelCount() == 0) return b;
  const openvdb::CoordBBox bb = impl_->grid->evalActiveVoxelBoundingBox();
  const Coord o = grid_index_offset(*impl_->grid);
  b.lo = Vec3(bb.min().x() - o.x(), bb.min().y() - o.y(), bb.min().z() - o.z());
  b.hi = Vec3(bb.max().x() - o.x(), bb.max().y() - o.y(), bb.max().z() - o.z());
  return b;
}

void SparseSdf::write(const std::string& path) const {
  ensure_openvdb_initialized();
  // OpenVDB writes through its own file object; write a private temporary, then move the (UUID-fixed) bytes
  // into place atomically.
  const std::string tmp = path + ".vdbtmp." + std::to_string(::getpid());
  try {
    std::filesystem::path parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    openvdb::io::File file(tmp);
    // A shallow copy (shares the tree) so that naming it does not touch this grid.
    openvdb::GridPtrVec grids{impl_->grid->copyGrid()};
    grids[0]->setName("sdf");
    file.write(grids);
    file.close();
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw IoError(path + ": cannot write VDB: " + e.what());
  }
  std::string bytes = read_file(tmp);
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
  make_uuid_deterministic(bytes);
  write_file_atomic(path, [&](std::ostream& o) { o.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

SparseSdf SparseSdf::read(const std::string& path) {
  ensure_openvdb_initialized();
  if (!std::filesystem::is_regular_file(path)) throw IoError(path + ": no such file");
  try {
    openvdb::io::File file(path);
    file.open();
    openvdb::GridBase::Ptr base;
    for (auto it = file.beginName(); it != file.endName(); ++it)
      if (it.gridName() == "sdf") base = file.readGrid("sdf");
    if (!base) {
      openvdb::GridPtrVecPtr all = file.getGrids();
      for (auto& g : *all)
        if (g->isType<FloatGrid>()) {
          if (base) throw IoError(path + ": no grid named \"sdf\" and more than one FloatGrid");
          base = g;
        }
    }
    file.close();
    auto grid = openvdb::gridPtrCast<FloatGrid>(base);
    if (!grid) throw IoError(path + ": no FloatGrid named \"sdf\"");
    return sparse_sdf_from_grid(grid);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw IoError(path + ": cannot read VDB: " + e.what());
  }
}

}  // namespace sdfkit
