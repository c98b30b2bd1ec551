#include "sdf/samples.h"

#include "core/error.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/mesh_queries.h"
#include "sdf/pseudonormal.h"
#include "sdf/sealed.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

namespace sdfkit {
namespace {

struct Candidate {
  Eigen::Vector3f p;
  float sdf;
};

/// A drawn candidate waiting for its exact query.
struct Pending {
  Eigen::Vector3f p;
  int32_t face;    ///< hint: closest face of the cell's coarse centre
  uint64_t key;    ///< Morton code of the cell (query order)
  double value;    ///< before the query: an upper bound of the distance; after: the exact signed distance (NaN:
                   ///< beyond the bins' reach)
};

/// Morton (Z-order) code of a voxel at 2-voxel resolution, 10 bits per axis: nearby cells get nearby codes.
uint64_t morton_key(const openvdb::Coord& c) {
  auto spread = [](uint64_t v) {  // 10 bits -> every third bit
    v &= 0x3ff;
    v = (v | (v << 16)) & 0x30000ff;
    v = (v | (v << 8)) & 0x300f00f;
    v = (v | (v << 4)) & 0x30c30c3;
    v = (v | (v << 2)) & 0x9249249;
    return v;
  };
  return (spread(static_cast<uint64_t>(c.x() >> 1)) << 2) | (spread(static_cast<uint64_t>(c.y() >> 1)) << 1) |
         spread(static_cast<uint64_t>(c.z() >> 1));
}

/// Exact signed distance of a point: exact unsigned distance (BVH); the sign from the pseudo-normal at the
/// closest feature (closed meshes), or else from the nearest voxel of the grid when the point is too far from the
/// surface for a crossing in between, else from the winding number. With the grid's sealed cavities, points in
/// them are inside whatever the exact sign says (and the grid's signs already include them).
struct ExactSigned {
  const MeshDistance& dist;
  const WindingNumber* wn;      ///< null when `normals` decide
  const PseudoNormals* normals;
  const SealedCavities* sealed;  ///< null unless the grid was sealed
  const openvdb::FloatGrid& grid;
  double h;
  openvdb::Coord offset;  ///< grid_index_offset
  bool boundary_free;     ///< closed parts only: a segment free of triangles certifies the voxel's sign

