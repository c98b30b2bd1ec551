// libFuzzer target: sdfkit::read_mesh on a .glb file (core/mesh_io.h). scripts/fuzz glb [SECONDS]
#include "core/mesh_io.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".glb", [](const std::string& path) {
    sdfkit::MeshReport report;
    (void)sdfkit::read_mesh(path, &report);
  });
}
