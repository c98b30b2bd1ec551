#include "nets/checkpoint.h"

#include "core/error.h"
#include "core/files.h"
#include "core/json.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace sdfkit {
namespace {

constexpr char kMagic[8] = {'S', 'D', 'F', 'K', 'I', 'T', 'C', 'K'};
constexpr size_t kPrefix = 8 + 4 + 8;

template <typename U>
void put(std::string& s, U v) {
  char b[sizeof(U)];
  std::memcpy(b, &v, sizeof(U));  // x86-64 / aarch64: little endian
  s.append(b, sizeof(U));
}

template <typename U>
U get(const std::string& s, size_t at) {
  U v;
  std::memcpy(&v, s.data() + at, sizeof(U));
  return v;
}

}  // namespace

const std::vector<float>& Checkpoint::block(const std::string& name, long expected_count) const {
  for (const auto& b : blocks)
    if (b.first == name) {
      if (expected_count >= 0 && static_cast<long>(b.second.size()) != expected_count)
        throw IoError("checkpoint block '" + name + "' has " + std::to_string(b.second.size()) +
                      " values, expected " + std::to_string(expected_count));
      return b.second;
    }
  throw IoError("checkpoint has no block '" + name + "'");
}

bool Checkpoint::has_block(const std::string& name) const {
  for (const auto& b : blocks)
    if (b.first == name) return true;
  return false;
}

void Checkpoint::set_block(const std::string& name, std::vector<float> values) {
  for (auto& b : blocks)
    if (b.first == name) {
      b.second = std::move(values);
      return;
    }
  blocks.emplace_back(name, std::move(values));
}

Checkpoint training_state_checkpoint(const std::string& kind, const Json& architecture, const Json& settings,
                                     const TrainingProgress& progress, const float* params, size_t n,
                                     const Optimizer& opt) {
  Checkpoint ck;
  ck.header["kind"] = kind;
  ck.header["architecture"] = architecture;
  ck.header["settings"] = settings;
  ck.header["step"] = progress.step;
  ck.header["seconds"] = progress.seconds;
  ck.header["curve"] = progress.curve;
  ck.set_block("params", std::vector<float>(params, params + n));
  ck.put_optimizer(opt);
  return ck;
}

TrainingProgress restore_training_state(const Checkpoint& checkpoint, float* params, size_t n, Optimizer& opt) {
  const auto& p = checkpoint.block("params", static_cast<long>(n));
  std::copy(p.begin(), p.end(), params);
  checkpoint.get_optimizer(opt);
  TrainingProgress progress;
  progress.step = checkpoint.header.at("step").get<long>();
  progress.seconds = checkpoint.header.value("seconds", 0.0);
  progress.curve = checkpoint.header.value("curve", Json::array());
  return progress;
}

void Checkpoint::put_optimizer(const Optimizer& opt) {
  StateBlob s = opt.serialize();
  header["optimizer"] = s.meta;
  for (auto& b : s.buffers) set_block(b.first, std::move(b.second));
}

void Checkpoint::get_optimizer(Optimizer& opt) const {
  if (!header.contains("optimizer")) throw IoError("checkpoint has no optimizer state");
  StateBlob s;
  s.meta = header.at("optimizer");
  for (const auto& b : blocks)
    if (b.first.rfind("opt_", 0) == 0) s.buffers.push_back(b);
  opt.deserialize(s);
}

void Checkpoint::put_average(const WeightAverage& average) {
  StateBlob s = average.serialize();
  header["weight_average"] = s.meta;
  for (auto& b : s.buffers) set_block(b.first, std::move(b.second));
}

void Checkpoint::get_average(WeightAverage& average) const {
  if (!header.contains("weight_average")) throw IoError("checkpoint has no weight average");
  StateBlob s;
  s.meta = header.at("weight_average");
  s.buffers.emplace_back("ema", block("ema"));
  average.deserialize(s);
}

