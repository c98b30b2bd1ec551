#include "core/json.h"
#include "metrics/protocols.h"

#include "core/error.h"
#include "core/primitives.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace sdfkit;

namespace {

// A triangle of size 1e-7 at p: every sample of it (vertex or surface) is p to within 1e-7, so every distance
// between two of them is known by hand.
Mesh speck(const Vec3& p) {
  Mesh m;
  m.V.resize(3, 3);
  m.V.row(0) = p.transpose();
  m.V.row(1) = (p + Vec3(1e-7, 0, 0)).transpose();
  m.V.row(2) = (p + Vec3(0, 1e-7, 0)).transpose();
  m.F.resize(1, 3);
  m.F << 0, 1, 2;
  return m;
}

double value(const EvalResult& r, const std::string& key) {
  const auto v = r.get(key);
  REQUIRE_MESSAGE(v.has_value(), key);
  return *v;
}

}  // namespace

TEST_CASE("disn protocol reproduces the hand-computed example: two specks 0.1 apart") {
  // Every pred->gt and gt->pred distance is 0.1: CD = (0.01 + 0.01) x 1000 = 20; EMD = n x 0.1 x 0.01 (n = 2048:
  // 2.048; the test uses n = 256 to stay fast: all costs tie to 1e-7, the auction's slowest case);
  // thresholds 0.0125, 0.025, 0.05 are below 0.1 (P = R = F = 0), 0.125, 0.25, 0.5 above (100%);
  // IoU: the specks fall in voxel columns floor(1.1/2.4*110) = 50 and floor(1.2/2.4*110) = 55: IoU 0.
  ProtocolSettings s;
  s.samples = 256;
  const EvalResult r = evaluate(speck(Vec3::Zero()), speck(Vec3(0.1, 0, 0)), s);
  CHECK(r.samples == 256);
  CHECK(value(r, "cd") == doctest::Approx(20.0).epsilon(1e-5));
  CHECK(value(r, "emd") == doctest::Approx(0.256).epsilon(1e-5));
  for (const char* k : {"f_0.5", "f_1", "f_2", "p_2", "r_2"}) CHECK(value(r, k) == 0.0);
  for (const char* k : {"f_5", "f_10", "f_20", "p_5", "r_20"}) CHECK(value(r, k) == 100.0);
  CHECK(value(r, "iou") == 0.0);
  CHECK(r.metrics.size() == metric_keys(Protocol::kDisn).size());
  // approximate EMD on this example: all mass moves 0.1 whatever the plan
  ProtocolSettings approx = s;
  approx.emd = EmdMethod::kApprox;
  CHECK(value(evaluate(speck(Vec3::Zero()), speck(Vec3(0.1, 0, 0)), approx), "emd") ==
        doctest::Approx(0.256).epsilon(1e-3));
  // the default sample count is DISN's 2048
  ProtocolSettings quick;
  quick.with_emd = false;
  CHECK(evaluate(speck(Vec3::Zero()), speck(Vec3(0.1, 0, 0)), quick).samples == 2048);
}

TEST_CASE("tmnet protocol reproduces the hand-computed example") {
  ProtocolSettings s;
  s.protocol = Protocol::kTmnet;
  s.samples = 256;  // the numbers below do not depend on n
  const EvalResult r = evaluate(speck(Vec3::Zero()), speck(Vec3(0, 0.2, 0)), s);
  CHECK(value(r, "cd") == doctest::Approx((0.04 + 0.04) * 1000).epsilon(1e-5));  // 80
  CHECK(value(r, "emd") == doctest::Approx(0.2 * 100).epsilon(1e-5));            // mean x 100 = 20
}

TEST_CASE("onet protocol reproduces the hand-computed example, and its IoU on two unit cubes") {
  ProtocolSettings s;
  s.protocol = Protocol::kOnet;
  s.samples = 1000;
  s.with_iou = false;
  const EvalResult r = evaluate(speck(Vec3::Zero()), speck(Vec3(0, 0, 0.3)), s);
  CHECK(value(r, "accuracy") == doctest::Approx(0.3).epsilon(1e-5));
  CHECK(value(r, "completeness") == doctest::Approx(0.3).epsilon(1e-5));
  CHECK(value(r, "cd_l1") == doctest::Approx(0.3).epsilon(1e-5));
  CHECK(value(r, "cd_l2") == doctest::Approx(0.09).epsilon(1e-5));
  CHECK(value(r, "normal_consistency") == doctest::Approx(1.0));  // parallel planes
  CHECK_FALSE(r.get("iou").has_value());
  // Cubes [0,1]^3 and [0.5,1.5]x[0,1]^2: intersection 0.5, union 1.5, IoU = 1/3.
  s.with_iou = true;
  s.iou_points = 100000;
  const EvalResult c = evaluate(make_box(Vec3::Zero(), Vec3::Ones()), make_box(Vec3(0.5, 0, 0), Vec3(1.5, 1, 1)), s);
  CHECK(value(c, "iou") == doctest::Approx(1.0 / 3.0).epsilon(0.02));
}

