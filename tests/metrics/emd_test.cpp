#include "metrics/emd.h"

#include "core/error.h"
#include "core/random.h"
#include "test_util.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <numeric>

using namespace sdfkit;
using namespace sdfkit::testing;

namespace {

Points permuted(const Points& p, uint64_t seed) {
  std::vector<int> order(p.rows());
  std::iota(order.begin(), order.end(), 0);
  Rng rng(seed);
  for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.below(i)]);
  Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(i) = p.row(order[i]);
  return q;
}

// Two clusters of very different sizes on each side: nearest-neighbour candidates alone cannot match them, so
// the certificate must add edges.
Points clustered(long n, uint64_t seed, double split, double offset) {
  Rng rng(seed);
  Points p(n, 3);
  for (long i = 0; i < n; ++i) {
    const bool left = rng.uniform() < split;
    p.row(i) << rng.uniform(-0.1, 0.1) + (left ? -offset : offset), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1);
  }
  return p;
}

}  // namespace

TEST_CASE("exact EMD equals the brute-force Hungarian optimum (n <= 200)") {
  for (int n : {1, 2, 7, 50, 200}) {
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      const Points a = random_cloud(n, seed * 31 + n), b = random_cloud(n, seed * 37 + n + 5, 0.7);
      const EmdResult ref = emd_hungarian(a, b);
      const EmdResult e = emd_exact(a, b);
      // certified: optimum <= total <= optimum + gap_bound, gap_bound <= tolerance x diagonal (< 4e-9 here)
      CHECK(e.total >= ref.total - 1e-9);
      CHECK(e.total <= ref.total + e.gap_bound + 1e-9);
      CHECK(e.gap_bound <= 4e-9);
      CHECK(e.total == doctest::Approx(ref.total).epsilon(1e-10));
      // the returned matching is a permutation whose cost is the total
      std::vector<int> m = e.match;
      double cost = 0;
      for (int i = 0; i < n; ++i) cost += (a.row(i) - b.row(m[i])).norm();
      CHECK(cost == doctest::Approx(e.total).epsilon(1e-12));
      std::sort(m.begin(), m.end());
      for (int i = 0; i < n; ++i) CHECK(m[i] == i);
    }
  }
  // Unbalanced clusters force the certificate to add edges (more than one round) and still match the optimum.
  const Points a = clustered(150, 3, 0.8, 1.0), b = clustered(150, 4, 0.2, 1.0);
  const EmdResult e = emd_exact(a, b, EmdSettings{EmdMethod::kExact, 4, 1e-9});
  CHECK(e.rounds >= 2);
  CHECK(e.total == doctest::Approx(emd_hungarian(a, b).total).epsilon(1e-10));
  // Duplicated points (ties everywhere)
  Points d = random_cloud(40, 9);
  d.bottomRows(20) = d.topRows(20);
  const Points d2 = random_cloud(40, 10);
  CHECK(emd_exact(d, d2).total == doctest::Approx(emd_hungarian(d, d2).total).epsilon(1e-10));
}

// The sparse + certified solver against the dense Hungarian method on inputs that defeat k-NN candidate graphs:
// duplicates, all points equal, far clusters of unequal sizes, a few distinct points with many copies.
void check_against_dense(const Points& a, const Points& b, const EmdSettings& settings = {}) {
  const EmdResult ref = emd_hungarian(a, b);
  const EmdResult e = emd_exact(a, b, settings);
  const double diag = 4.0;  // every input below lies in [-2, 2]^3 or closer
  CHECK(e.gap_bound >= 0);
  CHECK(e.gap_bound <= settings.tolerance * diag * std::sqrt(3.0) + 1e-12);
  CHECK(e.total >= ref.total - 1e-9);
  CHECK(e.total <= ref.total + e.gap_bound + 1e-9);
  CHECK(e.total == doctest::Approx(ref.total).epsilon(1e-11));
  std::vector<int> m = e.match;
  std::sort(m.begin(), m.end());
  for (int i = 0; i < static_cast<int>(m.size()); ++i) REQUIRE(m[i] == i);
}

