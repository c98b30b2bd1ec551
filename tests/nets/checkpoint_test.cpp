#include "core/json.h"
#include "nets/checkpoint.h"

#include "nets/layers.h"
#include "nets/loss.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>
#include <unistd.h>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  return (test::scratch_dir("nets_ck") / name).string();
}

// A tiny model + its training loop; the batch of step k depends only on (seed, k).
struct Tiny {
  Sequential<float> net;
  ParamStore<float> store;
  Optimizer opt;
  LrSchedule lr;
  long step = 0;
  Tiny() : opt(OptimizerSettings{}, 0) {
    net.emplace<Linear<float>>(3, 16);
    net.add(relu<float>());
    net.emplace<Linear<float>>(16, 1);
    net.training(true);
    store.add(net);
    store.allocate(true);
    store.init(42);
    opt = Optimizer(OptimizerSettings{}, store.size());
    lr.kind = LrSchedule::Kind::kStep;
    lr.base = 1e-2;
    lr.step_size = 3;
    lr.gamma = 0.5;
  }
  void train(long steps) {
    for (long k = 0; k < steps; ++k, ++step) {
      Rng rng = Rng::derived(7, static_cast<uint64_t>(step));
      Tensor x({1, 32, 3}), t({1, 32, 1}), y, dy;
      for (int i = 0; i < 32; ++i) {
        double r2 = 0;
        for (int c = 0; c < 3; ++c) {
          x[i * 3 + c] = static_cast<float>(rng.uniform(-1, 1));
          r2 += x[i * 3 + c] * x[i * 3 + c];
        }
        t[i] = static_cast<float>(std::sqrt(r2) - 0.5);
      }
      net.forward(x, y);
      l1_loss(y, t, &dy);
      store.zero_grad();
      net.backward(x, y, dy, nullptr);
      clip_grad_norm(store.grads.data(), store.size(), 1.0);
      opt.step(store.values.data(), store.grads.data(), lr.at(step));
    }
  }
  Checkpoint save() const {
    Checkpoint ck;
    ck.header["architecture"] = store.architecture();
    ck.header["training"] = {{"step", step}, {"seed", 7}, {"lr", lr.to_json()}};
    ck.set_block("params", std::vector<float>(store.values.begin(), store.values.end()));
    ck.put_optimizer(opt);
    return ck;
  }
  void load(const Checkpoint& ck, const std::string& path) {
    require_header_match(ck, "architecture", store.architecture(), path);
    const auto& p = ck.block("params", static_cast<long>(store.size()));
    std::copy(p.begin(), p.end(), store.values.begin());
    ck.get_optimizer(opt);
    step = ck.header.at("training").at("step").get<long>();
  }
};

}  // namespace

TEST_CASE("checkpoint round trip is bit-exact") {
  Checkpoint ck;
  ck.header["architecture"] = {{"type", "test"}, {"width", 3}};
  ck.header["note"] = "unicode é ok";
  std::vector<float> a = {1.0f, -0.0f, 3.4028235e38f, 1.17549435e-38f, 1e-45f, 0.1f};
  ck.set_block("params", a);
  ck.set_block("empty", {});
  ck.set_block("opt_m", {2.5f});
  const std::string path = temp_path("rt.ckpt");
  save_checkpoint(path, ck);
  const Checkpoint r = load_checkpoint(path);
  CHECK(r.header.at("architecture") == ck.header.at("architecture"));
  CHECK(r.header.at("note") == "unicode é ok");
  CHECK(r.header.at("version") == kCheckpointVersion);
  const auto& b = r.block("params");
  REQUIRE(b.size() == a.size());
  CHECK(std::memcmp(b.data(), a.data(), a.size() * sizeof(float)) == 0);
  CHECK(r.block("empty").empty());
  CHECK(r.block("opt_m")[0] == 2.5f);
  CHECK_THROWS_AS(static_cast<void>(r.block("params", 5)), IoError);
  CHECK_THROWS_AS(static_cast<void>(r.block("missing")), IoError);
  // Non-finite values are refused at save time.
  ck.set_block("params", {NAN});
  CHECK_THROWS_AS(save_checkpoint(temp_path("nan.ckpt"), ck), InvalidInput);
  CHECK_FALSE(fs::exists(temp_path("nan.ckpt")));
}

TEST_CASE("every corrupted byte and every truncation is detected") {
  Tiny t;
  const std::string path = temp_path("c.ckpt");
  save_checkpoint(path, t.save());
  const std::string good = read_file(path);
  // Flip one bit at many positions spread over magic, header, payload and checksum.
  int detected = 0, tried = 0;
  for (size_t pos = 0; pos < good.size(); pos += std::max<size_t>(1, good.size() / 300)) {
    std::string bad = good;
    bad[pos] = static_cast<char>(bad[pos] ^ 0x10);
    write_text_atomic(path, bad);
    ++tried;
    try {
      (void)load_checkpoint(path);
    } catch (const IoError&) {
      ++detected;
    }
  }
  CHECK(detected == tried);
  for (size_t len : {size_t(0), size_t(5), size_t(30), good.size() / 2, good.size() - 1}) {
    write_text_atomic(path, good.substr(0, len));
    CHECK_THROWS_AS(load_checkpoint(path), IoError);
  }
  CHECK_THROWS_AS(load_checkpoint(temp_path("does_not_exist.ckpt")), IoError);
  // Message names the file.
  write_text_atomic(path, good.substr(0, good.size() - 3));
  try {
    (void)load_checkpoint(path);
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find(path) != std::string::npos);
  }
}

