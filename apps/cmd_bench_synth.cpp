// `sdfkit bench synth`: time to generate the procedural benchmark (in memory, per category) and to write it
// (generate + binary PLY + lists) with 1 and all threads; triangle counts and bytes. Medians of --reps runs, ratios
// against in-memory generation on one thread measured in the same run. Results: docs/benchmarks/synth.md.
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/json.h"
#include "synth/benchmark.h"
#include "synth/categories.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <unistd.h>

namespace sdfkit::app {
namespace {

const auto cpu_seconds = process_cpu_seconds;

namespace fs = std::filesystem;



std::function<int()> setup_bench_synth(CLI::App& app) {
  struct Opts {
    int per_category = 100;
    int reps = 5;
    int jobs = 0;
    uint64_t seed = 0;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("-n,--per-category", o->per_category, "shapes per category (100 = the full preset)")
      ->check(in_range(1, 100000))
      ->capture_default_str();
  app.add_option("--reps", o->reps, "repetitions (medians are reported)")->check(in_range(1, 1000))->capture_default_str();
  app.add_option("-j,--jobs", o->jobs, "threads of the parallel run (0 = all cores)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--seed", o->seed, "benchmark seed")->capture_default_str();
  app.add_flag("--json", o->json, "print the results as JSON");
  return [o] {
    SynthSettings s;
    s.per_category = o->per_category;
    s.seed = o->seed;
    const auto plan = plan_benchmark(s);
    const size_t ncat = categories().size();

    // 1. In-memory generation on one thread, per category (the baseline).
    std::vector<std::vector<double>> cat_ms(ncat);
    std::vector<std::vector<long>> tris(ncat);
    std::vector<double> gen_total;
    for (int rep = 0; rep < o->reps; ++rep) {
      std::vector<double> acc(ncat, 0.0);
      const auto t0 = std::chrono::steady_clock::now();
      for (const auto& e : plan) {
        const auto a = std::chrono::steady_clock::now();
        const SynthShape shape = generate_shape(e.category, e.seed);
        acc[e.category] += std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
        if (rep == 0) tris[e.category].push_back(static_cast<long>(shape.mesh.F.rows()));
      }
      gen_total.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      for (size_t c = 0; c < ncat; ++c) cat_ms[c].push_back(1e3 * acc[c] / o->per_category);
    }
    const double base = median(gen_total);

    // 2. Writing the benchmark (generate + PLY + lists + categories.json) with 1 thread and with --jobs.
    const fs::path dir = fs::temp_directory_path() / ("sdfkit_bench_synth_" + std::to_string(::getpid()));
    auto time_write = [&](int jobs, double* cpu) {
      std::vector<double> walls, cpus;
      s.jobs = jobs;
      for (int rep = 0; rep < o->reps; ++rep) {
        fs::remove_all(dir);
        const double c0 = cpu_seconds();
        const auto t0 = std::chrono::steady_clock::now();
        write_benchmark(dir.string(), s);
        walls.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        cpus.push_back(cpu_seconds() - c0);
      }
      if (cpu) *cpu = median(cpus);
      return median(walls);
    };
    double cpu1 = 0, cpun = 0;
    const double w1 = time_write(1, &cpu1);
    const double wn = time_write(o->jobs, &cpun);
    const int threads = o->jobs > 0 ? o->jobs : tbb::this_task_arena::max_concurrency();
    uintmax_t bytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file()) bytes += e.file_size();
    fs::remove_all(dir);

    Json cats = Json::array();
    long all_min = 1L << 60, all_max = 0;
    double all_sum = 0;
    std::vector<double> all_tris;
    if (!o->json)
      std::printf("%zu shapes (%d per category), %d runs, medians; baseline = in-memory generation on 1 thread\n",
                  plan.size(), o->per_category, o->reps);
    if (!o->json) std::printf("%-11s %10s %10s %10s %10s\n", "category", "ms/shape", "tri min", "tri median", "tri max");
    for (size_t c = 0; c < ncat; ++c) {
      if (tris[c].empty()) continue;
      std::vector<double> t(tris[c].begin(), tris[c].end());
      const long mn = *std::min_element(tris[c].begin(), tris[c].end());
      const long mx = *std::max_element(tris[c].begin(), tris[c].end());
      all_min = std::min(all_min, mn);
      all_max = std::max(all_max, mx);
      for (const double x : t) {
        all_sum += x;
        all_tris.push_back(x);
      }
      const double ms = median(cat_ms[c]);
      cats.push_back({{"category", categories()[c].name},
                      {"ms_per_shape", ms},
                      {"triangles_min", mn},
                      {"triangles_median", median(t)},
                      {"triangles_max", mx}});
      if (!o->json)
        std::printf("%-11s %10.3f %10ld %10.0f %10ld\n", categories()[c].name.c_str(), ms, mn, median(t), mx);
    }
    const Json out = {{"shapes", plan.size()},
                      {"per_category", o->per_category},
                      {"reps", o->reps},
                      {"categories", cats},
                      {"generate_1_thread_s", base},
                      {"write_1_thread_wall_s", w1},
                      {"write_1_thread_cpu_s", cpu1},
                      {"write_threads", threads},
                      {"write_parallel_wall_s", wn},
                      {"write_parallel_cpu_s", cpun},
                      {"write_1_thread_over_generate", w1 / base},
                      {"parallel_speedup", w1 / wn},
                      {"bytes_written", bytes},
                      {"triangles_min", all_min},
                      {"triangles_median", median(all_tris)},
                      {"triangles_mean", all_sum / static_cast<double>(all_tris.size())},
                      {"triangles_max", all_max}};
    if (o->json) {
      std::cout << out.dump(2) << '\n';
    } else {
      std::printf("generate only, 1 thread:        %8.3f s  (x1.00)\n", base);
      std::printf("write (gen + PLY), 1 thread:    %8.3f s wall, %.3f s cpu  (x%.2f)\n", w1, cpu1, w1 / base);
      std::printf("write (gen + PLY), %d threads:   %8.3f s wall, %.3f s cpu  (x%.2f; speed-up x%.2f)\n", threads, wn,
                  cpun, wn / base, w1 / wn);
      std::printf("written: %.1f MB; triangles per shape min %ld, median %.0f, mean %.0f, max %ld\n", bytes / 1e6,
                  all_min, median(all_tris), all_sum / static_cast<double>(all_tris.size()), all_max);
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench synth", "time generating and writing the procedural benchmark (1 and N threads)",
                        setup_bench_synth);

}  // namespace
}  // namespace sdfkit::app