TEST_CASE("sparse + certified EMD equals the dense solver on degenerate and clustered inputs") {
  SUBCASE("duplicated points on both sides (vertex sampling with replacement, as the disn protocol does)") {
    const Points va = random_cloud(23, 40), vb = random_cloud(37, 41, 0.8);
    Points a(250, 3), b(250, 3);
    Rng rng(42);
    for (int i = 0; i < 250; ++i) {
      a.row(i) = va.row(static_cast<Eigen::Index>(rng.below(23)));
      b.row(i) = vb.row(static_cast<Eigen::Index>(rng.below(37)));
    }
    check_against_dense(a, b);
    check_against_dense(a, b, EmdSettings{EmdMethod::kExact, 2, 1e-9});  // tiny graph: the certificate does the work
  }
  SUBCASE("all points of one set equal; all points of both sets equal") {
    const Points b = random_cloud(200, 43);
    Points a(200, 3);
    a.rowwise() = Eigen::RowVector3d(0.3, -0.2, 0.1);
    check_against_dense(a, b);
    const EmdResult same = emd_exact(a, a);
    CHECK(same.total == 0.0);
  }
  SUBCASE("two far clusters of unequal sizes (80/20 against 20/80)") {
    const Points a = clustered(240, 44, 0.8, 1.5), b = clustered(240, 45, 0.2, 1.5);
    check_against_dense(a, b);
    check_against_dense(a, b, EmdSettings{EmdMethod::kExact, 4, 1e-9});
  }
  SUBCASE("three distinct points with many copies against three others") {
    Rng rng(46);
    Points a(180, 3), b(180, 3);
    for (int i = 0; i < 180; ++i) {
      a.row(i) << static_cast<double>(rng.below(3)), 0, 0;
      b.row(i) << 0.5 * static_cast<double>(rng.below(3)), 1, 0;
    }
    check_against_dense(a, b);
  }
}

TEST_CASE("EMD of a permutation of the same cloud is 0, of a translated cloud it is n |t|") {
  const Points a = random_cloud(500, 5);
  const Points b = permuted(a, 6);
  const EmdResult e = emd(a, b);
  CHECK(e.total == 0.0);
  for (int i = 0; i < 500; ++i) CHECK(b.row(e.match[i]) == a.row(i));
  // A rigid translation by t smaller than... any: the identity matching costs n|t| and no matching costs less
  // (sum |a_i - b_m(i)| >= |sum (a_i - b_m(i))| = n |t|).
  Points c = a;
  c.rowwise() += Eigen::RowVector3d(0.01, -0.02, 0.005);
  CHECK(emd(a, c).total == doctest::Approx(500 * Vec3(0.01, -0.02, 0.005).norm()).epsilon(1e-9));
}

TEST_CASE("exact EMD does not depend on the thread count, approx EMD is deterministic and above the optimum") {
  const Points a = random_cloud(300, 21), b = random_cloud(300, 22, 0.9);
  EmdResult one, two, ap1, ap2;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = emd_exact(a, b);
    ap1 = emd_approx(a, b);
  }
  two = emd_exact(a, b);
  ap2 = emd_approx(a, b);
  CHECK(one.total == two.total);
  CHECK(one.match == two.match);
  CHECK(ap1.total == ap2.total);
  // The approximate plan moves (almost) all the mass, so its cost is at least about the optimum, and for
  // well-spread clouds within a modest factor of it.
  CHECK(ap1.total > 0.98 * one.total);
  CHECK(ap1.total < 1.5 * one.total);
  CHECK(emd_approx(a, permuted(a, 3)).total < 0.05 * one.total);
}

TEST_CASE("EMD refuses mismatched sizes, empty and NaN sets with a clear message") {
  const Points a = random_cloud(10, 1), b = random_cloud(11, 2);
  CHECK_THROWS_WITH_AS(emd(a, b), doctest::Contains("same size, got 10 and 11"), InvalidInput);
  CHECK_THROWS_AS(emd(Points(0, 3), Points(0, 3)), InvalidInput);
  Points nan = a;
  nan(0, 0) = std::nan("");
  CHECK_THROWS_WITH_AS(emd(a, nan), doctest::Contains("non-finite"), InvalidInput);
  CHECK_THROWS_AS(emd_approx(a, b), InvalidInput);
  CHECK(parse_emd_method("approx") == EmdMethod::kApprox);
  CHECK_THROWS_AS(parse_emd_method("fast"), InvalidInput);
}
