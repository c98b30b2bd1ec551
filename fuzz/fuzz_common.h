// Shared by the libFuzzer targets (fuzz/fuzz_*.cpp): every sdfkit reader takes a path, so each input is written to a
// file of this process (in $TMPDIR, /tmp by default) with the reader's extension and read back. A reader may refuse
// the bytes with sdfkit's own errors (IoError, InvalidInput: a one-line message, exit 1 in the CLI); anything else
// (a crash, a sanitizer report, another exception, a hang, an out-of-memory) is a finding.
#pragma once

#include "core/error.h"

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

namespace sdfkit::fuzz {

inline std::string input_path(const char* extension) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir && *dir ? dir : "/tmp") + "/sdfkit_fuzz_" + std::to_string(getpid()) + extension;
}

/// Write the input to this process's file with `extension` and call read(path); sdfkit's errors are the expected
/// outcome for bad bytes.
template <typename Read>
int read_input(const uint8_t* data, size_t size, const char* extension, Read&& read) {
  static const std::string path = input_path(extension);
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    read(path);
  } catch (const Error&) {
    // Refused with a message: what a hostile file must get.
  }
  return 0;
}

}  // namespace sdfkit::fuzz