void save_checkpoint(const std::string& path, const Checkpoint& ck) {
  Json header = ck.header;
  Json table = Json::array();
  size_t offset = 0;
  for (const auto& b : ck.blocks) {
    for (const float v : b.second)
      require(std::isfinite(v), path + ": refusing to write a checkpoint with non-finite values in block '" +
                                    b.first + "'");
    table.push_back({{"name", b.first}, {"offset", offset}, {"count", b.second.size()}});
    offset += b.second.size();
  }
  header["blocks"] = table;
  header["format"] = "sdfkit-checkpoint";
  header["version"] = kCheckpointVersion;
  const std::string text = header.dump();
  std::string bytes;
  bytes.reserve(kPrefix + text.size() + offset * 4 + 8);
  bytes.append(kMagic, 8);
  put<uint32_t>(bytes, kCheckpointVersion);
  put<uint64_t>(bytes, text.size());
  bytes += text;
  for (const auto& b : ck.blocks)
    bytes.append(reinterpret_cast<const char*>(b.second.data()), b.second.size() * sizeof(float));
  put<uint64_t>(bytes, fnv1a(bytes.data(), bytes.size()));
  write_file_atomic(path, [&](std::ostream& o) { o.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

Checkpoint load_checkpoint(const std::string& path) {
  const std::string bytes = read_file(path);
  if (bytes.size() < kPrefix + 8 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw IoError(path + ": not an sdfkit checkpoint (bad magic or too short)");
  const uint32_t version = get<uint32_t>(bytes, 8);
  if (version != kCheckpointVersion)
    throw IoError(path + ": checkpoint format version " + std::to_string(version) + ", this build reads " +
                  std::to_string(kCheckpointVersion));
  const uint64_t hlen = get<uint64_t>(bytes, 12);
  if (hlen > bytes.size() - kPrefix - 8)
    throw IoError(path + ": truncated checkpoint (header length " + std::to_string(hlen) + " exceeds the file)");
  const size_t payload = bytes.size() - kPrefix - 8 - hlen;
  const uint64_t stored = get<uint64_t>(bytes, bytes.size() - 8);
  const uint64_t actual = fnv1a(bytes.data(), bytes.size() - 8);
  Json header;
  try {
    header = Json::parse(bytes.substr(kPrefix, hlen));
  } catch (const Json::exception&) {
    throw IoError(path + (stored != actual ? ": corrupt or truncated checkpoint (checksum mismatch)"
                                           : ": checkpoint header is not valid JSON"));
  }
  // The block table, checked before anything is copied: names are strings, offsets and counts non-negative
  // integers, every block inside the payload (compared without forming off + count, which could wrap).
  struct BlockEntry {
    std::string name;
    uint64_t offset = 0, count = 0;
  };
  std::vector<BlockEntry> table;
  uint64_t total = 0;
  const auto bad_table = [&](const std::string& why) {
    return IoError(path + ": checkpoint header has no valid block table (" + why + ")");
  };
  if (!header.is_object() || !header.contains("blocks") || !header.at("blocks").is_array())
    throw bad_table("no \"blocks\" array");
  for (const auto& b : header.at("blocks")) {
    const std::string which = "block " + std::to_string(table.size());
    if (!b.is_object()) throw bad_table(which + " is not an object");
    const auto field = [&](const char* key) -> const Json& {
      if (!b.contains(key)) throw bad_table(which + " has no \"" + key + "\"");
      return b.at(key);
    };
    const Json &name = field("name"), &offset = field("offset"), &count = field("count");
    if (!name.is_string()) throw bad_table(which + ": \"name\" is not a string");
    if (!offset.is_number_unsigned()) throw bad_table(which + ": \"offset\" is not a non-negative integer");
    if (!count.is_number_unsigned()) throw bad_table(which + ": \"count\" is not a non-negative integer");
    BlockEntry e{name.get<std::string>(), offset.get<uint64_t>(), count.get<uint64_t>()};
    if (e.count > std::numeric_limits<uint64_t>::max() - total) throw bad_table("the block counts overflow");
    total += e.count;
    table.push_back(std::move(e));
  }
  if (payload % 4 != 0 || payload / 4 < total)
    throw IoError(path + ": truncated checkpoint (" + std::to_string(payload) + " payload bytes, the header lists " +
                  std::to_string(total) + " floats)");
  if (payload / 4 != total)
    throw IoError(path + ": checkpoint payload size " + std::to_string(payload) + " does not match the header");
  if (stored != actual) throw IoError(path + ": corrupt checkpoint (checksum mismatch)");
  Checkpoint ck;
  const char* data = bytes.data() + kPrefix + hlen;
  for (const BlockEntry& e : table) {
    if (e.offset > total || e.count > total - e.offset)
      throw IoError(path + ": checkpoint block table is inconsistent (block '" + e.name + "' at offset " +
                    std::to_string(e.offset) + " with " + std::to_string(e.count) + " values lies outside the " +
                    std::to_string(total) + "-value payload)");
    std::vector<float> v(static_cast<size_t>(e.count));
    if (e.count > 0) std::memcpy(v.data(), data + e.offset * 4, static_cast<size_t>(e.count) * 4);
    ck.blocks.emplace_back(e.name, std::move(v));
  }
  header.erase("blocks");
  ck.header = std::move(header);
  return ck;
}

void require_header_match(const Checkpoint& ck, const std::string& key, const Json& expected, const std::string& path) {
  if (!ck.header.contains(key)) throw InvalidInput(path + ": checkpoint has no '" + key + "' entry");
  const Json diff = Json::diff(ck.header.at(key), expected);
  if (!diff.empty()) {
    const Json& first = diff.at(0);
    const std::string where = first.value("path", std::string(""));
    std::string have = "nothing";
    try {
      have = ck.header.at(key).at(Json::json_pointer(where)).dump();
    } catch (const Json::exception&) {
    }
    const std::string want = first.contains("value") ? first.at("value").dump() : std::string("nothing");
    throw InvalidInput(path + ": checkpoint " + key + " does not match this model (first difference at " + key +
                       where + ": file has " + have + ", expected " + want + ")");
  }
}

}  // namespace sdfkit
