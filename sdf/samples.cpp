#include "sdf/samples.h"

#include "core/error.h"
#include "core/random.h"
#include "sdf/distance.h"
#include "sdf/sparse_sdf_vdb.h"
#include "sdf/winding.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace sdfkit {
namespace {

struct Candidate {
  Eigen::Vector3f p;
  float sdf;
};

/// Exact signed distance of a point: exact unsigned distance; the sign of the nearest voxel when the point is
/// too far from the surface for a crossing in between, else the winding number.
struct ExactSigned {
  const MeshDistance& dist;
  const WindingNumber& wn;
  const openvdb::FloatGrid& grid;
  double h;
  long* winding_calls = nullptr;

  template <typename Accessor>
  double operator()(const Vec3& p, Accessor& acc, bool& used_winding) const {
    const double u = dist.closest(p).distance;
    used_winding = false;
    if (u > 0.9 * h) {
      const openvdb::Coord c(static_cast<int>(std::lround(p.x() / h)), static_cast<int>(std::lround(p.y() / h)),
                             static_cast<int>(std::lround(p.z() / h)));
      const float v = acc.getValue(c);
      if (v != 0.f) return v < 0 ? -u : u;
    }
    used_winding = true;
    return wn(p) > 0.5 ? -u : u;
  }
};

}  // namespace

MatrixXfR disn_samples(const Mesh& mesh, const SparseSdf& sdf, const SampleSettings& s, SampleReport* report) {
  require(s.count >= 0, "samples: count must be >= 0");
  require(s.uniform_share >= 0 && s.uniform_share <= 1, "samples: uniform share must be in [0, 1]");
  for (int b = 0; b < 4; ++b) require(s.edges[b] < s.edges[b + 1], "samples: bin edges must increase");
  require(!mesh.empty(), "samples: empty mesh");
  const openvdb::FloatGrid& grid = *vdb_grid(sdf);
  const double h = sdf.voxel_size();
  const double reach = std::max(std::abs(s.edges[0] + s.offset), std::abs(s.edges[4] + s.offset)) + 1.1 * h;
  require(sdf.background() >= reach,
          "samples: the grid's band (" + std::to_string(sdf.background()) + ") is too narrow for the bins (needs " +
              std::to_string(reach) + ")");

  const MeshDistance dist(mesh);
  const WindingNumber wn(mesh, s.winding_beta);
  const ExactSigned exact{dist, wn, grid, h};

  SampleReport rep;
  rep.uniform_count = std::lround(static_cast<double>(s.count) * s.uniform_share);
  const long binned = s.count - rep.uniform_count;
  for (int b = 0; b < 4; ++b) rep.bin_quota[b] = binned / 4 + (b < binned % 4 ? 1 : 0);

  // Candidate cells per bin: band voxels whose value can be within the bin once moved by up to half a cell
  // diagonal (plus slack for the grid's float rounding).
  const double tol = 0.8661 * h + 0.05 * h;
  std::array<std::vector<openvdb::Coord>, 4> cells;
  for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf)
    for (auto it = leaf->cbeginValueOn(); it; ++it) {
      const double v = *it;
      for (int b = 0; b < 4; ++b)
        if (v >= s.edges[b] + s.offset - tol && v <= s.edges[b + 1] + s.offset + tol) cells[b].push_back(it.getCoord());
    }

  std::array<std::vector<Candidate>, 4> accepted;
  std::array<long, 4> want = rep.bin_quota;
  std::array<long, 4> tried{};
  std::array<uint64_t, 4> next_batch{};
  std::array<bool, 4> exhausted{};
  constexpr int kChunk = 256, kChunks = 32;
  long winding_calls = 0;

  auto fill_bin = [&](int b) {
    const long cap = s.max_candidates_per_bin > 0 ? s.max_candidates_per_bin : 64 * std::max(want[b], 1024L);
    if (cells[b].empty()) exhausted[b] = true;
    while (!exhausted[b] && static_cast<long>(accepted[b].size()) < want[b]) {
      std::vector<std::vector<Candidate>> chunk_out(kChunks);
      std::vector<long> chunk_winding(kChunks, 0);
      const uint64_t batch = next_batch[b]++;
      tbb::parallel_for(0, kChunks, [&](int c) {
        Rng rng = Rng::derived(s.seed, (static_cast<uint64_t>(b + 1) << 48) + batch * kChunks + c);
        auto acc = grid.getConstAccessor();
        const double lo = s.edges[b] + s.offset, hi = s.edges[b + 1] + s.offset;
        for (int k = 0; k < kChunk; ++k) {
          const openvdb::Coord& cell = cells[b][rng.below(cells[b].size())];
          const Eigen::Vector3f pf(static_cast<float>((cell.x() + rng.uniform(-0.5, 0.5)) * h),
                                   static_cast<float>((cell.y() + rng.uniform(-0.5, 0.5)) * h),
                                   static_cast<float>((cell.z() + rng.uniform(-0.5, 0.5)) * h));
          const Vec3 p = pf.cast<double>();
          bool used = false;
          const double v = exact(p, acc, used);
          chunk_winding[c] += used;
          const bool last = b == 3;
          if (v >= lo && (v < hi || (last && v <= hi))) chunk_out[c].push_back({pf, static_cast<float>(v)});
        }
      });
      tried[b] += static_cast<long>(kChunk) * kChunks;
      for (int c = 0; c < kChunks; ++c) {
        winding_calls += chunk_winding[c];
        for (const Candidate& cand : chunk_out[c])
          if (static_cast<long>(accepted[b].size()) < want[b]) accepted[b].push_back(cand);
      }
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
      bool used = false;
      uniform[static_cast<size_t>(i)] = {pf, static_cast<float>(exact(pf.cast<double>(), acc, used))};
    }
  });

  long total = rep.uniform_count;
  for (int b = 0; b < 4; ++b) {
    rep.bin_counts[b] = static_cast<long>(accepted[b].size());
    total += rep.bin_counts[b];
    rep.candidates += tried[b];
  }
  MatrixXfR out(total, 4);
  Eigen::Index row = 0;
  auto put = [&](const Candidate& c) {
    out.row(row++) << c.p.x(), c.p.y(), c.p.z(), c.sdf;
  };
  for (int b = 0; b < 4; ++b)
    for (const Candidate& c : accepted[b]) put(c);
  for (const Candidate& c : uniform) put(c);
  (void)winding_calls;
  if (report) *report = rep;
  return out;
}

}  // namespace sdfkit
