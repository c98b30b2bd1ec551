#include "metrics/kdtree.h"

#include "core/error.h"
#include "test_util.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <limits>
#include <tbb/global_control.h>

using namespace sdfkit;
using namespace sdfkit::testing;

TEST_CASE("KD-tree nearest and knn agree with brute force") {
  const Points set = random_cloud(3000, 1);
  const Points queries = random_cloud(500, 2, 1.3);
  KdTree tree(set);
  Eigen::VectorXi idx;
  Eigen::VectorXd d2;
  tree.nearest(queries, idx, d2);
  for (Eigen::Index i = 0; i < queries.rows(); ++i) {
    const auto [j, bd2] = brute_nearest(set, queries.row(i));
    CHECK(d2(i) == doctest::Approx(bd2).epsilon(1e-12));
    CHECK((set.row(idx(i)) - queries.row(i)).squaredNorm() == doctest::Approx(bd2).epsilon(1e-12));
  }
  // knn: the k smallest distances, sorted
  for (int i = 0; i < 20; ++i) {
    const Vec3 q = queries.row(i);
    std::vector<double> all(set.rows());
    for (Eigen::Index j = 0; j < set.rows(); ++j) all[j] = (set.row(j) - q.transpose()).squaredNorm();
    std::sort(all.begin(), all.end());
    const auto nn = tree.knn(q, 16);
    REQUIRE(nn.size() == 16);
    for (int k = 0; k < 16; ++k) CHECK(nn[k].second == doctest::Approx(all[k]).epsilon(1e-12));
  }
  CHECK(tree.knn(Vec3::Zero(), 5000).size() == 3000);
  // ordered queries (warm-started from the previous neighbour) give the same distances
  const KdTree qtree(queries);
  const std::vector<uint32_t> order = qtree.leaf_order();
  Eigen::VectorXi idx2;
  Eigen::VectorXd d2b;
  tree.nearest(queries, idx2, d2b, &order);
  CHECK(d2b == d2);
  std::vector<uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (uint32_t i = 0; i < sorted.size(); ++i) CHECK(sorted[i] == i);
}

TEST_CASE("KD-tree survives a move and gives the same answers with one or two threads") {
  const Points set = random_cloud(2000, 5);
  const Points queries = random_cloud(2000, 6);
  KdTree a(set);
  KdTree b = std::move(a);
  Eigen::VectorXi i1, i2;
  Eigen::VectorXd d1, d2;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b.nearest(queries, i1, d1);
  }
  b.nearest(queries, i2, d2);
  CHECK(i1 == i2);
  CHECK(d1 == d2);
}

TEST_CASE("KD-tree refuses empty and non-finite sets") {
  CHECK_THROWS_AS(KdTree(Points(0, 3)), InvalidInput);
  Points p = random_cloud(10, 1);
  p(3, 1) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH_AS(KdTree(p, "gt.xyz"), doctest::Contains("gt.xyz"), InvalidInput);
}

// knn_batch starts each search with a radius from the previous query; it must keep exactly the neighbours (and
// their order, ties included) of independent searches, in any visiting order and with any thread count.
TEST_CASE("KD-tree knn_batch equals one knn per query, ties on a lattice included") {
  Points lattice(6 * 6 * 6, 3);  // integer lattice: many equal distances
  for (int i = 0; i < 216; ++i) lattice.row(i) = Vec3(i % 6, (i / 6) % 6, i / 36).transpose();
  for (const Points& set : {random_cloud(1500, 8), lattice}) {
    const KdTree tree(set);
    Points queries = random_cloud(700, 9, 3.0);
    queries.topRows(216) = lattice;  // queries on lattice points: exact ties at every rank
    const KdTree query_tree(queries);
    const std::vector<uint32_t> order = query_tree.leaf_order();
    for (int k : {1, 7, 24}) {
      std::vector<uint32_t> plain, ordered, one_thread;
      tree.knn_batch(queries, k, plain);
      tree.knn_batch(queries, k, ordered, &order);
      {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        tree.knn_batch(queries, k, one_thread, &order);
      }
      int mismatches = 0;
      for (Eigen::Index q = 0; q < queries.rows(); ++q) {
        const auto ref = tree.knn(queries.row(q).transpose(), k);
        for (int r = 0; r < k; ++r) {
          const size_t at = static_cast<size_t>(q) * k + r;
          mismatches += (plain[at] != static_cast<uint32_t>(ref[r].first)) + (ordered[at] != plain[at]);
        }
      }
      CHECK(mismatches == 0);
      CHECK(one_thread == ordered);
    }
  }
  std::vector<uint32_t> out;
  CHECK_THROWS_AS(KdTree(random_cloud(5, 1)).knn_batch(random_cloud(3, 2), 6, out), InvalidInput);  // k > size
}
