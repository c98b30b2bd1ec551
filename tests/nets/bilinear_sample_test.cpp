#include "nets/bilinear_sample.h"

#include "gradcheck.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;
using namespace sdfkit::test;

namespace {

// L = <r, sample(maps, pos)>; returns (analytic dmaps, dpos) and checks them against finite differences.
// one_sided: +1 right difference, -1 left difference, 0 central (for positions only; maps are linear).
void check_sampler(const TensorD& maps0, const TensorD& pos0, int one_sided, const BilinearSampleSettings& s = {}) {
  TensorD maps = maps0, pos = pos0, y;
  bilinear_sample(maps, pos, y, s);
  const TensorD r = random_tensor(y.shape, 99);
  TensorD dm, dp;
  bilinear_sample_backward(maps, pos, r, &dm, &dp, s);
  auto loss = [&] {
    TensorD yy;
    bilinear_sample(maps, pos, yy, s);
    return dot(r, yy);
  };
  std::vector<size_t> all_m;
  for (size_t i = 0; i < static_cast<size_t>(maps.size()); ++i) all_m.push_back(i);
  const auto nm = numeric_gradient(loss, maps.ptr(), all_m);
  std::vector<double> am(dm.data.begin(), dm.data.end());
  CHECK(relative_error(am, nm) < 1e-6);
  const double h = 1e-7;
  for (int64_t i = 0; i < pos.size(); ++i) {
    const double old = pos[i];
    double num;
    if (one_sided == 0) {
      pos[i] = old + h;
      const double fp = loss();
      pos[i] = old - h;
      const double fm = loss();
      num = (fp - fm) / (2 * h);
    } else {
      const double f0 = loss();
      pos[i] = old + one_sided * h;
      num = (loss() - f0) / (one_sided * h);
    }
    pos[i] = old;
    INFO("position entry ", i, " value ", old);
    CHECK(std::abs(dp[i] - num) <= 1e-5 * std::max(1.0, std::abs(num)));
  }
}

}  // namespace

TEST_CASE("bilinear sample: gradients at generic interior positions") {
  const TensorD maps = random_tensor({2, 3, 5, 6}, 1);
  TensorD pos = random_tensor({2, 7, 2}, 2, 0.05, 3.95);
  check_sampler(maps, pos, 0);
}

TEST_CASE("bilinear sample: exact at integer positions, one-sided gradients there") {
  const TensorD maps = random_tensor({1, 2, 4, 5}, 3);
  TensorD pos({1, 20, 2}), y;
  int p = 0;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c, ++p) {
      pos[2 * p] = c;
      pos[2 * p + 1] = r;
    }
  bilinear_sample(maps, pos, y);
  for (int k = 0; k < 20; ++k)
    for (int ch = 0; ch < 2; ++ch) CHECK(y[k * 2 + ch] == maps[ch * 20 + k]);  // exact, not approximately
  // Interior integer positions: right derivative (cell to the right). Exclude the last row/column, where the
  // cell to the left is used (left derivative).
  TensorD inner({1, 6, 2});
  const double pts[6][2] = {{0, 0}, {1, 2}, {3, 1}, {2, 0}, {0, 2}, {1, 1}};
  for (int i = 0; i < 6; ++i) {
    inner[2 * i] = pts[i][0];
    inner[2 * i + 1] = pts[i][1];
  }
  check_sampler(maps, inner, +1);
  TensorD last({1, 1, 2});
  last[0] = 4;  // x = W - 1
  last[1] = 3;  // y = H - 1
  check_sampler(maps, last, -1);
}

