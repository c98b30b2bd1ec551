#include "metrics/kdtree.h"

#include "core/error.h"
#include "metrics/sampling.h"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sdfkit::metrics {
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
  constexpr Eigen::Index block = 256;
  const Eigen::Index blocks = (n + block - 1) / block;
  tbb::parallel_for(Eigen::Index(0), blocks, [&](Eigen::Index b) {
    uint32_t prev = 0;
    bool have_prev = false;
    for (Eigen::Index k = b * block; k < std::min(n, (b + 1) * block); ++k) {
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

}  // namespace sdfkit::metrics
