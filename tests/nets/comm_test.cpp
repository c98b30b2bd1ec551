#include "nets/comm.h"

#include "core/random.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

using namespace sdfkit;

TEST_CASE("Comm item ranges are contiguous, cover the batch and differ in size by at most one") {
  for (int items : {1, 2, 7, 8, 16})
    for (int size = 1; size <= items; ++size) {
      int next = 0, lo = items, hi = 0;
      for (int r = 0; r < size; ++r) {
        const auto [b, e] = Comm::item_range(items, r, size);
        CHECK(b == next);
        CHECK(e >= b);
        next = e;
        lo = std::min(lo, e - b);
        hi = std::max(hi, e - b);
      }
      CHECK(next == items);
      CHECK(hi - lo <= 1);
    }
  CHECK_THROWS(Comm::item_range(4, 2, 2));
}

TEST_CASE("Comm ordered_sum adds item buffers in item order, bit for bit, at any thread count") {
  // Values of very different magnitudes, so that another order of the additions would change the last bits.
  const size_t n = 3 * (size_t(1) << 14) + 7;
  std::vector<std::vector<float>> items(5, std::vector<float>(n));
  Rng rng(3);
  for (auto& it : items)
    for (float& v : it) v = static_cast<float>(rng.uniform(-1, 1) * std::pow(10.0, rng.uniform(-6, 6)));
  std::vector<float> expected(n);
  for (size_t i = 0; i < n; ++i) {
    float acc = 0.0f;
    for (const auto& it : items) acc += it[i];
    expected[i] = acc;
  }
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    auto copies = items;
    std::vector<float*> ptrs;
    for (auto& it : copies) ptrs.push_back(it.data());
    std::vector<float> out(n, 42.f);
    Comm::world().ordered_sum(ptrs, out.data(), n);
    CHECK(std::memcmp(out.data(), expected.data(), n * sizeof(float)) == 0);
    CHECK(copies == items);  // read only
    Comm::world().ordered_sum(ptrs, out.data(), n, true);
    CHECK(std::memcmp(out.data(), expected.data(), n * sizeof(float)) == 0);
    for (const auto& c : copies) CHECK(std::all_of(c.begin(), c.end(), [](float v) { return v == 0.0f; }));
  }
  // The order matters for these values: the reversed order gives other bits somewhere.
  size_t differ = 0;
  for (size_t i = 0; i < n; ++i) {
    float acc = 0.0f;
    for (size_t k = items.size(); k-- > 0;) acc += items[k][i];
    differ += acc != expected[i];
  }
  CHECK(differ > 0);
  CHECK(Comm::world().size() == 1);
  CHECK(Comm::world().gather({1.5, 2.5}) == std::vector<double>{1.5, 2.5});
}