  /// NaN when the point is farther than `bound` from the mesh.
  template <typename Accessor>
  double operator()(const Vec3& p, Accessor& acc, double bound = 1e300, int32_t hint = -1) const {
    const ClosestPoint cp = dist.closest(p, bound, hint);
    if (cp.face < 0) return std::numeric_limits<double>::quiet_NaN();
    const double u = cp.distance;
    if (normals) return normals->inside(p, cp) || (sealed && sealed->contains(p, dist)) ? -u : u;
    const openvdb::Coord c(static_cast<int>(std::lround(p.x() / h)) + offset.x(),
                           static_cast<int>(std::lround(p.y() / h)) + offset.y(),
                           static_cast<int>(std::lround(p.z() / h)) + offset.z());
    const float v = acc.getValue(c);
    if (v != 0.f) {
      // No surface between p and its nearest voxel: when the ball of radius u around p holds the voxel, or
      // when no triangle touches the segment between them (one BVH segment query instead of a winding number).
      if (u > 0.9 * h) return v < 0 ? -u : u;
      const Vec3 x((c.x() - offset.x()) * h, (c.y() - offset.y()) * h, (c.z() - offset.z()) * h);
      if (boundary_free && !dist.segment_may_cross(p, x)) return v < 0 ? -u : u;
    }
    if (sealed && sealed->contains(p, dist)) return -u;
    return (*wn)(p) > 0.5 ? -u : u;
  }
};

/// A box of `size`^3 voxel cells with its lowest voxel at `origin` (index space): it spans
/// [origin - 0.5, origin + size - 0.5] voxels on each axis.
struct Cell {
  openvdb::Coord origin;
  int32_t size;
  int32_t face;  ///< closest face of the enclosing coarse cell's centre (a hint for exact queries)
  Eigen::Vector3f centre;  ///< centre of the enclosing coarse cell (object units)
  float centre_u;          ///< exact unsigned distance at `centre` (bounds the cell's distances: 1-Lipschitz)
};

constexpr int32_t kCoarse = 4;  ///< coarse cell: 4^3 voxels (exact distance at its centre)
constexpr int32_t kFine = 2;    ///< near-surface sub-cell: 2^3 voxels (bounds from the grid's voxel values)
constexpr int32_t kRoot = 32;   ///< root blocks of the hierarchy

/// Cells that can hold points of each bin: a hierarchy of exact distances at block centres prunes space farther
/// than the bins reach; coarse cells crossed by no surface take one sign; cells the surface may cross are split
/// into 2^3-voxel sub-cells bounded by the grid's exact band values (and signed values beyond the band). The lists
/// cover every point of each bin (distance is 1-Lipschitz), in a deterministic order.
std::array<std::vector<Cell>, 4> candidate_cells(const Mesh& mesh, const MeshDistance& dist,
                                                 const openvdb::FloatGrid& grid, double h,
                                                 const std::array<double, 5>& lo_hi_edges, double offset) {
  std::array<double, 4> lo{}, hi{};
  for (int b = 0; b < 4; ++b) {
    lo[b] = lo_hi_edges[b] + offset;
    hi[b] = lo_hi_edges[b + 1] + offset;
  }
  const double reach = std::max(std::abs(lo[0]), std::abs(hi[3])) + 1e-6;
  const double slack = 1e-3 * h;  // float rounding of the grid values
  Box3 box;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) box.extend(mesh.V.row(i).transpose());
  const openvdb::Coord off = grid_index_offset(grid);  // index i sits at (i - off) * h
  const Vec3 offv(off.x(), off.y(), off.z());
  const auto to_index_lo = [&](double x, int a) {
    return static_cast<int32_t>(std::floor((x - reach) / h)) - 1 + off[a];
  };
  const auto to_index_hi = [&](double x, int a) {
    return static_cast<int32_t>(std::ceil((x + reach) / h)) + 1 + off[a];
  };
  auto floor_div = [](int32_t a, int32_t d) { return a >= 0 ? a / d : -((-a + d - 1) / d); };
  openvdb::Coord rlo, rhi;
  for (int a = 0; a < 3; ++a) {
    rlo[a] = floor_div(to_index_lo(box.lo[a], a), kRoot);
    rhi[a] = floor_div(to_index_hi(box.hi[a], a), kRoot);
  }
  std::vector<openvdb::Coord> roots;
  for (int32_t x = rlo.x(); x <= rhi.x(); ++x)
    for (int32_t y = rlo.y(); y <= rhi.y(); ++y)
      for (int32_t z = rlo.z(); z <= rhi.z(); ++z) roots.emplace_back(x * kRoot, y * kRoot, z * kRoot);

  std::vector<std::array<std::vector<Cell>, 4>> per_root(roots.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, roots.size(), 1), [&](const auto& range) {
    auto acc = grid.getConstAccessor();
    const double half_voxel_diag = 0.8661 * h;
    auto add = [&](std::array<std::vector<Cell>, 4>& out, const Cell& c, double a, double b) {
      for (int k = 0; k < 4; ++k)
        if (b + slack >= lo[k] && a - slack <= hi[k]) out[k].push_back(c);
    };
    std::function<void(std::array<std::vector<Cell>, 4>&, const openvdb::Coord&, int32_t, int32_t)> visit =
        [&](std::array<std::vector<Cell>, 4>& out, const openvdb::Coord& o, int32_t size, int32_t hint) {
          const Vec3 centre = (Vec3(o.x(), o.y(), o.z()) - offv + Vec3::Constant(0.5 * (size - 1))) * h;
          const double r = 0.8661 * size * h;
          const ClosestPoint cp = dist.closest(centre, reach + r, hint);
          if (cp.face < 0) return;  // the whole block is farther than every bin
          if (size > kCoarse) {
            const int32_t half = size / 2;
            for (int c = 0; c < 8; ++c)
              visit(out, o.offsetBy(c & 4 ? half : 0, c & 2 ? half : 0, c & 1 ? half : 0), half, cp.face);
            return;
          }
          const double d = cp.distance;
          const Eigen::Vector3f cf = centre.cast<float>();
          const auto cu = static_cast<float>(d);
          if (d > r) {  // no surface inside: one sign, that of any of its voxels
            const float g = acc.getValue(o);
            const double s = g < 0 ? -1.0 : 1.0;
            add(out, {o, size, cp.face, cf, cu}, s > 0 ? d - r : -(d + r), s > 0 ? d + r : -(d - r));
            return;
          }
          for (int32_t x = 0; x < size; x += kFine)
            for (int32_t y = 0; y < size; y += kFine)
              for (int32_t z = 0; z < size; z += kFine) {
                const openvdb::Coord so = o.offsetBy(x, y, z);
                // Every point of the sub-cell is within half a voxel diagonal of one of its 8 voxels.
                double umin = 1e300, umax = 0;
                bool pos = false, neg = false, near = false;
                for (int c = 0; c < 8; ++c) {
                  const openvdb::Coord v = so.offsetBy(c & 4 ? 1 : 0, c & 2 ? 1 : 0, c & 1 ? 1 : 0);
                  const float g = acc.getValue(v);
                  const bool active = acc.isValueOn(v);
                  // Beyond the band (inactive): farther than the band's width, at least one voxel.
                  const double u = active ? std::abs(static_cast<double>(g)) : h;
                  umin = std::min(umin, u);
                  umax = std::max(umax, active ? u : d + r);
                  (g < 0 ? neg : pos) = true;
                  near = near || u <= half_voxel_diag + slack;
                }
                const double a = std::max(0.0, umin - half_voxel_diag), b = std::min(umax + half_voxel_diag, d + r);
                const Cell cell{so, kFine, cp.face, cf, cu};
                if (near || (pos && neg)) add(out, cell, -b, b);
                else if (pos) add(out, cell, a, b);
                else add(out, cell, -b, -a);
              }
        };
    for (size_t i = range.begin(); i != range.end(); ++i) visit(per_root[i], roots[i], kRoot, -1);
  });
  std::array<std::vector<Cell>, 4> cells;
  for (auto& r : per_root)
    for (int b = 0; b < 4; ++b) cells[b].insert(cells[b].end(), r[b].begin(), r[b].end());
  return cells;
}

}  // namespace

