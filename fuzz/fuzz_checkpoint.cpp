// libFuzzer target: sdfkit::load_checkpoint (nets/checkpoint.h), then every block it lists. scripts/fuzz checkpoint
#include "fuzz/fuzz_common.h"
#include "nets/checkpoint.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return sdfkit::fuzz::read_input(data, size, ".ckpt", [](const std::string& path) {
    const sdfkit::Checkpoint ck = sdfkit::load_checkpoint(path);
    for (const auto& block : ck.blocks) (void)ck.block(block.first);
  });
}
