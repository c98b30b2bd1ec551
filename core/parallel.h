// Parallel loops whose errors do not depend on the scheduling. tbb::parallel_for rethrows the exception of whichever
// thread failed first, so a loop over files with two bad ones names either, run to run. These report the failure of
// the lowest failing index, always: the same command gives the same message.
#pragma once

#include <atomic>
#include <cstddef>
#include <exception>
#include <limits>
#include <mutex>
#include <utility>

#include <tbb/parallel_for.h>

namespace sdfkit {

/// Collects the failures of a parallel loop's items and keeps the one of the lowest index. An item above a failure
/// already seen is skipped (it cannot be the first); every item below the first failure runs, so which failure is
/// kept does not depend on the order in which the threads reach the items.
class FirstFailure {
 public:
  /// Runs f() for item `index` unless an item with a lower index has already failed; an exception f() throws is
  /// caught and kept when `index` is the lowest failing index so far.
  template <class F>
  void run(size_t index, F&& f) {
    if (index > first_.load(std::memory_order_acquire)) return;
    try {
      std::forward<F>(f)();
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (index < first_.load(std::memory_order_relaxed)) {
        error_ = std::current_exception();
        first_.store(index, std::memory_order_release);
      }
    }
  }

  /// True when some item failed.
  bool failed() const { return first_.load(std::memory_order_acquire) != kNone; }
  /// The lowest failing index (only when failed()).
  size_t first_index() const { return first_.load(std::memory_order_acquire); }
  /// Rethrows the kept exception, if any. Call after the loop.
  void rethrow() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (error_) std::rethrow_exception(error_);
  }

 private:
  static constexpr size_t kNone = std::numeric_limits<size_t>::max();
  std::atomic<size_t> first_{kNone};
  mutable std::mutex mutex_;
  std::exception_ptr error_;
};

/// tbb::parallel_for(begin, end, body) whose exception, if any item throws, is the one of the lowest failing index,
/// rethrown after the loop; the items below it all run, the items above it may not.
template <class Index, class Body>
void parallel_for_ordered_errors(Index begin, Index end, const Body& body) {
  FirstFailure errors;
  tbb::parallel_for(begin, end, [&](Index i) { errors.run(static_cast<size_t>(i - begin), [&] { body(i); }); });
  errors.rethrow();
}

}  // namespace sdfkit
