#include "core/simd.h"

#include "core/primitives.h"
#include "metrics/emd.h"
#include "metrics/grid_nn.h"
#include "metrics/sampling.h"
#include "test_util.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;
using namespace sdfkit::testing;

namespace {

struct RestoreAvx2 {
  bool saved = avx2_enabled();
  ~RestoreAvx2() { set_avx2_enabled(saved); }
};

}  // namespace

// The AVX2 kernels and the portable ones must give the same bits: same IEEE operations, same order, no FMA.
TEST_CASE("vectorised kernels: AVX2 and portable versions give identical results") {
  const RestoreAvx2 restore;
  const std::string avx2 = avx2_enabled() ? "yes" : "no (both runs use the portable kernels)";
  MESSAGE("AVX2 available on this CPU: " << avx2);
  // Sizes that leave remainders for both the 4- and the 8-lane loops.
  const Points a = sample_surface(make_torus(Vec3::Zero(), 0.65, 0.30, 32, 16), 517, 1).points;
  const Points b = sample_surface(make_torus(Vec3(0.03, 0, -0.02), 0.6, 0.33, 32, 16), 517, 2).points;

  set_avx2_enabled(true);
  const EmdResult e1 = emd_exact(a, b);
  const NearestGrid g1(b);
  Eigen::VectorXi i1;
  Eigen::VectorXd d1;
  g1.nearest(random_cloud(3001, 3, 1.2), i1, d1);

  set_avx2_enabled(false);
  CHECK_FALSE(avx2_enabled());
  const EmdResult e2 = emd_exact(a, b);
  const NearestGrid g2(b);
  Eigen::VectorXi i2;
  Eigen::VectorXd d2;
  g2.nearest(random_cloud(3001, 3, 1.2), i2, d2);

  CHECK(e1.total == e2.total);
  CHECK(e1.match == e2.match);
  CHECK(e1.gap_bound == e2.gap_bound);
  CHECK(e1.bids == e2.bids);  // the auction's 4-lane bid scan makes the same bids
  CHECK(e1.path_scans == e2.path_scans);
  CHECK(i1 == i2);
  CHECK(d1 == d2);
  // and the EMD is the optimum (brute-force Hungarian) in both cases
  CHECK(e2.total == doctest::Approx(emd_hungarian(a, b).total).epsilon(1e-12));
}