TEST_CASE("protocols are deterministic given the seed and independent of the thread count") {
  const Mesh a = make_torus(Vec3::Zero(), 0.6, 0.25, 48, 24), b = make_icosphere(Vec3(0.05, 0, 0), 0.7, 3);
  for (Protocol p : {Protocol::kDisn, Protocol::kTmnet, Protocol::kOnet}) {
    ProtocolSettings s;
    s.protocol = p;
    s.seed = 9;
    s.samples = p == Protocol::kOnet ? 5000 : 512;
    s.iou_points = 5000;
    Json one;
    {
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
      one = evaluate(a, b, s).to_json()["metrics"];
    }
    const Json two = evaluate(a, b, s).to_json()["metrics"];
    CHECK(one == two);
    s.seed = 10;
    CHECK(evaluate(a, b, s).to_json()["metrics"] != two);
  }
}

TEST_CASE("point clouds: IoU and normal consistency are null with a note, errors name the input") {
  Mesh cloud;
  cloud.V = make_icosphere(Vec3::Zero(), 0.5, 2).V;
  const Mesh mesh = make_icosphere(Vec3::Zero(), 0.5, 3);
  const EvalResult r = evaluate(cloud, mesh, {});
  CHECK(r.get("cd").has_value());
  CHECK_FALSE(r.get("iou").has_value());
  CHECK(r.to_json()["metrics"]["iou"].is_null());
  CHECK(r.to_json()["notes"]["iou"].get<std::string>().find("point cloud") != std::string::npos);
  CHECK_THROWS_WITH_AS(evaluate(Mesh{}, mesh, {}), doctest::Contains("prediction: empty"), InvalidInput);
  Mesh nan = mesh;
  nan.V(0, 0) = std::nan("");
  CHECK_THROWS_WITH_AS(evaluate(mesh, nan, {}), doctest::Contains("ground truth: non-finite"), InvalidInput);
  CHECK_THROWS_AS(parse_protocol("pix2mesh"), InvalidInput);
  CHECK(parse_protocol("tmnet") == Protocol::kTmnet);
}

TEST_CASE("point clouds of exactly the protocol's count are scored as given: the exact CD and EMD") {
  // 2048 points 1 apart on the x axis, and the same points moved 0.1 along y: every nearest neighbour is the
  // partner 0.1 away, so CD = (0.01 + 0.01) x 1000 = 20 and the optimal matching moves every point 0.1.
  // Drawing 2048 of each with replacement (as the protocols once did) loses about a third of the partners: CD
  // about 1100 in a simulation of that draw.
  Mesh a, b;
  a.V.resize(2048, 3);
  for (int i = 0; i < 2048; ++i) a.V.row(i) << i, 0, 0;
  b.V = a.V.rowwise() + Vec3(0, 0.1, 0).transpose();
  for (Protocol p : {Protocol::kTmnet, Protocol::kDisn}) {
    ProtocolSettings s;
    s.protocol = p;
    s.with_iou = false;
    const EvalResult r = evaluate(a, b, s);
    CHECK(r.pred_sampling == "as_given");
    CHECK(r.gt_sampling == "as_given");
    CHECK(r.to_json()["sampling"]["prediction"] == "as_given");
    CHECK(value(r, "cd") == doctest::Approx(20.0).epsilon(1e-9));
    CHECK(value(r, "emd") == doctest::Approx(p == Protocol::kTmnet ? 0.1 * 100 : 2048 * 0.1 * 0.01).epsilon(1e-9));
  }
  // More points than the count: subsampled without replacement; fewer: padded; meshes say how they were sampled.
  ProtocolSettings s;
  s.protocol = Protocol::kTmnet;
  s.samples = 1000;
  s.with_emd = false;
  Mesh small;
  small.V = a.V.topRows(500);
  const EvalResult r = evaluate(a, small, s);
  CHECK(r.pred_sampling == "subsampled");
  CHECK(r.gt_sampling == "padded");
  const EvalResult m = evaluate(make_icosphere(Vec3::Zero(), 1, 2), a, s);
  CHECK(m.pred_sampling == "surface");
  s.protocol = Protocol::kDisn;
  s.with_iou = false;
  CHECK(evaluate(make_icosphere(Vec3::Zero(), 1, 2), a, s).pred_sampling == "vertices_with_replacement");
}
