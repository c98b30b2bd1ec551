#include "bench/timing.h"

#include <doctest/doctest.h>

#include <cmath>
#include <thread>
#include <vector>

using namespace sdfkit;

TEST_CASE("median: middle value of an odd count, mean of the two middle values of an even count, NaN for none") {
  CHECK(median({5.0}) == 5.0);
  CHECK(median({3.0, 1.0, 2.0}) == 2.0);          // unsorted input
  CHECK(median({9.0, -1.0, 4.0, 4.0, 7.0}) == 4.0);
  CHECK(median({4.0, 1.0, 3.0, 2.0}) == 2.5);     // (2 + 3) / 2
  CHECK(median({1.0, 10.0}) == 5.5);
  CHECK(std::isnan(median({})));
  // The argument is a copy: the caller's vector keeps its order.
  const std::vector<double> v = {3.0, 1.0, 2.0};
  CHECK(median(v) == 2.0);
  CHECK(v == std::vector<double>{3.0, 1.0, 2.0});
}

TEST_CASE("mean: sum over count, NaN for none") {
  CHECK(mean({2.0}) == 2.0);
  CHECK(mean({1.0, 2.0, 3.0, 4.0}) == 2.5);
  CHECK(mean({-1.0, 1.0, 6.0}) == 2.0);
  CHECK(std::isnan(mean({})));
}

TEST_CASE("clocks: wall time and CPU time advance, peak RSS is positive") {
  const auto t0 = BenchClock::now();
  const double p0 = process_cpu_seconds(), c0 = thread_cpu_seconds();
  // Busy work that the compiler cannot remove: CPU time must advance, not only wall time.
  volatile double sink = 0;
  while (thread_cpu_seconds() - c0 < 0.01) sink = sink + std::sqrt(static_cast<double>(sink) + 1.0);
  CHECK(thread_cpu_seconds() - c0 >= 0.01);
  CHECK(process_cpu_seconds() - p0 >= 0.01);
  CHECK(seconds_since(t0) >= 0.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  CHECK(seconds_since(t0) >= 0.005);
  CHECK(peak_rss_mb() > 0.0);
}
