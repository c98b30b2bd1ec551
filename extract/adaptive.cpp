#include "extract/adaptive.h"

#include "core/error.h"
#include "extract/mc_core.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_set>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

namespace sdfkit {
namespace {

using Clock = std::chrono::steady_clock;

void check_settings(const ExtractSettings& s, bool adaptive) {
  require(s.resolution >= 2 && s.resolution <= 2049,
          "extract: resolution must be in [2, 2049] grid points per axis, got " + std::to_string(s.resolution));
  require(s.box_size > 0 && std::isfinite(s.box_size) && s.box_min.allFinite(),
          "extract: the box must have a positive, finite size");
  require(std::isfinite(s.iso), "extract: iso must be finite");
  require(s.safety >= 1.0 && std::isfinite(s.safety), "extract: safety must be >= 1 (1 for a true SDF)");
  require(s.max_batch >= 1, "extract: max_batch must be >= 1");
  if (!adaptive) return;
  require(s.coarse_resolution >= 2 && s.coarse_resolution <= s.resolution,
          "extract: coarse_resolution must be in [2, resolution]");
  const int n = s.resolution - 1, c = s.coarse_resolution - 1;
  const int ratio = n % c == 0 ? n / c : 0;
  require(ratio >= 1 && (ratio & (ratio - 1)) == 0,
          "extract: (resolution - 1) / (coarse_resolution - 1) must be a power of two, got " +
              std::to_string(n) + " / " + std::to_string(c));
}

double voxel_of(const ExtractSettings& s) { return s.box_size / (s.resolution - 1); }

/// Grid point -> world, written exactly as DenseGrid::point so that both paths evaluate identical coordinates.
Vec3 point_of(const ExtractSettings& s, double voxel, int i, int j, int k) { return s.box_min + voxel * Vec3(i, j, k); }

/// Calls the functor on `points`, checks its answer, returns the values.
void evaluate(const BatchField& field, const Points& points, Eigen::VectorXd& values) {
  values.resize(0);
  field(points, values);
  if (values.size() != points.rows())
    throw InvalidInput("extract: the field returned " + std::to_string(values.size()) + " values for " +
                       std::to_string(points.rows()) + " points");
  for (Eigen::Index r = 0; r < values.size(); ++r)
    if (!std::isfinite(values[r])) {
      std::ostringstream msg;
      msg << "extract: the field returned " << values[r] << " at point (" << points(r, 0) << ", " << points(r, 1)
          << ", " << points(r, 2) << ")";
      throw InvalidInput(msg.str());
    }
}

/// Fine-grid values stored in 8^3 blocks allocated on first touch: memory follows the evaluated band, not the
/// full grid. Unevaluated entries hold NaN. Blocks live in pages of kPageBlocks that never move, so growing the
/// store copies nothing (a single growing vector spent a tenth of a 257^3 extraction in reallocation copies).
class BlockStore {
 public:
  static constexpr int kB = 8;
  static constexpr size_t kBlockSize = size_t(kB) * kB * kB;
  static constexpr size_t kPageBlocks = 64;
  explicit BlockStore(int points_per_axis) : nb_((points_per_axis + kB - 1) / kB) {
    index_.assign(size_t(nb_) * nb_ * nb_, -1);
  }
  float get(int i, int j, int k) const {
    const int32_t b = index_[block_of(i, j, k)];
    return b < 0 ? kUnset : block(static_cast<size_t>(b))[local(i, j, k)];
  }
  float& ref(int i, int j, int k) {
    int32_t& b = index_[block_of(i, j, k)];
    if (b < 0) {
      if (blocks_ % kPageBlocks == 0) pages_.emplace_back(kPageBlocks * kBlockSize, kUnset);
      b = static_cast<int32_t>(blocks_++);
    }
    return block(static_cast<size_t>(b))[local(i, j, k)];
  }
  [[nodiscard]] size_t blocks() const { return blocks_; }
  static constexpr float kUnset = std::numeric_limits<float>::quiet_NaN();

