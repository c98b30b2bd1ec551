#include "metrics/grid_nn.h"

#include "core/error.h"
#include "metrics/sampling.h"
#include "core/simd.h"

#include <tbb/parallel_for.h>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {
namespace {

constexpr int kMaxRing = 5;  // cells up to this many cells away are searched; farther answers come from the KD-tree
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr size_t kNeighbourhood = 27;  // the first 27 sorted offsets: the cell and its neighbours (least distance 0)

// Scans the points [begin, end) of the cell-sorted arrays for one nearer to q than (best_slot, best_d2), ties to
// the smaller original index. The squared distance is (dx^2 + dy^2) + dz^2 in double in every version (no fused
// multiply-add), so all versions agree bit for bit with each other and with a brute-force loop.
void scan_points_generic(const double* x, const double* y, const double* z, const uint32_t* order, uint32_t begin,
                         uint32_t end, const double q[3], uint32_t& best_slot, double& best_d2) {
  for (uint32_t s = begin; s < end; ++s) {
    const double dx = x[s] - q[0], dy = y[s] - q[1], dz = z[s] - q[2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 < best_d2 || (d2 == best_d2 && order[s] < order[best_slot])) {
      best_slot = s;
      best_d2 = d2;
    }
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
// Four points at a time; lanes that may improve (d2 <= best) are then taken one by one with the exact rule.
__attribute__((target("avx2"))) void scan_points_avx2(const double* x, const double* y, const double* z,
                                                      const uint32_t* order, uint32_t begin, uint32_t end,
                                                      const double q[3], uint32_t& best_slot, double& best_d2) {
  const __m256d qx = _mm256_set1_pd(q[0]), qy = _mm256_set1_pd(q[1]), qz = _mm256_set1_pd(q[2]);
  uint32_t s = begin;
  for (; s + 4 <= end; s += 4) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(x + s), qx), dy = _mm256_sub_pd(_mm256_loadu_pd(y + s), qy),
                  dz = _mm256_sub_pd(_mm256_loadu_pd(z + s), qz);
    const __m256d d2 =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
    auto mask = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(d2, _mm256_set1_pd(best_d2), _CMP_LE_OQ)));
    if (mask == 0) continue;
    alignas(32) double lane[4];
    _mm256_store_pd(lane, d2);
    while (mask != 0) {
      const int k = __builtin_ctz(mask);
      mask &= mask - 1;
      const uint32_t t = s + static_cast<uint32_t>(k);
      if (lane[k] < best_d2 || (lane[k] == best_d2 && order[t] < order[best_slot])) {
        best_slot = t;
        best_d2 = lane[k];
      }
    }
  }
  scan_points_generic(x, y, z, order, s, end, q, best_slot, best_d2);
}
#endif

void scan_points(const double* x, const double* y, const double* z, const uint32_t* order, uint32_t begin,
                 uint32_t end, const double q[3], uint32_t& best_slot, double& best_d2) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (avx2_enabled()) return scan_points_avx2(x, y, z, order, begin, end, q, best_slot, best_d2);
#endif
  scan_points_generic(x, y, z, order, begin, end, q, best_slot, best_d2);
}

}  // namespace

// The offsets of the (2R+1)^3 block around a cell, sorted by the least distance a point of the centre cell can
// have to the offset cell: sqrt(sum over axes of max(0, |d| - 1)^2) cell sizes; ties by offset for determinism.
const std::vector<NearestGrid::CellOffset>& NearestGrid::block_offsets() {
  static const std::vector<CellOffset> kTable = [] {
    std::vector<CellOffset> t;
    for (int z = -kMaxRing; z <= kMaxRing; ++z)
      for (int y = -kMaxRing; y <= kMaxRing; ++y)
        for (int x = -kMaxRing; x <= kMaxRing; ++x) {
          CellOffset o;
          o.d[0] = x;
          o.d[1] = y;
          o.d[2] = z;
          o.rank = 0;
          for (int v : {x, y, z}) o.rank += std::max(0, std::abs(v) - 1) * std::max(0, std::abs(v) - 1);
          o.least = std::sqrt(static_cast<double>(o.rank));
          t.push_back(o);
        }
    std::stable_sort(t.begin(), t.end(), [](const CellOffset& a, const CellOffset& b) { return a.rank < b.rank; });
    return t;
  }();
  return kTable;
}