TEST_CASE("bilinear sample: borders are clamped (DISN), zero position gradient outside") {
  const TensorD maps = random_tensor({1, 3, 4, 4}, 5);
  TensorD pos({1, 4, 2}), y;
  const double outside[4][2] = {{-2.5, 1.5}, {7.0, 2.25}, {1.5, -0.1}, {2.5, 9.0}};
  for (int i = 0; i < 4; ++i) {
    pos[2 * i] = outside[i][0];
    pos[2 * i + 1] = outside[i][1];
  }
  bilinear_sample(maps, pos, y);
  // Clamped x = 0 at y = 1.5: halfway between rows 1 and 2 of column 0.
  for (int ch = 0; ch < 3; ++ch)
    CHECK(y[0 * 3 + ch] == doctest::Approx(0.5 * (maps[ch * 16 + 1 * 4 + 0] + maps[ch * 16 + 2 * 4 + 0])));
  TensorD dm, dp;
  bilinear_sample_backward(maps, pos, random_tensor(y.shape, 6), &dm, &dp);
  CHECK(dp[0] == 0.0);  // x clamped
  CHECK(dp[2] == 0.0);
  CHECK(dp[5] == 0.0);  // y clamped
  CHECK(dp[7] == 0.0);
  CHECK(dp[1] != 0.0);  // y not clamped for the first point
  check_sampler(maps, pos, 0);
  // Positions just inside the border: ordinary central differences.
  TensorD near({1, 2, 2});
  near.data = {0.01, 2.99, 2.99, 0.01};
  check_sampler(maps, near, 0);
}

TEST_CASE("bilinear sample: reference image coordinates map onto smaller maps (corner aligned)") {
  const TensorD maps = random_tensor({1, 2, 5, 5}, 7);
  BilinearSampleSettings s;
  s.reference_width = 9;
  s.reference_height = 9;
  TensorD pos({1, 2, 2}), y;
  pos.data = {8, 4, 2, 6};  // -> map (4, 2) and (1, 3)
  bilinear_sample(maps, pos, y, s);
  CHECK(y[0] == maps[2 * 5 + 4]);
  CHECK(y[2] == maps[3 * 5 + 1]);
  TensorD generic = random_tensor({1, 5, 2}, 8, 0.3, 7.7);
  check_sampler(maps, generic, 0, s);
}

TEST_CASE("bilinear sample: affine maps are reproduced exactly, bad shapes rejected") {
  TensorD maps({1, 1, 6, 7});
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 7; ++c) maps[r * 7 + c] = 0.5 + 2.0 * c - 3.0 * r;
  const TensorD pos = random_tensor({1, 30, 2}, 9, 0.0, 5.0);
  TensorD y;
  bilinear_sample(maps, pos, y);
  for (int p = 0; p < 30; ++p) CHECK(y[p] == doctest::Approx(0.5 + 2.0 * pos[2 * p] - 3.0 * pos[2 * p + 1]));
  TensorD bad({2, 30, 2});
  CHECK_THROWS_AS(bilinear_sample(maps, bad, y), InvalidInput);
}

TEST_CASE("bilinear sample: the channel-last accumulate helper equals bilinear_sample, borders included") {
  const int C = 5, H = 4, W = 6;
  const TensorD maps = random_tensor(Shape{1, C, H, W}, 7);
  // Positions in a 13-pixel reference image: interior, exactly integer, on and beyond every border.
  const std::vector<double> xy{3.3, 7.9, 0, 0, 12, 12, -2.5, 5, 14.2, -1, 6, 6.5, 12, 0.25};
  const int64_t P = static_cast<int64_t>(xy.size() / 2);
  TensorD pos(Shape{1, P, 2});
  for (size_t i = 0; i < xy.size(); ++i) pos[static_cast<int64_t>(i)] = xy[i];
  const BilinearSampleSettings st{13, 13};
  TensorD ref;
  bilinear_sample(maps, pos, ref, st);
  std::vector<double> hwc(static_cast<size_t>(C * H * W));
  for (int c = 0; c < C; ++c)
    for (int i = 0; i < H * W; ++i) hwc[static_cast<size_t>(i * C + c)] = maps[c * H * W + i];
  for (int64_t p = 0; p < P; ++p) {
    std::vector<double> acc(C, 1.5);  // accumulates onto what is there
    bilinear_accumulate_hwc(hwc.data(), H, W, C, pos[2 * p], pos[2 * p + 1], st, acc.data());
    for (int c = 0; c < C; ++c) CHECK(acc[static_cast<size_t>(c)] - 1.5 == doctest::Approx(ref[p * C + c]).epsilon(1e-12));
  }
}
