#include "metrics/chamfer.h"

#include "core/error.h"
#include "test_util.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;
using namespace sdfkit::testing;

TEST_CASE("Chamfer distances and F-scores match brute force on random clouds") {
  const Points a = random_cloud(700, 11);
  const Points b = random_cloud(900, 12, 0.8);
  double acc = 0, acc2 = 0, comp = 0, comp2 = 0;
  std::vector<double> da, db;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    const double d2 = brute_nearest(b, a.row(i)).second;
    acc += std::sqrt(d2);
    acc2 += d2;
    da.push_back(std::sqrt(d2));
  }
  for (Eigen::Index i = 0; i < b.rows(); ++i) {
    const double d2 = brute_nearest(a, b.row(i)).second;
    comp += std::sqrt(d2);
    comp2 += d2;
    db.push_back(std::sqrt(d2));
  }
  acc /= 700, acc2 /= 700, comp /= 900, comp2 /= 900;
  const PairEvaluator pair(a, b);
  const ChamferResult c = pair.chamfer();
  CHECK(c.accuracy == doctest::Approx(acc).epsilon(1e-12));
  CHECK(c.completeness == doctest::Approx(comp).epsilon(1e-12));
  CHECK(c.cd_squared() == doctest::Approx(acc2 + comp2).epsilon(1e-12));
  CHECK(c.cd_l1() == doctest::Approx(0.5 * (acc + comp)).epsilon(1e-12));
  CHECK(c.cd_l2() == doctest::Approx(0.5 * (acc2 + comp2)).epsilon(1e-12));
  // one-off function = evaluator
  CHECK(chamfer(a, b).cd_squared() == c.cd_squared());
  // swapping the roles swaps accuracy and completeness
  const ChamferResult s = chamfer(b, a);
  CHECK(s.accuracy == doctest::Approx(c.completeness).epsilon(1e-14));
  for (double t : {0.02, 0.05, 0.1, 0.2}) {
    long pa = 0, pb = 0;
    for (double d : da) pa += d < t;
    for (double d : db) pb += d < t;
    const FScore f = pair.fscore(t);
    CHECK(f.precision == doctest::Approx(pa / 700.0));
    CHECK(f.recall == doctest::Approx(pb / 900.0));
    const double P = pa / 700.0, R = pb / 900.0;
    CHECK(f.fscore == doctest::Approx(P + R > 0 ? 2 * P * R / (P + R) : 0.0));
  }
}

TEST_CASE("Chamfer of identical sets is 0, of a shifted set it is the shift, F-score threshold is strict") {
  const Points a = random_cloud(300, 3);
  CHECK(chamfer(a, a).cd_squared() == 0.0);
  // Single points at distance exactly 0.5: F at threshold 0.5 is 0 (strict <), slightly above it is 1.
  Points p(1, 3), q(1, 3);
  p << 0, 0, 0;
  q << 0.5, 0, 0;
  const PairEvaluator pq(p, q);
  CHECK(pq.chamfer().cd_squared() == doctest::Approx(0.5));  // 0.25 + 0.25
  CHECK(pq.chamfer().cd_l1() == doctest::Approx(0.5));
  CHECK(pq.fscore(0.5).fscore == 0.0);
  CHECK(pq.fscore(0.5000001).fscore == 1.0);
  CHECK(f_from_pr(0, 0) == 0.0);
  CHECK(f_from_pr(1, 0.5) == doctest::Approx(2.0 / 3.0));
}

TEST_CASE("Chamfer refuses empty and NaN clouds") {
  const Points a = random_cloud(10, 1);
  CHECK_THROWS_WITH_AS(chamfer(Points(0, 3), a), doctest::Contains("prediction"), InvalidInput);
  Points nan = a;
  nan(2, 2) = std::nan("");
  CHECK_THROWS_WITH_AS(chamfer(a, nan), doctest::Contains("ground truth"), InvalidInput);
  CHECK_THROWS_AS((void)PairEvaluator(a, a).fscore(0.0), InvalidInput);
}
