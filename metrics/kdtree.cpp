#include "metrics/kdtree.h"

#include "core/error.h"
#include "metrics/sampling.h"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sdfkit {
namespace {

struct RowsAdaptor {
  const Points* P;
  [[nodiscard]] size_t kdtree_get_point_count() const { return static_cast<size_t>(P->rows()); }
  [[nodiscard]] double kdtree_get_pt(size_t i, size_t d) const {
    return (*P)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d));
  }
  template <class Bbox>
  bool kdtree_get_bbox(Bbox& /*unused*/) const {
    return false;
  }
};

// nanoflann's k-NN result set with a cap on the radius: worstDist() is never above `cap` (squared). With a cap
// at least the final k-th distance, the search keeps exactly the points it would keep without one.
class CappedKnn : public nanoflann::KNNResultSet<double, uint32_t> {
 public:
  CappedKnn(size_t k, double cap) : KNNResultSet(k), cap_(cap) {}
  [[nodiscard]] double worstDist() const { return std::min(KNNResultSet::worstDist(), cap_); }

 private:
  double cap_;
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, RowsAdaptor>, RowsAdaptor, 3,
                                                 uint32_t>;

}  // namespace

struct KdTree::Impl {
  RowsAdaptor adaptor;
  Tree tree;
  explicit Impl(const Points* p) : adaptor{p}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(12)) {
    tree.buildIndex();
  }
};

KdTree::KdTree(Points points, const std::string& what) : points_(std::move(points)) {
  require_finite_points(points_, what);
  require(points_.rows() < (Eigen::Index(1) << 31), what + ": too many points for a 32-bit index");
  impl_ = std::make_unique<Impl>(&points_);
}
KdTree::~KdTree() = default;
// The adaptor points at the Points object that owns the data; after a move that object is a different one, so
// the pointer is re-targeted (the tree's own index arrays live in Impl and move with it).
KdTree::KdTree(KdTree&& other) noexcept : points_(std::move(other.points_)), impl_(std::move(other.impl_)) {
  if (impl_) impl_->adaptor.P = &points_;
}
KdTree& KdTree::operator=(KdTree&& other) noexcept {
  points_ = std::move(other.points_);
  impl_ = std::move(other.impl_);
  if (impl_) impl_->adaptor.P = &points_;
  return *this;
}

std::pair<int, double> KdTree::nearest(const Vec3& q) const {
  uint32_t index = 0;
  double d2 = 0;
  nanoflann::KNNResultSet<double, uint32_t> result(1);
  result.init(&index, &d2);
  const double query[3] = {q.x(), q.y(), q.z()};
  impl_->tree.findNeighbors(result, query, nanoflann::SearchParams());
  return {static_cast<int>(index), d2};
}

void KdTree::nearest(const Points& queries, Eigen::VectorXi& index, Eigen::VectorXd& squared_distance,
                     const std::vector<uint32_t>* order) const {
  const Eigen::Index n = queries.rows();
  require(order == nullptr || static_cast<Eigen::Index>(order->size()) == n, "KdTree::nearest: order size mismatch");
  index.resize(n);
  squared_distance.resize(n);
  constexpr Eigen::Index kBlock = 256;
  const Eigen::Index blocks = (n + kBlock - 1) / kBlock;
  tbb::parallel_for(Eigen::Index(0), blocks, [&](Eigen::Index b) {
    uint32_t prev = 0;
    bool have_prev = false;
    for (Eigen::Index k = b * kBlock; k < std::min(n, (b + 1) * kBlock); ++k) {
      const Eigen::Index i = order != nullptr ? static_cast<Eigen::Index>((*order)[k]) : k;
      const double q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
      uint32_t idx = 0;
      double d2 = 0;
      nanoflann::KNNResultSet<double, uint32_t> result(1);
      result.init(&idx, &d2);
      if (have_prev) {
        const double dx = q[0] - points_(prev, 0), dy = q[1] - points_(prev, 1), dz = q[2] - points_(prev, 2);
        result.addPoint(dx * dx + dy * dy + dz * dz, prev);
      }
      impl_->tree.findNeighbors(result, q, nanoflann::SearchParams());
      index(i) = static_cast<int>(idx);
      squared_distance(i) = d2;
      prev = idx;
      have_prev = true;
    }
  });
}

