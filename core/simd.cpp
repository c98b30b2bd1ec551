#include "core/simd.h"

#include <atomic>

namespace sdfkit {
namespace {

bool cpu_has_avx2() {
#if defined(__x86_64__) && defined(__GNUC__)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

std::atomic<bool>& avx2_flag() {
  static std::atomic<bool> flag{cpu_has_avx2()};
  return flag;
}

}  // namespace

bool avx2_enabled() { return avx2_flag().load(std::memory_order_relaxed); }
void set_avx2_enabled(bool on) { avx2_flag().store(on && cpu_has_avx2(), std::memory_order_relaxed); }

}  // namespace sdfkit