namespace {
/// A checkpoint file with a valid magic, version, sizes and checksum around an arbitrary header text and
/// `floats` zero floats: only the block table can be wrong, so loading exercises the table checks alone.
std::string write_forged_checkpoint(const std::string& path, const std::string& header_text, size_t floats) {
  std::string bytes("SDFKITCK", 8);
  const uint32_t version = kCheckpointVersion;
  const uint64_t hlen = header_text.size();
  bytes.append(reinterpret_cast<const char*>(&version), 4);
  bytes.append(reinterpret_cast<const char*>(&hlen), 8);
  bytes += header_text;
  bytes.append(floats * 4, '\0');
  const uint64_t sum = fnv1a(bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&sum), 8);
  write_text_atomic(path, bytes);
  return path;
}
}  // namespace

TEST_CASE("a forged block table is an IoError naming the file, never a wild read or a JSON exception") {
  const std::string path = temp_path("forged.ckpt");
  // Sanity: the forger makes loadable files.
  const Checkpoint ok =
      load_checkpoint(write_forged_checkpoint(path, R"({"blocks":[{"name":"a","offset":0,"count":4}]})", 4));
  REQUIRE(ok.block("a").size() == 4);
  const std::vector<std::pair<std::string, size_t>> cases = {
      // offset near 2^64: off + count wraps to a small number and used to pass the bounds check
      {R"({"blocks":[{"name":"a","offset":18446744073709551615,"count":4},{"name":"b","offset":0,"count":0}]})", 4},
      {R"({"blocks":[{"name":"a","offset":18446744073709551612,"count":4}]})", 4},
      {R"({"blocks":[{"name":"a","offset":-4,"count":4}]})", 4},
      {R"({"blocks":[{"name":"a","offset":0,"count":-4}]})", 0},
      {R"({"blocks":[{"name":"a","offset":1,"count":4}]})", 4},
      {R"({"blocks":[{"name":"a","offset":0.5,"count":4}]})", 4},
      {R"({"blocks":[{"name":"a","offset":"0","count":4}]})", 4},
      {R"({"blocks":[{"offset":0,"count":4}]})", 4},  // no name
      {R"({"blocks":[{"name":7,"offset":0,"count":4}]})", 4},
      {R"({"blocks":[{"name":"a","count":4}]})", 4},
      {R"({"blocks":[{"name":"a","offset":0}]})", 4},
      {R"({"blocks":[4]})", 4},
      {R"({"blocks":{"name":"a"}})", 4},
      {R"({"blocks":7})", 0},
      {R"({"no_blocks":[]})", 0},
      {R"([1,2,3])", 0},
      {R"("text")", 0},
      // the counts sum to 2^64 + 4, which wrapped to 4 and matched a 4-float payload
      {R"({"blocks":[{"name":"a","offset":0,"count":18446744073709551615},{"name":"b","offset":0,"count":5}]})", 4},
  };
  for (const auto& item : cases) {
    const auto& text = item.first;
    const auto& floats = item.second;
    CAPTURE(text);
    write_forged_checkpoint(path, text, floats);
    std::string err = "no error";
    try {
      (void)load_checkpoint(path);
    } catch (const IoError& e) {
      err = e.what();
    } catch (const std::exception& e) {
      err = std::string("not an IoError: ") + e.what();
    }
    CHECK(err.rfind(path + ": ", 0) == 0);
  }
}

TEST_CASE("a mismatched architecture is a clear error") {
  Tiny t;
  const Checkpoint ck = t.save();
  Json other = t.store.architecture();
  other[0]["layers"][2]["out"] = 2;
  try {
    require_header_match(ck, "architecture", other, "m.ckpt");
    FAIL("no error");
  } catch (const InvalidInput& e) {
    const std::string msg = e.what();
    CHECK(msg.find("m.ckpt") != std::string::npos);
    CHECK(msg.find("/0/layers/2/out") != std::string::npos);
  }
}

TEST_CASE("resume from a checkpoint gives bit-identical results to an uninterrupted run") {
  Tiny full;
  full.train(10);
  Tiny first;
  first.train(4);
  const std::string path = temp_path("resume.ckpt");
  save_checkpoint(path, first.save());
  Tiny resumed;  // fresh objects, as after a restart
  resumed.load(load_checkpoint(path), path);
  CHECK(resumed.step == 4);
  resumed.train(6);
  REQUIRE(resumed.store.values.size() == full.store.values.size());
  CHECK(std::memcmp(resumed.store.values.data(), full.store.values.data(), full.store.size() * sizeof(float)) == 0);
  CHECK(resumed.opt.steps() == full.opt.steps());
}