std::vector<uint32_t> KdTree::leaf_order() const {
  return std::vector<uint32_t>(impl_->tree.vAcc.begin(), impl_->tree.vAcc.end());
}

std::vector<std::pair<int, double>> KdTree::knn(const Vec3& q, int k) const {
  k = std::max(0, std::min<int>(k, static_cast<int>(points_.rows())));
  std::vector<uint32_t> idx(static_cast<size_t>(k));
  std::vector<double> d2(static_cast<size_t>(k));
  std::vector<std::pair<int, double>> out(static_cast<size_t>(knn(q, k, idx.data(), d2.data())));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {static_cast<int>(idx[i]), d2[i]};
  return out;
}

int KdTree::knn(const Vec3& q, int k, uint32_t* index, double* squared_distance) const {
  k = std::max(0, std::min<int>(k, static_cast<int>(points_.rows())));
  if (k == 0) return 0;
  nanoflann::KNNResultSet<double, uint32_t> result(static_cast<size_t>(k));
  result.init(index, squared_distance);
  const double query[3] = {q.x(), q.y(), q.z()};
  impl_->tree.findNeighbors(result, query, nanoflann::SearchParams());
  return static_cast<int>(result.size());
}

void KdTree::knn_batch(const Points& queries, int k, std::vector<uint32_t>& index,
                       const std::vector<uint32_t>* order) const {
  const Eigen::Index n = queries.rows();
  require(k >= 1 && k <= points_.rows(), "KdTree::knn_batch: k must be in [1, size]");
  require(order == nullptr || static_cast<Eigen::Index>(order->size()) == n, "KdTree::knn_batch: order size mismatch");
  const auto uk = static_cast<size_t>(k);
  index.resize(static_cast<size_t>(n) * uk);
  constexpr Eigen::Index kBlock = 256;
  const Eigen::Index blocks = (n + kBlock - 1) / kBlock;
  tbb::parallel_for(Eigen::Index(0), blocks, [&](Eigen::Index b) {
    std::vector<double> d2(uk);
    double prev_q[3] = {0, 0, 0}, prev_kth = 0;
    bool have_prev = false;
    for (Eigen::Index t = b * kBlock; t < std::min(n, (b + 1) * kBlock); ++t) {
      const Eigen::Index i = order != nullptr ? static_cast<Eigen::Index>((*order)[t]) : t;
      const double q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
      double cap = std::numeric_limits<double>::infinity();
      if (have_prev) {
        const double dx = q[0] - prev_q[0], dy = q[1] - prev_q[1], dz = q[2] - prev_q[2];
        const double r = std::sqrt(prev_kth) + std::sqrt(dx * dx + dy * dy + dz * dz);
        cap = r * r * (1 + 1e-9) + 1e-300;  // outward: rounding must not cut the k-th point off
      }
      uint32_t* out = index.data() + static_cast<size_t>(i) * uk;
      CappedKnn result(uk, cap);
      result.init(out, d2.data());
      impl_->tree.findNeighbors(result, q, nanoflann::SearchParams());
      if (result.size() < uk) {  // cannot happen (the cap holds k points), but never return fewer
        CappedKnn again(uk, std::numeric_limits<double>::infinity());
        again.init(out, d2.data());
        impl_->tree.findNeighbors(again, q, nanoflann::SearchParams());
      }
      std::copy(q, q + 3, prev_q);
      prev_kth = d2[uk - 1];
      have_prev = true;
    }
  });
}

}  // namespace sdfkit