MatrixXfR disn_samples(const Mesh& mesh, const SparseSdf& sdf, const SampleSettings& s, SampleReport* report) {
  require(!mesh.empty(), "samples: empty mesh");
  return disn_samples(MeshQueries(mesh, s.sign, sdf.voxel_size(), s.winding_beta), sdf, s, report);
}

MatrixXfR disn_samples(const MeshQueries& queries, const SparseSdf& sdf, const SampleSettings& s,
                       SampleReport* report) {
  require(s.count >= 0, "samples: count must be >= 0");
  require(s.uniform_share >= 0 && s.uniform_share <= 1, "samples: uniform share must be in [0, 1]");
  for (int b = 0; b < 4; ++b) require(s.edges[b] < s.edges[b + 1], "samples: bin edges must increase");
  const Mesh& mesh = queries.mesh();
  require(!mesh.empty(), "samples: empty mesh");
  const openvdb::FloatGrid& grid = *vdb_grid(sdf);
  const double h = sdf.voxel_size();
  const double reach = std::max(std::abs(s.edges[0] + s.offset), std::abs(s.edges[4] + s.offset));

  const MeshDistance& dist = queries.distance();
  const SignMethod method = queries.sign();
  const PseudoNormals* normals = queries.pseudo_normals();
  const WindingNumber* wn = normals ? nullptr : &queries.winding();
  const SealedCavities* sealed = sdf.sealed();
  const ExactSigned exact{dist, wn, normals, sealed, grid, h, grid_index_offset(grid), queries.boundary_free()};
  const openvdb::Coord off = exact.offset;

  SampleReport rep;
  rep.sign = method;
  rep.uniform_count = std::lround(static_cast<double>(s.count) * s.uniform_share);
  const long binned = s.count - rep.uniform_count;
  for (int b = 0; b < 4; ++b) rep.bin_quota[b] = binned / 4 + (b < binned % 4 ? 1 : 0);

  const std::array<std::vector<Cell>, 4> cells = candidate_cells(mesh, dist, grid, h, s.edges, s.offset);
  // Cells are drawn with probability proportional to their volume (size^3 voxels): uniform over space.
  std::array<std::vector<int64_t>, 4> cum;
  for (int b = 0; b < 4; ++b) {
    int64_t total = 0;
    cum[b].reserve(cells[b].size());
    for (const Cell& c : cells[b]) cum[b].push_back(total += static_cast<int64_t>(c.size) * c.size * c.size);
  }

  std::array<std::vector<Candidate>, 4> accepted;
  std::array<long, 4> want = rep.bin_quota;
  std::array<long, 4> tried{}, evaluated{};
  std::array<uint64_t, 4> next_batch{};
  std::array<bool, 4> exhausted{};
  constexpr int kChunk = 256, kChunks = 32;
  // Candidates whose distance is known from the grid to miss the bin are dropped before the exact query. The
  // unsigned distance is 1-Lipschitz: each of the 8 lattice voxels around p bounds it by its stored |value|
  // (exact in the band, at least the band's width beyond it) +- its distance to p. The sign is that of the
  // nearest voxel when p is farther from that voxel than the surface can be: for pseudo-normal signs when p
  // lies in the surface-free ball around the voxel; for winding-number signs when ExactSigned itself takes the
  // voxel's sign (u > 0.9 voxel), and with sealed cavities (where the sealed state may change across a gap
  // without a surface) by the same margin. Dropping only skips queries: every stored sample is still exact.
  const double slack = 1e-3 * h;
  const double sign_margin = normals && !sealed ? 0.0 : 0.9 * h;
  // `bound` receives an upper bound of p's distance (the exact query then prunes the BVH from the start).
  auto may_fall_in = [&](const Vec3& p, const Cell& cell, auto& acc, double lo, double hi, double& bound) {
    const Vec3 ip = p / h + Vec3(off.x(), off.y(), off.z());
    const openvdb::Coord base(static_cast<int32_t>(std::floor(ip.x())), static_cast<int32_t>(std::floor(ip.y())),
                              static_cast<int32_t>(std::floor(ip.z())));
    double ulo = 0, uhi = 1e300, nearest_r = 1e300, nearest_g = 0;
    for (int c = 0; c < 8; ++c) {
      const openvdb::Coord v = base.offsetBy(c & 4 ? 1 : 0, c & 2 ? 1 : 0, c & 1 ? 1 : 0);
      float g = 0;
      const bool active = acc.probeValue(v, g);
      const double r = h * (ip - Vec3(v.x(), v.y(), v.z())).norm();
      const double u = std::abs(static_cast<double>(g));
      ulo = std::max(ulo, u - r);
      if (active) uhi = std::min(uhi, u + r);
      if (r < nearest_r) nearest_r = r, nearest_g = g;
    }
    const double rc = (p - cell.centre.cast<double>()).norm();
    ulo = std::max(ulo, cell.centre_u - rc);
    uhi = std::min(uhi, cell.centre_u + rc);
    ulo = std::max(0.0, ulo - slack);
    uhi += slack;
    bound = uhi;
    const auto overlaps = [&](double a, double b) { return b >= lo && a <= hi; };
    if (std::abs(nearest_g) - nearest_r > sign_margin + slack)
      return nearest_g < 0 ? overlaps(-uhi, -ulo) : overlaps(ulo, uhi);
    return overlaps(-uhi, -ulo) || overlaps(ulo, uhi);
  };

  auto fill_bin = [&](int b) {
    const long cap = s.max_candidates_per_bin > 0 ? s.max_candidates_per_bin : 64 * std::max(want[b], 1024L);
    if (cells[b].empty()) exhausted[b] = true;
    while (!exhausted[b] && static_cast<long>(accepted[b].size()) < want[b]) {
      // Batch size: a full batch first, then what the bin's acceptance so far says is still needed (+10%), so
      // that the last batch does not overshoot by thousands of exact queries. Deterministic (counts only).
      int per_chunk = kChunk;
      const long missing = want[b] - static_cast<long>(accepted[b].size());
      if (tried[b] > 0 && !accepted[b].empty()) {
        const double rate = static_cast<double>(accepted[b].size()) / static_cast<double>(tried[b]);
        const double need = 1.1 * static_cast<double>(missing) / rate / kChunks + 1.0;
        per_chunk = static_cast<int>(std::clamp(std::ceil(need), 4.0, static_cast<double>(kChunk)));
      }
      // Draw and pre-filter the batch's candidates (per chunk, in order), then run the exact queries in the
      // spatial (Morton) order of the points so that consecutive queries walk the same BVH nodes and triangles,
      // then keep the accepted ones in the drawing order: the samples do not depend on the query order.
      std::vector<std::vector<Pending>> chunk_pending(kChunks);
      const uint64_t batch = next_batch[b]++;
      const double lo = s.edges[b] + s.offset, hi = s.edges[b + 1] + s.offset;
      tbb::parallel_for(0, kChunks, [&](int c) {
        Rng rng = Rng::derived(s.seed, (static_cast<uint64_t>(b + 1) << 48) + batch * kChunks + c);
        auto acc = grid.getConstAccessor();
        auto& out = chunk_pending[static_cast<size_t>(c)];
        for (int k = 0; k < per_chunk; ++k) {
          const auto pick = static_cast<int64_t>(rng.below(static_cast<uint64_t>(cum[b].back())));
          const auto ci = static_cast<int32_t>(std::upper_bound(cum[b].begin(), cum[b].end(), pick) - cum[b].begin());
          const Cell& cell = cells[b][static_cast<size_t>(ci)];
          const double side = cell.size;
          const Eigen::Vector3f pf(
              static_cast<float>((cell.origin.x() - off.x() - 0.5 + side * rng.uniform()) * h),
              static_cast<float>((cell.origin.y() - off.y() - 0.5 + side * rng.uniform()) * h),
              static_cast<float>((cell.origin.z() - off.z() - 0.5 + side * rng.uniform()) * h));
          double bound = 0;
          if (!may_fall_in(pf.cast<double>(), cell, acc, lo, hi, bound)) continue;
          out.push_back({pf, cell.face, morton_key(cell.origin), std::min(bound, reach * 1.001 + 1e-9)});
        }
      });
      std::vector<Pending> pending;
      for (auto& cp : chunk_pending) pending.insert(pending.end(), cp.begin(), cp.end());
      chunk_pending.clear();
      std::vector<uint64_t> order(pending.size());  // (Morton key of the cell, drawing index): a total order
      for (size_t i = 0; i < pending.size(); ++i) order[i] = (pending[i].key << 20) | i;
      std::sort(order.begin(), order.end());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 64), [&](const auto& r) {
        auto acc = grid.getConstAccessor();
        for (size_t k = r.begin(); k != r.end(); ++k) {
          Pending& q = pending[static_cast<size_t>(order[k] & ((uint64_t{1} << 20) - 1))];
          q.value = exact(q.p.cast<double>(), acc, q.value, q.face);
        }
      });
      evaluated[b] += static_cast<long>(pending.size());
      for (const Pending& q : pending) {
        const double v = q.value;
        if (!std::isfinite(v)) continue;
        const bool last = b == 3;
        if (v >= lo && (v < hi || (last && v <= hi)) && static_cast<long>(accepted[b].size()) < want[b])
          accepted[b].push_back({q.p, static_cast<float>(v)});
      }
      tried[b] += static_cast<long>(per_chunk) * kChunks;
      if (tried[b] >= cap && static_cast<long>(accepted[b].size()) < want[b]) exhausted[b] = true;
    }
  };
  for (int b = 0; b < 4; ++b) fill_bin(b);
  // Shortfalls move to the nearest bin that can still produce samples, until all are placed or none can.
  for (int round = 0; round < 8; ++round) {
    bool moved = false;
    for (int b = 0; b < 4; ++b) {
      const long missing = want[b] - static_cast<long>(accepted[b].size());
      if (missing <= 0 || !exhausted[b]) continue;
      int target = -1;
      for (int dist_b = 1; dist_b < 4 && target < 0; ++dist_b)
        for (int t : {b - dist_b, b + dist_b})
          if (t >= 0 && t < 4 && !exhausted[t] && target < 0) target = t;
      if (target < 0) continue;
      want[b] -= missing;
      want[target] += missing;
      rep.redistributed += missing;
      fill_bin(target);
      moved = true;
    }
    if (!moved) break;
  }

  // Uniform far-field share.
  std::vector<Candidate> uniform(static_cast<size_t>(rep.uniform_count));
  tbb::parallel_for(tbb::blocked_range<long>(0, rep.uniform_count, 256), [&](const auto& r) {
    auto acc = grid.getConstAccessor();
    for (long i = r.begin(); i != r.end(); ++i) {
      Rng rng = Rng::derived(s.seed ^ 0x756e69666f726dULL, static_cast<uint64_t>(i));
      const Eigen::Vector3f pf(static_cast<float>(rng.uniform(-s.box, s.box)),
                               static_cast<float>(rng.uniform(-s.box, s.box)),
                               static_cast<float>(rng.uniform(-s.box, s.box)));
      uniform[static_cast<size_t>(i)] = {pf, static_cast<float>(exact(pf.cast<double>(), acc))};
    }
  });

  long total = rep.uniform_count;
  for (int b = 0; b < 4; ++b) {
    rep.bin_counts[b] = static_cast<long>(accepted[b].size());
    total += rep.bin_counts[b];
    rep.candidates += evaluated[b];
  }
  MatrixXfR out(total, 4);
  Eigen::Index row = 0;
  auto put = [&](const Candidate& c) {
    out.row(row++) << c.p.x(), c.p.y(), c.p.z(), c.sdf;
  };
  for (int b = 0; b < 4; ++b)
    for (const Candidate& c : accepted[b]) put(c);
  for (const Candidate& c : uniform) put(c);
  if (report) *report = rep;
  return out;
}

}  // namespace sdfkit
