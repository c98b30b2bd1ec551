// libFuzzer target: sdfkit::read_point_cloud on a .xyz file (core/io/points.h). scripts/fuzz xyz [SECONDS]
#include "core/io/points.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".xyz",
                                  [](const std::string& path) { (void)sdfkit::read_point_cloud(path); });
}
