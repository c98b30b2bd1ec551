#include "core/error.h"
#include "sdf/distance.h"
#include "sdf/orientation.h"
#include "sdf/samples.h"
#include "test_meshes.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

using namespace sdfkit;

namespace {
/// A coarser grid than the default keeps the tests fast; the sampling logic does not depend on the voxel size.
/// The default band (3 voxels = 0.06) is narrower than the bins (|sdf| <= 0.103): samples must not need it.
SparseSdfSettings coarse() {
  SparseSdfSettings s;
  s.voxel_size = 0.02;
  return s;
}
}  // namespace

TEST_CASE("samples: four equal bins on d = sdf - 0.003, every stored sdf is the exact distance") {
  SampleSettings ss;
  ss.count = 4000;
  ss.seed = 9;
  for (const auto& c : test::hard_cases()) {
    if (c.name == "thin plate") continue;  // cannot fill the inner bins; see the next test
    CAPTURE(c.name);
    // As prepare_mesh does: validated (duplicate faces would count twice in the winding number) and oriented.
    const Mesh m = orient_consistently(validate_mesh(c.mesh, c.name));
    const SparseSdf sdf = SparseSdf::from_mesh(m, coarse());
    SampleReport rep;
    const MatrixXfR S = disn_samples(m, sdf, ss, &rep);
    REQUIRE(S.rows() == 4000);
    CHECK(rep.redistributed == 0);
    std::array<long, 4> count{};
    long bad_distance = 0, bad_sign = 0, off_grid = 0, not_rounded = 0;
    for (Eigen::Index i = 0; i < S.rows(); ++i) {
      const Vec3 p = S.row(i).head<3>().cast<double>().transpose();
      const double v = S(i, 3);
      const double d = v - 0.003;
      int bin = d < -0.03 ? 0 : d < 0 ? 1 : d < 0.03 ? 2 : 3;
      if (d >= -0.1 - 1e-6 && d <= 0.1 + 1e-6) ++count[bin];
      const double bf = MeshDistance::brute_force(c.mesh, p);
      if (std::abs(std::abs(v) - bf) > 1e-4) ++bad_distance;
      // The stored value is the float32 rounding of the exact distance of the stored (float32) point.
      if (static_cast<float>(std::abs(v)) != static_cast<float>(bf)) ++not_rounded;
      if (c.sdf && std::isfinite(c.sdf(p)) && std::abs(c.sdf(p)) > 2e-3 &&  // polygonised sphere/torus vs closed form
           (c.sdf(p) < 0) != (v < 0)) ++bad_sign;
      if (c.expected && c.expected(p) != 0 && (v < 0 ? -1 : 1) != c.expected(p)) ++bad_sign;
      // Continuous positions, not grid points.
      if (std::abs(p.x() / sdf.voxel_size() - std::round(p.x() / sdf.voxel_size())) < 1e-6) ++off_grid;
    }
    // Sample i of bin b sits in rows [b * 1000, (b + 1) * 1000).
    for (int b = 0; b < 4; ++b) CHECK(count[b] == 1000);
    for (int b = 0; b < 4; ++b) CHECK(rep.bin_counts[b] == 1000);
    CHECK(bad_distance == 0);
    CHECK(not_rounded <= 4);  // a BVH and a brute-force sum may round a tie differently, very rarely
    CHECK(bad_sign == 0);
    CHECK(off_grid < 10);
  }
}

TEST_CASE("samples: a plate thinner than the inner bins redistributes, keeps the total, reports it") {
  const Mesh plate = make_box(Vec3(-0.5, -0.4, -0.002), Vec3(0.5, 0.4, 0.002));
  const SparseSdf sdf = SparseSdf::from_mesh(plate, coarse());
  SampleSettings ss;
  ss.count = 2000;
  SampleReport rep;
  const MatrixXfR S = disn_samples(plate, sdf, ss, &rep);
  CHECK(S.rows() == 2000);
  CHECK(rep.bin_counts[0] == 0);  // nothing deeper than 0.027 inside a 0.004 plate
  CHECK(rep.redistributed == 500);
  CHECK(rep.bin_counts[0] + rep.bin_counts[1] + rep.bin_counts[2] + rep.bin_counts[3] == 2000);
  CHECK(S.allFinite());
}

TEST_CASE("samples: same seed -> identical bytes for 1 and 2 threads, uniform share, other seed differs") {
  const Mesh m = make_torus(Vec3::Zero(), 0.6, 0.25, 64, 32);
  const SparseSdf sdf = SparseSdf::from_mesh(m, coarse());
  SampleSettings ss;
  ss.count = 3000;
  ss.uniform_share = 0.2;
  ss.seed = 4;
  MatrixXfR one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = disn_samples(m, sdf, ss);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = disn_samples(m, sdf, ss);
  }
  CHECK(one == two);
  // The last 600 rows are uniform in [-1.2, 1.2]^3 with exact distances.
  for (Eigen::Index i = 2400; i < 3000; ++i) {
    CHECK(one.row(i).head<3>().cwiseAbs().maxCoeff() <= 1.2f);
    const Vec3 p = one.row(i).head<3>().cast<double>().transpose();
    CHECK(std::abs(one(i, 3) - torus_sdf(p, Vec3::Zero(), 0.6, 0.25)) < 3e-3);  // polygonal torus
  }
  ss.seed = 5;
  CHECK_FALSE(disn_samples(m, sdf, ss) == one);
}
