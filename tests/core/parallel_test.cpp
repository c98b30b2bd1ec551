#include "core/parallel.h"

#include <doctest/doctest.h>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace sdfkit;

namespace {

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("parallel_for_ordered_errors reports the lowest failing index, not the first thread to fail") {
  // Item 7 fails at once, item 3 only after a pause: a plain tbb::parallel_for on several threads reports item 7
  // (its exception is caught first and cancels the loop), the ordered loop must report item 3 every time.
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 4);
  tbb::task_arena arena(4);
  for (int run = 0; run < 10; ++run) {
    std::vector<std::atomic<int>> ran(64);
    const std::string msg = message_of([&] {
      arena.execute([&] {
        parallel_for_ordered_errors(0, 64, [&](int i) {
          ran[static_cast<size_t>(i)] = 1;
          if (i == 7) throw std::runtime_error("item 7");
          if (i == 3) {
            std::this_thread::sleep_for(std::chrono::milliseconds(30));
            throw std::runtime_error("item 3");
          }
        });
      });
    });
    CHECK(msg == "item 3");
    for (int i = 0; i < 3; ++i) CHECK(ran[static_cast<size_t>(i)].load() == 1);  // every item below the failure ran
  }
}

TEST_CASE("parallel_for_ordered_errors runs every item of a loop that does not fail, over any index range") {
  std::vector<std::atomic<int>> count(100);
  parallel_for_ordered_errors(long(-20), long(80), [&](long i) { ++count[static_cast<size_t>(i + 20)]; });
  for (const auto& c : count) CHECK(c.load() == 1);
  int calls = 0;
  parallel_for_ordered_errors(5, 5, [&](int) { ++calls; });  // empty range: nothing runs, nothing throws
  CHECK(calls == 0);
  // Offsets are taken from the range's start: a failure at index 10 of [10, 20) is item 0, and items above it stop.
  CHECK(message_of([] {
          parallel_for_ordered_errors(10, 20, [](int i) {
            if (i == 10 || i == 15) throw std::runtime_error("at " + std::to_string(i));
          });
        }) == "at 10");
}

TEST_CASE("FirstFailure keeps the lowest failing index and skips the items above it") {
  FirstFailure f;
  CHECK_FALSE(f.failed());
  CHECK_NOTHROW(f.rethrow());
  int ran = 0;
  f.run(5, [&] {
    ++ran;
    throw std::runtime_error("five");
  });
  REQUIRE(f.failed());
  CHECK(f.first_index() == 5);
  f.run(9, [&] { ++ran; });  // above the failure: skipped
  CHECK(ran == 1);
  f.run(2, [&] {
    ++ran;
    throw std::invalid_argument("two");
  });
  f.run(4, [&] {
    ++ran;
    throw std::runtime_error("four");
  });  // still below 5 but above 2: skipped
  CHECK(ran == 2);
  CHECK(f.first_index() == 2);
  CHECK_THROWS_AS(f.rethrow(), std::invalid_argument);
  CHECK(message_of([&] { f.rethrow(); }) == "two");
}
