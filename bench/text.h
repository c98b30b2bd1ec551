// printf into a std::string, for the benchmarks' text tables (bench/*_bench.cpp). Internal to bench/.
#pragma once

#include <string>

namespace sdfkit::detail {

/// What std::printf(format, ...) would print, as a string.
std::string bench_printf(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace sdfkit::detail