 private:
  const float* block(size_t b) const { return pages_[b / kPageBlocks].data() + (b % kPageBlocks) * kBlockSize; }
  float* block(size_t b) { return pages_[b / kPageBlocks].data() + (b % kPageBlocks) * kBlockSize; }
  size_t block_of(int i, int j, int k) const { return size_t(i / kB) + size_t(nb_) * (size_t(j / kB) + size_t(nb_) * (k / kB)); }
  static int local(int i, int j, int k) { return (i % kB) + kB * ((j % kB) + kB * (k % kB)); }
  int nb_;
  size_t blocks_ = 0;
  std::vector<int32_t> index_;
  std::vector<std::vector<float>> pages_;
};

/// Queues grid points for evaluation (each at most once) and evaluates them in batches.
class Evaluator {
 public:
  Evaluator(const BatchField& field, const ExtractSettings& s, BlockStore& store)
      : field_(field), s_(s), voxel_(voxel_of(s)), store_(store) {}

  void request(int i, int j, int k) {
    float& v = store_.ref(i, j, k);
    if (!std::isnan(v)) return;  // evaluated or already queued
    v = kQueued;
    pending_.push_back({i, j, k});
  }

  /// Evaluates everything queued; returns how many points that was.
  long flush() {
    const long total = static_cast<long>(pending_.size());
    Points batch;
    Eigen::VectorXd values;
    for (size_t begin = 0; begin < pending_.size(); begin += size_t(s_.max_batch)) {
      const size_t end = std::min(pending_.size(), begin + size_t(s_.max_batch));
      batch.resize(static_cast<Eigen::Index>(end - begin), 3);
      for (size_t r = begin; r < end; ++r) {
        const auto& p = pending_[r];
        batch.row(static_cast<Eigen::Index>(r - begin)) = point_of(s_, voxel_, p[0], p[1], p[2]).transpose();
      }
      evaluate(field_, batch, values);
      for (size_t r = begin; r < end; ++r) {
        const auto& p = pending_[r];
        store_.ref(p[0], p[1], p[2]) = static_cast<float>(values[static_cast<Eigen::Index>(r - begin)] - s_.iso);
      }
    }
    pending_.clear();
    evaluations_ += total;
    return total;
  }
  [[nodiscard]] long evaluations() const { return evaluations_; }

 private:
  static constexpr float kQueued = std::numeric_limits<float>::infinity();
  const BatchField& field_;
  const ExtractSettings& s_;
  double voxel_;
  BlockStore& store_;
  std::vector<std::array<int, 3>> pending_;
  long evaluations_ = 0;
};

struct Cell {
  int i, j, k;
};

/// Sort key of a (possibly padding) fine cell: z, then y, then x -- the order the dense path visits cells.
uint64_t order_key(int i, int j, int k) {
  return (uint64_t(k + 1) << 42) | (uint64_t(j + 1) << 21) | uint64_t(i + 1);
}

/// Whether grid point (i, j, k) lies on the grid of n cells per axis (points 0..n); padding points do not.
bool on_grid(int n, int i, int j, int k) { return i >= 0 && j >= 0 && k >= 0 && i <= n && j <= n && k <= n; }

/// Surface following (ExtractSettings::follow_surface): grows `ordered` (final and padding cells, sorted by
/// order_key, corners evaluated) across every cell face whose four corners straddle iso, evaluating the new cells'
/// corners level by level, and sorts it again. Returns the evaluations it made.
template <class RequestCorners>
long follow_surface(std::vector<std::pair<uint64_t, Cell>>& ordered, const ExtractSettings& s, const BlockStore& store,
                    Evaluator& eval, const RequestCorners& request_corners) {
  const int n = s.resolution - 1;
  const int lo = s.close_boundary ? -1 : 0, hi = s.close_boundary ? n : n - 1;  // cell index range (with padding)
  auto value = [&](int i, int j, int k) {
    return on_grid(n, i, j, k) ? double(store.get(i, j, k)) : detail::kPadValue;
  };
  std::unordered_set<uint64_t> member;
  member.reserve(ordered.size() * 2);
  std::vector<Cell> frontier;
  frontier.reserve(ordered.size());
  for (const auto& [key, c] : ordered) {
    member.insert(key);
    frontier.push_back(c);
  }
  long evaluations = 0;
  std::vector<Cell> added;
  while (!frontier.empty()) {
    added.clear();
    for (const Cell& c : frontier) {
      double v[detail::kCorners];
      for (int corner = 0; corner < detail::kCorners; ++corner)
        v[corner] = value(c.i + (corner & 1), c.j + ((corner >> 1) & 1), c.k + ((corner >> 2) & 1));
      for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
          bool in = false, out = false;
          for (int corner = 0; corner < detail::kCorners; ++corner)
            if (((corner >> axis) & 1) == side) (v[corner] < 0 ? in : out) = true;
          if (!(in && out)) continue;
          Cell nb = c;
          int& coord = axis == 0 ? nb.i : axis == 1 ? nb.j : nb.k;
          coord += side ? 1 : -1;
          if (coord < lo || coord > hi) continue;
          if (!member.insert(order_key(nb.i, nb.j, nb.k)).second) continue;
          added.push_back(nb);
          request_corners(nb);
        }
    }
    evaluations += eval.flush();
    for (const Cell& c : added) ordered.push_back({order_key(c.i, c.j, c.k), c});
    std::swap(frontier, added);
  }
  tbb::parallel_sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return evaluations;
}

}  // namespace

