// glTF 2 (.gltf JSON and .glb binary): sdfkit's structural checks before assimp reads the file
// (core/io/assimp.cpp), and the .glb writer (the encoding is core/glb.h's).
#include "core/io/formats.h"
#include "core/files.h"
#include "core/glb.h"
#include "core/json.h"

#include <cstdint>
#include <cstring>
#include <string>

namespace sdfkit::io {

/// A glTF's JSON (the .gltf file, or a GLB's first chunk): an object whose "asset" names version 2. assimp hands a
/// file its glTF importer declines to every other importer, which then read it as something else (a 41-byte
/// ".gltf" found by fuzzing made one read past its buffer); so only what the glTF 2 importer takes reaches assimp.
void check_gltf_json(const std::string& path, const std::string& text, const char* what) {
  const Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object())
    fail_io(path, std::string("not a glTF file (") + what + " is not a JSON object)");
  const auto asset = j.find("asset");
  if (asset == j.end() || !asset->is_object() || !asset->contains("version") || !asset->at("version").is_string())
    fail_io(path, "not a glTF file (no asset.version)");
  const std::string version = asset->at("version").get<std::string>();
  if (version.rfind("2.", 0) != 0) fail_io(path, "glTF version '" + version + "' (only version 2 is read)");
}

/// A binary glTF's container (glTF 2.0 spec, "GLB File Format"): 12-byte header (magic, version 2, total length =
/// the file size), then chunks of (length, type, data) that fit in the file, the first a JSON chunk. assimp trusts
/// the length fields and allocates what they say (4 GB for a 748-byte file found by fuzzing).
void check_glb(const std::string& path, const std::string& data) {
  const auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, data.data() + at, 4);  // little endian, as the format and x86-64 / aarch64
    return v;
  };
  if (data.size() < 20) fail_io(path, "truncated binary glTF file (" + std::to_string(data.size()) + " bytes)");
  if (u32(4) != 2) fail_io(path, "binary glTF version " + std::to_string(u32(4)) + " (only version 2 is read)");
  if (u32(8) != data.size())
    fail_io(path, "binary glTF header says " + std::to_string(u32(8)) + " bytes, the file has " +
                      std::to_string(data.size()));
  for (size_t at = 12, index = 0; at < data.size(); ++index) {
    if (data.size() - at < 8) fail_io(path, "truncated binary glTF chunk header at byte " + std::to_string(at));
    const uint32_t length = u32(at), type = u32(at + 4);
    if (length > data.size() - at - 8)
      fail_io(path, "binary glTF chunk " + std::to_string(index) + " says " + std::to_string(length) +
                        " bytes, the file has " + std::to_string(data.size() - at - 8) + " after its header");
    if (index == 0 && type != 0x4E4F534Au) fail_io(path, "binary glTF file whose first chunk is not JSON");
    if (index == 0) check_gltf_json(path, data.substr(at + 8, length), "its JSON chunk");
    at += 8 + static_cast<size_t>(length);
  }
}

void write_glb(const std::string& path, const Mesh& mesh) {
  std::string bytes;
  try {
    bytes = encode_glb(mesh);
  } catch (const InvalidInput& e) {
    fail_input(path, e.what());
  }
  write_file_atomic(path, [&](std::ostream& o) { o.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

}  // namespace sdfkit::io