NearestGrid::NearestGrid(const Points& points, const std::string& what) {
  require_finite_points(points, what);
  const Eigen::Index n = points.rows();
  require(n < (Eigen::Index(1) << 31), what + ": too many points for a 32-bit index");

  const Vec3 lo = points.colwise().minCoeff().transpose(), hi = points.colwise().maxCoeff().transpose();
  const Vec3 ext = hi - lo;
  const double longest = ext.maxCoeff();
  for (int a = 0; a < 3; ++a) origin_[a] = lo[a];
  if (longest > 0) {
    // About one cell per eight points over the box (flat boxes counted with a thickness of 1/64 of the longest
    // side): a surface sample then puts a few dozen points in each occupied cell, most cells being empty, and
    // the vectorised scan of a cell costs little per point. (Callgrind on two nearby 100k-point torus samples:
    // 1/16 and 1/8 cell per point ~2,000 instructions per query, 1/4 2,400, 1/2 3,200.)
    const double target = 0.125 * static_cast<double>(n);
    const Vec3 thick = ext.cwiseMax(longest / 64);
    h_ = std::cbrt(thick.prod() / target);
    for (;;) {
      double cells = 1;
      for (int a = 0; a < 3; ++a) {
        dims_[a] = static_cast<int>(std::clamp(std::ceil(ext[a] / h_), 1.0, 2048.0));
        cells *= dims_[a];
      }
      if (cells <= 4 * target + 64) break;
      h_ *= 1.25;
    }
  }
  inv_h_ = 1 / h_;
  const double max_abs = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
  // Rounding of cell bounds and of the bucketing (a few ulps of the coordinates) must never prune the cell that
  // holds the nearest point: every box distance is reduced by this margin.
  slack_ = 64 * kEps * (max_abs + longest);

  order_ = bucket(points, cell_start_);
  for (auto* c : {&x_, &y_, &z_}) c->resize(static_cast<size_t>(n));
  for (size_t s = 0; s < order_.size(); ++s) {
    x_[s] = points(order_[s], 0);
    y_[s] = points(order_[s], 1);
    z_[s] = points(order_[s], 2);
  }
}

std::vector<uint32_t> NearestGrid::bucket(const Points& p, std::vector<uint32_t>& start) const {
  const size_t cells = static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2];
  const auto n = static_cast<size_t>(p.rows());
  std::vector<uint32_t> cell_of(n), sorted(n);
  start.assign(cells + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    const size_t c = cell_index(cell_coord(p(r, 0), 0), cell_coord(p(r, 1), 1), cell_coord(p(r, 2), 2));
    cell_of[i] = static_cast<uint32_t>(c);
    ++start[c + 1];
  }
  for (size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t i = 0; i < n; ++i) sorted[fill[cell_of[i]]++] = static_cast<uint32_t>(i);  // stable
  return sorted;
}

NearestGrid::~NearestGrid() = default;

int NearestGrid::cell_coord(double x, int axis) const {
  const double t = (x - origin_[axis]) * inv_h_;
  if (!(t > 0)) return 0;
  if (t >= dims_[axis]) return dims_[axis] - 1;
  return static_cast<int>(t);
}

NearestGrid::Hit NearestGrid::search(const double q[3], uint32_t guess, bool& resolved) const {
  const double slack = slack_ + 4 * kEps * std::max({std::abs(q[0]), std::abs(q[1]), std::abs(q[2])});
  int c0[3];
  // lower[a] / upper[a]: distance along axis a from q to the lower / upper wall of its (clamped) cell, and
  // outside[a]: its distance to the cell itself (non-zero only for a query outside the grid's box); all less the
  // margin. The slab of cells c0[a] + k (k != 0) is then (|k| - 1) h + lower or upper away along that axis.
  double lower[3], upper[3], outside[3];
  for (int a = 0; a < 3; ++a) {
    c0[a] = cell_coord(q[a], a);
    const double lo = origin_[a] + c0[a] * h_, hi = origin_[a] + (c0[a] + 1) * h_;
    lower[a] = q[a] - lo - slack;
    upper[a] = hi - q[a] - slack;
    outside[a] = std::max(0.0, std::max(-lower[a], -upper[a]) - 2 * slack);
  }
  const auto axis_gap2 = [&](int a, int k) {
    const double g = k == 0 ? outside[a] : std::max(0.0, (k > 0 ? upper[a] : lower[a]) + (std::abs(k) - 1) * h_);
    return g * g;
  };
  Hit best{std::numeric_limits<uint32_t>::max(), kInf};
  const auto scan = [&](int cx, int cy, int cz) {
    const size_t cell = cell_index(cx, cy, cz);
    scan_points(x_.data(), y_.data(), z_.data(), order_.data(), cell_start_[cell], cell_start_[cell + 1], q,
                best.slot, best.d2);
  };
  if (guess != best.slot) {  // a point near the previous query: an upper bound that prunes from the start
    const double dx = x_[guess] - q[0], dy = y_[guess] - q[1], dz = z_[guess] - q[2];
    best = {guess, dx * dx + dy * dy + dz * dz};
  }
  // 1. The query's own cell, then those of its 26 neighbours whose slab along every axis is close enough.
  scan(c0[0], c0[1], c0[2]);
  double g2[3][3];
  for (int a = 0; a < 3; ++a)
    for (int k = -1; k <= 1; ++k) g2[a][k + 1] = axis_gap2(a, k);
  for (int dz = -1; dz <= 1; ++dz) {
    if (c0[2] + dz < 0 || c0[2] + dz >= dims_[2] || g2[2][dz + 1] > best.d2) continue;
    for (int dy = -1; dy <= 1; ++dy) {
      if (c0[1] + dy < 0 || c0[1] + dy >= dims_[1] || g2[2][dz + 1] + g2[1][dy + 1] > best.d2) continue;
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx | dy | dz) == 0 || c0[0] + dx < 0 || c0[0] + dx >= dims_[0]) continue;
        if (g2[2][dz + 1] + g2[1][dy + 1] + g2[0][dx + 1] > best.d2) continue;
        scan(c0[0] + dx, c0[1] + dy, c0[2] + dz);
      }
    }
  }
  // 2. Cells further out, in the order of the least distance any query in the centre cell can have to them
  //    (block_offsets() is sorted by it): the search stops at the first offset whose least distance exceeds the best
  //    distance found, since every cell after it is at least as far.
  double gap[3][2 * kMaxRing + 1];
  bool have_gap = false;
  const std::vector<CellOffset>& offsets = block_offsets();
  for (size_t i = kNeighbourhood; i < offsets.size(); ++i) {
    const CellOffset& o = offsets[i];
    const double lb = std::max(0.0, o.least * h_ - 2 * slack);
    if (lb * lb > best.d2) {
      resolved = true;
      return best;
    }
    const int cx = c0[0] + o.d[0], cy = c0[1] + o.d[1], cz = c0[2] + o.d[2];
    if (cx < 0 || cy < 0 || cz < 0 || cx >= dims_[0] || cy >= dims_[1] || cz >= dims_[2]) continue;
    if (!have_gap) {
      for (int a = 0; a < 3; ++a)
        for (int k = -kMaxRing; k <= kMaxRing; ++k) gap[a][k + kMaxRing] = axis_gap2(a, k);
      have_gap = true;
    }
    if (gap[0][o.d[0] + kMaxRing] + gap[1][o.d[1] + kMaxRing] + gap[2][o.d[2] + kMaxRing] > best.d2) continue;
    scan(cx, cy, cz);
  }
  // Every offset within kMaxRing was considered: the answer is final if no cell lies further out.
  resolved = true;
  for (int a = 0; a < 3; ++a) resolved = resolved && c0[a] - kMaxRing <= 0 && c0[a] + kMaxRing >= dims_[a] - 1;
  return best;
}