DenseGrid sample_dense(const BatchField& field, const ExtractSettings& s, long* evaluations) {
  check_settings(s, false);
  const int n = s.resolution;
  const double voxel = voxel_of(s);
  DenseGrid grid(s.box_min, voxel, n, n, n);
  const size_t total = grid.size();
  Points batch;
  Eigen::VectorXd values;
  for (size_t begin = 0; begin < total; begin += size_t(s.max_batch)) {
    const size_t end = std::min(total, begin + size_t(s.max_batch));
    batch.resize(static_cast<Eigen::Index>(end - begin), 3);
    for (size_t idx = begin; idx < end; ++idx) {
      const int i = int(idx % size_t(n)), j = int((idx / size_t(n)) % size_t(n)), k = int(idx / (size_t(n) * n));
      batch.row(static_cast<Eigen::Index>(idx - begin)) = point_of(s, voxel, i, j, k).transpose();
    }
    evaluate(field, batch, values);
    for (size_t idx = begin; idx < end; ++idx)
      grid.values[idx] = static_cast<float>(values[static_cast<Eigen::Index>(idx - begin)] - s.iso);
  }
  if (evaluations) *evaluations = static_cast<long>(total);
  return grid;
}

ExtractResult dense_extract(const BatchField& field, const ExtractSettings& s) {
  const auto t0 = Clock::now();
  ExtractResult r;
  const DenseGrid grid = sample_dense(field, s, &r.evaluations);
  r.level_cells = {static_cast<long>(s.resolution - 1) * (s.resolution - 1) * (s.resolution - 1)};
  r.level_evaluations = {r.evaluations};
  r.mesh = marching_cubes(grid, {0.0, s.close_boundary}, &r.mc);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

ExtractResult adaptive_extract(const BatchField& field, const ExtractSettings& s) {
  check_settings(s, true);
  const auto t0 = Clock::now();
  ExtractResult r;
  const int n = s.resolution - 1;  // fine cells per axis
  const int ratio = n / (s.coarse_resolution - 1);
  const double voxel = voxel_of(s);
  BlockStore store(s.resolution);
  Evaluator eval(field, s, store);

  // Refinement: cells of `size` fine cells, kept while they may hold the surface.
  std::vector<Cell> cells, next, final_cells;
  for (int k = 0; k < n; k += ratio)
    for (int j = 0; j < n; j += ratio)
      for (int i = 0; i < n; i += ratio) cells.push_back({i, j, k});
  if (ratio == 1) final_cells = cells;
  const bool sign_change = s.refine == RefineRule::kSignChange;
  for (int size = ratio; size >= 2; size /= 2) {
    const int h = size / 2;
    for (const Cell& c : cells) {
      if (!sign_change) {
        eval.request(c.i + h, c.j + h, c.k + h);
        continue;
      }
      for (int corner = 0; corner < detail::kCorners; ++corner)
        eval.request(c.i + size * (corner & 1), c.j + size * ((corner >> 1) & 1), c.k + size * ((corner >> 2) & 1));
    }
    r.level_cells.push_back(static_cast<long>(cells.size()));
    r.level_evaluations.push_back(eval.flush());
    // Half-diagonal of the cell, times the safety factor, with a relative margin that covers float storage.
    const double bound = s.safety * 0.5 * std::sqrt(3.0) * size * voxel * (1.0 + 1e-6);
    auto may_hold_surface = [&](const Cell& c, bool at_boundary) {
      if (!sign_change) {
        const double centre = store.get(c.i + h, c.j + h, c.k + h);
        // A cell on the box boundary also holds the cap when anything inside it is inside: drop it only when
        // it is surely outside.
        return at_boundary ? centre <= bound : std::abs(centre) <= bound;
      }
      int inside = 0;
      for (int corner = 0; corner < detail::kCorners; ++corner)
        inside += store.get(c.i + size * (corner & 1), c.j + size * ((corner >> 1) & 1),
                            c.k + size * ((corner >> 2) & 1)) < 0 ? 1 : 0;
      return (inside > 0 && inside < detail::kCorners) || (at_boundary && inside > 0);
    };
    next.clear();
    for (const Cell& c : cells) {
      const bool at_boundary = s.close_boundary && (c.i == 0 || c.j == 0 || c.k == 0 || c.i + size == n ||
                                                    c.j + size == n || c.k + size == n);
      if (!may_hold_surface(c, at_boundary)) continue;
      for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const Cell child{c.i + dx * h, c.j + dy * h, c.k + dz * h};
            (size == 2 ? final_cells : next).push_back(child);
          }
    }
    std::swap(cells, next);
  }

  // Final level: padding cells owned by kept boundary cells, then all corners.
  std::vector<std::pair<uint64_t, Cell>> ordered;
  ordered.reserve(final_cells.size() + final_cells.size() / 8);
  for (const Cell& c : final_cells) {
    ordered.push_back({order_key(c.i, c.j, c.k), c});
    if (!s.close_boundary) continue;
    const bool lo[3] = {c.i == 0, c.j == 0, c.k == 0}, hi[3] = {c.i == n - 1, c.j == n - 1, c.k == n - 1};
    if (!(lo[0] || lo[1] || lo[2] || hi[0] || hi[1] || hi[2])) continue;
    for (int dz = lo[2] ? -1 : 0; dz <= (hi[2] ? 1 : 0); ++dz)
      for (int dy = lo[1] ? -1 : 0; dy <= (hi[1] ? 1 : 0); ++dy)
        for (int dx = lo[0] ? -1 : 0; dx <= (hi[0] ? 1 : 0); ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          const Cell p{c.i + dx, c.j + dy, c.k + dz};
          ordered.push_back({order_key(p.i, p.j, p.k), p});
        }
  }
  tbb::parallel_sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  auto inside_grid = [n](int i, int j, int k) { return on_grid(n, i, j, k); };
  auto request_corners = [&](const Cell& c) {
    for (int corner = 0; corner < detail::kCorners; ++corner) {
      const int ci = c.i + (corner & 1), cj = c.j + ((corner >> 1) & 1), ck = c.k + ((corner >> 2) & 1);
      if (inside_grid(ci, cj, ck)) eval.request(ci, cj, ck);
    }
  };
  for (const auto& entry : ordered) request_corners(entry.second);
  r.level_cells.push_back(static_cast<long>(final_cells.size()));
  long final_evaluations = eval.flush();
  if (s.follow_surface) {
    const size_t before = ordered.size();
    final_evaluations += follow_surface(ordered, s, store, eval, request_corners);
    r.followed_cells = static_cast<long>(ordered.size() - before);
  }
  r.level_evaluations.push_back(final_evaluations);
  r.evaluations = eval.evaluations();

  // Marching cubes over consecutive chunks of the ordered cells, one builder per chunk, in parallel; appending
  // the chunks in order gives the serial build's mesh exactly (McBuilder::append), whatever the thread count.
  constexpr size_t kChunk = 8192;
  std::vector<detail::McBuilder> chunks((ordered.size() + kChunk - 1) / kChunk);
  tbb::parallel_for(size_t(0), chunks.size(), [&](size_t ch) {
    double sv[detail::kCorners];
    const size_t end = std::min(ordered.size(), (ch + 1) * kChunk);
    for (size_t n = ch * kChunk; n < end; ++n) {
      const Cell& c = ordered[n].second;
      uint32_t pad = 0;
      for (int corner = 0; corner < detail::kCorners; ++corner) {
        const int ci = c.i + (corner & 1), cj = c.j + ((corner >> 1) & 1), ck = c.k + ((corner >> 2) & 1);
        if (inside_grid(ci, cj, ck)) {
          sv[corner] = double(store.get(ci, cj, ck));
        } else {
          pad |= 1u << corner;
          sv[corner] = detail::kPadValue;
        }
      }
      if (!detail::McBuilder::has_crossing(sv, pad)) continue;
      chunks[ch].add_cell(c.i, c.j, c.k, sv, pad);
    }
  });
  detail::McBuilder builder;
  for (const detail::McBuilder& chunk : chunks) builder.append(chunk);
  r.mesh = builder.finish(s.box_min, voxel, &r.mc);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

}  // namespace sdfkit
