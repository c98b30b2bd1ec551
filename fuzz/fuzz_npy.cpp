// libFuzzer target: sdfkit::read_npy (core/files.h). scripts/fuzz npy [SECONDS]
#include "core/files.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".npy", [](const std::string& path) { (void)sdfkit::read_npy(path); });
}