std::pair<int, double> NearestGrid::fallback(const double q[3]) const {
  std::call_once(tree_once_, [this] {
    const Eigen::Index n = size();
    Points sorted(n, 3);
    for (Eigen::Index s = 0; s < n; ++s)
      sorted.row(s) << x_[static_cast<size_t>(s)], y_[static_cast<size_t>(s)], z_[static_cast<size_t>(s)];
    tree_ = std::make_unique<KdTree>(std::move(sorted));
  });
  fallbacks_.fetch_add(1, std::memory_order_relaxed);
  const auto [slot, d2] = tree_->nearest(Vec3(q[0], q[1], q[2]));
  return {static_cast<int>(order_[static_cast<size_t>(slot)]), d2};
}

std::pair<int, double> NearestGrid::nearest(const Vec3& q) const {
  require(q.allFinite(), "NearestGrid::nearest: non-finite query point");
  const double p[3] = {q.x(), q.y(), q.z()};
  bool resolved = false;
  const Hit hit = search(p, std::numeric_limits<uint32_t>::max(), resolved);
  if (!resolved) return fallback(p);
  return {static_cast<int>(order_[hit.slot]), hit.d2};
}

void NearestGrid::nearest(const Points& queries, Eigen::VectorXi& index, Eigen::VectorXd& squared_distance) const {
  require(queries.allFinite(), "NearestGrid::nearest: non-finite query point");
  const Eigen::Index n = queries.rows();
  index.resize(n);
  squared_distance.resize(n);
  // Visit the queries cell by cell (counting sort on the cell each falls in): neighbouring queries then read the
  // same few cells one after the other, and each search starts from the previous query's answer as its bound.
  std::vector<uint32_t> first;
  const std::vector<uint32_t> visit = bucket(queries, first);

  constexpr Eigen::Index kBlock = 512;  // a fixed split: results never depend on it or on the thread count
  tbb::parallel_for(Eigen::Index(0), (n + kBlock - 1) / kBlock, [&](Eigen::Index b) {
    uint32_t guess = std::numeric_limits<uint32_t>::max();
    for (Eigen::Index k = b * kBlock; k < std::min(n, (b + 1) * kBlock); ++k) {
      const Eigen::Index i = visit[static_cast<size_t>(k)];
      const double q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
      bool resolved = false;
      const Hit hit = search(q, guess, resolved);
      guess = resolved ? hit.slot : std::numeric_limits<uint32_t>::max();
      if (resolved) {
        index(i) = static_cast<int>(order_[hit.slot]);
        squared_distance(i) = hit.d2;
      } else {
        const auto [j, d2] = fallback(q);
        index(i) = j;
        squared_distance(i) = d2;
      }
    }
  });
}

long NearestGrid::fallback_count() const { return fallbacks_.load(std::memory_order_relaxed); }

}  // namespace sdfkit
