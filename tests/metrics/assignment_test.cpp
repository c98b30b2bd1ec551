#include "metrics/assignment.h"

#include "core/error.h"
#include "core/random.h"
#include "core/simd.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

using namespace sdfkit;

namespace {

double brute_force_min(const Eigen::MatrixXd& c) {
  std::vector<int> p(c.rows());
  std::iota(p.begin(), p.end(), 0);
  double best = 1e300;
  do {
    double s = 0;
    for (int i = 0; i < c.rows(); ++i) s += c(i, p[i]);
    best = std::min(best, s);
  } while (std::next_permutation(p.begin(), p.end()));
  return best;
}

Eigen::MatrixXd random_costs(int n, uint64_t seed, int distinct_values = 0) {
  Rng rng(seed);
  Eigen::MatrixXd c(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      c(i, j) = distinct_values > 0 ? static_cast<double>(rng.below(distinct_values)) : rng.uniform();
  return c;
}

}  // namespace

TEST_CASE("Hungarian method equals the minimum over all permutations (n <= 7)") {
  for (int n = 1; n <= 7; ++n)
    for (uint64_t seed = 0; seed < 6; ++seed) {
      // integer costs with few values: many ties
      const Eigen::MatrixXd c = random_costs(n, 100 * n + seed, seed % 2 == 0 ? 0 : 3);
      double total = 0;
      const std::vector<int> m = hungarian(c, &total);
      std::vector<int> sorted = m;
      std::sort(sorted.begin(), sorted.end());
      for (int i = 0; i < n; ++i) CHECK(sorted[i] == i);  // a permutation
      CHECK(total == doctest::Approx(brute_force_min(c)).epsilon(1e-12));
    }
  CHECK_THROWS_AS(hungarian(Eigen::MatrixXd::Zero(2, 3)), InvalidInput);
}

TEST_CASE("auction with epsilon scaling on a complete graph is within n eps of the Hungarian optimum") {
  for (int n : {1, 3, 10, 60}) {
    const Eigen::MatrixXd c = random_costs(n, 7 * n, n == 60 ? 5 : 0);
    SparseAuction s(n);
    for (int i = 0; i < n; ++i) {
      std::vector<std::pair<int, double>> e;
      for (int j = 0; j < n; ++j) e.emplace_back(j, c(i, j));
      s.add_edges(i, e);
    }
    const double eps = 1e-9;
    s.solve(1.0, eps);
    double total = 0, ref = 0;
    std::vector<int> m = s.col_of_row();
    for (int i = 0; i < n; ++i) total += c(i, m[i]);
    hungarian(c, &ref);
    CHECK(total >= ref - 1e-12);
    CHECK(total <= ref + n * eps + 1e-12);
    std::sort(m.begin(), m.end());
    for (int i = 0; i < n; ++i) CHECK(m[i] == i);
    // eps-complementary slackness on every edge
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        CHECK(c(i, s.col_of_row()[i]) + s.prices()[s.col_of_row()[i]] <= c(i, j) + s.prices()[j] + eps + 1e-12);
  }
}

TEST_CASE("a graph without a perfect matching is completed before the auction") {
  SparseAuction s(3);
  s.add_edges(0, {{0, 1.0}});
  s.add_edges(1, {{0, 2.0}});  // rows 0 and 1 both only reach column 0
  s.add_edges(2, {{1, 0.5}, {2, 0.5}});
  const int completed = s.ensure_perfect_matching([](int i, int j) { return double(i + j); });
  CHECK(completed == 1);
  s.solve(1.0, 1e-9);
  std::vector<int> m = s.col_of_row();
  std::sort(m.begin(), m.end());
  CHECK(m == std::vector<int>{0, 1, 2});
}

TEST_CASE("shortest augmenting paths: exact optimum on complete and sparse graphs, warm re-solve after new edges") {
  for (int n : {1, 4, 30, 120}) {
    for (int distinct : {0, 3}) {  // continuous costs, and integer costs with many ties
      const Eigen::MatrixXd c = random_costs(n, 11 * n + distinct, distinct);
      double ref = 0;
      hungarian(c, &ref);
      // complete graph
      SparseShortestPath full(n);
      for (int i = 0; i < n; ++i) {
        std::vector<std::pair<int, double>> e;
        for (int j = 0; j < n; ++j) e.emplace_back(j, c(i, j));
        full.add_edges(i, e);
      }
      full.solve();
      double total = 0;
      for (int i = 0; i < n; ++i) total += c(i, full.col_of_row()[i]);
      CHECK(total == doctest::Approx(ref).epsilon(1e-12));
      // complementary slackness holds exactly (up to rounding) on every edge: the prices certify optimality
      const std::vector<double> p = full.prices();
      for (int i = 0; i < n; ++i) {
        CHECK(full.slack(i) <= 1e-12);
        for (int j = 0; j < n; ++j) CHECK(c(i, full.col_of_row()[i]) + p[full.col_of_row()[i]] <= c(i, j) + p[j] + 1e-12);
      }
      // sparse graph: the identity permutation plus 3 random columns per row; then every edge added (warm)
      SparseShortestPath sparse(n);
      Rng rng(5 * n + distinct);
      for (int i = 0; i < n; ++i) {
        std::vector<std::pair<int, double>> e{{i, c(i, i)}};
        for (int t = 0; t < 3; ++t) {
          const int j = static_cast<int>(rng.below(static_cast<uint64_t>(n)));
          e.emplace_back(j, c(i, j));
        }
        sparse.add_edges(i, e);
      }
      sparse.solve();
      double graph_total = 0;
      for (int i = 0; i < n; ++i) graph_total += c(i, sparse.col_of_row()[i]);
      CHECK(graph_total >= ref - 1e-9);
      for (int i = 0; i < n; ++i) {
        std::vector<std::pair<int, double>> e;
        for (int j = 0; j < n; ++j) e.emplace_back(j, c(i, j));
        sparse.add_edges(i, e);  // frees the rows the new edges undercut
      }
      sparse.solve();
      total = 0;
      std::vector<int> m = sparse.col_of_row();
      for (int i = 0; i < n; ++i) total += c(i, m[i]);
      CHECK(total == doctest::Approx(ref).epsilon(1e-12));
      std::sort(m.begin(), m.end());
      for (int i = 0; i < n; ++i) CHECK(m[i] == i);
    }
  }
  // warm start from given prices: same optimum
  const Eigen::MatrixXd c = random_costs(40, 99);
  double ref = 0;
  hungarian(c, &ref);
  SparseShortestPath s(40);
  for (int i = 0; i < 40; ++i) {
    std::vector<std::pair<int, double>> e;
    for (int j = 0; j < 40; ++j) e.emplace_back(j, c(i, j));
    s.add_edges(i, e);
  }
  std::vector<double> prices(40);
  Rng rng(3);
  for (double& q : prices) q = rng.uniform();
  s.reset(prices);
  s.solve();
  double total = 0;
  for (int i = 0; i < 40; ++i) total += c(i, s.col_of_row()[i]);
  CHECK(total == doctest::Approx(ref).epsilon(1e-12));
  // a graph without a perfect matching is refused
  SparseShortestPath bad(2);
  bad.add_edges(0, {{0, 1.0}});
  bad.add_edges(1, {{0, 1.0}});
  CHECK_THROWS_AS(bad.solve(), InvalidInput);
}

// The auction's bid scan has a 4-lane AVX2 version (chosen at run time) and a portable one; they must make the
// same bids, including the choice among columns of equal value (the smallest column) on integer costs.
TEST_CASE("auction: AVX2 and portable bid scans give the same prices, bids and assignment, ties included") {
  const bool saved = avx2_enabled();
  for (int n : {5, 37, 90}) {
    for (int distinct : {0, 2, 4}) {
      const Eigen::MatrixXd c = random_costs(n, 3 * n + distinct, distinct);
      Rng rng(n + 100 * distinct);
      std::vector<std::vector<std::pair<int, double>>> rows(n);
      for (int i = 0; i < n; ++i) {  // rows of 1 .. n edges: remainders of every size for the 4-lane loop
        const int m = 1 + static_cast<int>(rng.below(static_cast<uint64_t>(n)));
        rows[i].emplace_back(i, c(i, i));
        for (int t = 0; t < m; ++t) {
          const int j = static_cast<int>(rng.below(static_cast<uint64_t>(n)));
          rows[i].emplace_back(j, c(i, j));
        }
      }
      std::vector<int> match[2];
      std::vector<double> prices[2];
      long bids[2];
      for (int v = 0; v < 2; ++v) {
        set_avx2_enabled(v == 0);
        SparseAuction s(n);
        for (int i = 0; i < n; ++i) s.add_edges(i, rows[i]);
        s.solve(1.0, 1e-6);
        match[v] = s.col_of_row();
        prices[v] = s.prices();
        bids[v] = s.num_bids();
      }
      CHECK(match[0] == match[1]);
      CHECK(prices[0] == prices[1]);
      CHECK(bids[0] == bids[1]);
    }
  }
  set_avx2_enabled(saved);
}

TEST_CASE("EdgeRows: rows stay sorted with the lowest cost per column while they grow, bad input is refused") {
  EdgeRows g(4);
  CHECK(g.add(2, {{3, 1.0}, {1, 2.0}, {3, 0.5}}) == 2);
  CHECK(g.add(0, {{0, 1.0}}) == 1);
  for (int t = 0; t < 20; ++t) CHECK(g.add(2, {{t % 4, 1.0 + t}}) == (t == 0 || t == 2 ? 1 : 0));  // moves, regrows
  REQUIRE(g.size(2) == 4);
  CHECK(std::vector<int>(g.cols(2), g.cols(2) + 4) == std::vector<int>{0, 1, 2, 3});
  CHECK(g.cost(2, 3) == 0.5);   // the lowest of 1.0, 0.5 and the later 4.0, 8.0, ...
  CHECK(g.cost(2, 0) == 1.0);
  CHECK(g.cost(2, 2) == 3.0);
  CHECK(g.cost(0, 0) == 1.0);   // row 0 untouched by row 2's moves
  CHECK(g.num_edges() == 5);
  CHECK_THROWS_AS(g.add(1, {{4, 1.0}}), InvalidInput);
  CHECK_THROWS_AS(g.add(1, {{0, std::nan("")}}), InvalidInput);
  CHECK_THROWS_AS(EdgeRows(2, {0, 2, 3}, {1, 0, 1}, {1.0, 1.0, 1.0}), InvalidInput);  // row 0 not sorted
  const EdgeRows h(2, {0, 2, 3}, {0, 1, 1}, {1.0, 2.0, 3.0});
  CHECK(h.cost(0, 1) == 2.0);
  CHECK(h.cost(1, 1) == 3.0);
}
