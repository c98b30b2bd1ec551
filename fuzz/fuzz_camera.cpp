// libFuzzer target: sdfkit::read_camera, a view's camera JSON (camera/camera.h). scripts/fuzz camera [SECONDS]
#include "camera/camera.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".json", [](const std::string& path) { (void)sdfkit::read_camera(path); });
}
