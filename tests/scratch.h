// Scratch folders for tests. CTest runs every test case as its own process, two at a time (scripts/test), so a fixed
// path under /tmp that two test cases share is a race: one test case's files, or its captured stderr, are
// overwritten by the other's. The process id in the name keeps test cases (and concurrent runs) apart.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

namespace sdfkit::test {

/// True in the AddressSanitizer build (scripts/test --sanitize), where address-space caps cannot be used.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

namespace detail {
/// The folders made by this process; removed when it ends unless SDFKIT_KEEP_TEST_FILES is set (for debugging).
struct ScratchRegistry {
  std::map<std::string, std::filesystem::path> dirs;
  ~ScratchRegistry() {
    if (std::getenv("SDFKIT_KEEP_TEST_FILES") != nullptr) return;
    std::error_code ec;
    for (const auto& [tag, dir] : dirs) std::filesystem::remove_all(dir, ec);
  }
};
inline ScratchRegistry& scratch_registry() {
  static ScratchRegistry r;
  return r;
}
}  // namespace detail

/// `$TMPDIR/sdfkit_TAG_PID`: empty the first time this process asks for TAG, the same folder (and its contents)
/// after that.
inline std::filesystem::path scratch_dir(const std::string& tag) {
  auto& dirs = detail::scratch_registry().dirs;
  const auto it = dirs.find(tag);
  if (it != dirs.end()) {
    std::filesystem::create_directories(it->second);
    return it->second;
  }
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("sdfkit_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  dirs.emplace(tag, dir);
  return dir;
}

}  // namespace sdfkit::test
