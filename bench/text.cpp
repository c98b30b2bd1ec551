#include "bench/text.h"

#include <cstdarg>
#include <cstdio>

namespace sdfkit::detail {

std::string bench_printf(const char* format, ...) {
  va_list args, count_args;
  va_start(args, format);
  va_copy(count_args, args);
  const int n = std::vsnprintf(nullptr, 0, format, count_args);
  va_end(count_args);
  std::string out(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::vsnprintf(out.data(), out.size() + 1, format, args);
  va_end(args);
  return out;
}

}  // namespace sdfkit::detail
