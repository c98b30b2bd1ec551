// libFuzzer target: sdfkit::read_image on a .png file (camera/image.h, OpenImageIO). scripts/fuzz image [SECONDS]
#include "camera/image.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".png", [](const std::string& path) { (void)sdfkit::read_image(path); });
}
