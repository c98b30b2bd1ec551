// `sdfkit bench train`: training steps (shipped, DISN-size, pose) at 1 and 2 threads against the GEMM peak
// (bench/train_bench.h).
#include "apps/command.h"
#include "bench/train_bench.h"
#include "core/error.h"
#include "core/json.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

namespace sdfkit::app {
namespace {

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

std::function<int()> setup_bench_train(CLI::App& app) {
  struct Opts {
    TrainBenchSettings s;
    std::string configs = "shipped,disn,pose", threads = "1,2";
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--data", o->s.data,
                 "prepared dataset with views (default: 8 shapes made by this command in a temporary folder)");
  app.add_option("--configs", o->configs, "comma-separated: shipped, disn, pose")->capture_default_str();
  app.add_option("--threads", o->threads, "comma-separated thread counts")->capture_default_str();
  app.add_option("--steps", o->s.steps, "timed steps per run (median reported)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--warmup", o->s.warmup, "untimed steps before them")->capture_default_str()->check(non_negative());
  app.add_option("--gemm", o->s.gemm, "side of the square GEMMs that define the peak")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--reps", o->s.reps, "GEMM repetitions (median)")->capture_default_str()->check(positive());
  app.add_flag("--json", o->json, "print JSON on stdout");
  return [o] {
    TrainBenchSettings s = o->s;
    s.configs.clear();
    for (const auto& name : split_list(o->configs)) {
      auto c = find_train_bench_config(name);
      if (!c) throw InvalidInput("--configs: unknown configuration '" + name + "' (shipped, disn, pose)");
      s.configs.push_back(*c);
    }
    s.threads.clear();
    for (const auto& t : split_list(o->threads)) {
      char* end = nullptr;
      const long v = std::strtol(t.c_str(), &end, 10);
      if (end == t.c_str() || *end != '\0' || v < 1 || v > 256)
        throw InvalidInput("--threads: '" + t + "' is not a thread count from 1 to 256");
      s.threads.push_back(static_cast<int>(v));
    }
    // Without --data the benchmark makes its dataset with this executable's synth and prep.
    s.sdfkit_exe = std::filesystem::read_symlink("/proc/self/exe").string();
    const TrainBenchResult r =
        run_train_bench(s, [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); });
    if (o->json)
      std::cout << train_bench_json(r).dump(2) << '\n';
    else
      std::fputs(train_bench_text(r).c_str(), stdout);
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench train",
                        "training steps (shipped, DISN-size, pose) at 1 and 2 threads against the GEMM peak",
                        setup_bench_train);

}  // namespace
}  // namespace sdfkit::app
