#include "bench/synth_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/json.h"
#include "synth/benchmark.h"
#include "synth/categories.h"

#include <tbb/task_arena.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>

namespace sdfkit {

SynthBenchResult run_synth_bench(const SynthBenchSettings& settings) {
  namespace fs = std::filesystem;
  SynthSettings s;
  s.per_category = settings.per_category;
  s.seed = settings.seed;
  const auto plan = plan_benchmark(s);
  const size_t ncat = categories().size();

  // 1. In-memory generation on one thread, per category (the baseline).
  std::vector<std::vector<double>> cat_ms(ncat);
  std::vector<std::vector<long>> tris(ncat);
  std::vector<double> gen_total;
  for (int rep = 0; rep < settings.reps; ++rep) {
    std::vector<double> acc(ncat, 0.0);
    const auto t0 = BenchClock::now();
    for (const auto& e : plan) {
      const auto a = BenchClock::now();
      const SynthShape shape = generate_shape(e.category, e.seed);
      acc[e.category] += seconds_since(a);
      if (rep == 0) tris[e.category].push_back(static_cast<long>(shape.mesh.F.rows()));
    }
    gen_total.push_back(seconds_since(t0));
    for (size_t c = 0; c < ncat; ++c) cat_ms[c].push_back(1e3 * acc[c] / settings.per_category);
  }
  const double base = median(gen_total);

  // 2. Writing the benchmark (generate + PLY + lists + categories.json) with 1 thread and with `jobs`.
  const fs::path dir = fs::temp_directory_path() / ("sdfkit_bench_synth_" + std::to_string(::getpid()));
  auto time_write = [&](int jobs, double* cpu) {
    std::vector<double> walls, cpus;
    s.jobs = jobs;
    for (int rep = 0; rep < settings.reps; ++rep) {
      fs::remove_all(dir);
      const double c0 = process_cpu_seconds();
      const auto t0 = BenchClock::now();
      write_benchmark(dir.string(), s);
      walls.push_back(seconds_since(t0));
      cpus.push_back(process_cpu_seconds() - c0);
    }
    if (cpu) *cpu = median(cpus);
    return median(walls);
  };
  SynthBenchResult out;
  out.shapes = plan.size();
  out.per_category = settings.per_category;
  out.reps = settings.reps;
  out.generate_1_thread_s = base;
  out.write_1_thread_wall_s = time_write(1, &out.write_1_thread_cpu_s);
  out.write_parallel_wall_s = time_write(settings.jobs, &out.write_parallel_cpu_s);
  out.write_threads = settings.jobs > 0 ? settings.jobs : tbb::this_task_arena::max_concurrency();
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.bytes_written += e.file_size();
  fs::remove_all(dir);

  long all_min = 1L << 60, all_max = 0;
  double all_sum = 0;
  std::vector<double> all_tris;
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
    out.categories.push_back({categories()[c].name, median(cat_ms[c]), mn, median(t), mx});
  }
  out.triangles_min = all_min;
  out.triangles_max = all_max;
  out.triangles_median = median(all_tris);
  out.triangles_mean = all_sum / static_cast<double>(all_tris.size());
  return out;
}

std::string synth_bench_text(const SynthBenchResult& r) {
  using detail::bench_printf;
  std::string text =
      bench_printf("%zu shapes (%d per category), %d runs, medians; baseline = in-memory generation on 1 thread\n",
                   r.shapes, r.per_category, r.reps);
  text += bench_printf("%-11s %10s %10s %10s %10s\n", "category", "ms/shape", "tri min", "tri median", "tri max");
  for (const SynthBenchCategory& c : r.categories)
    text += bench_printf("%-11s %10.3f %10ld %10.0f %10ld\n", c.name.c_str(), c.ms_per_shape, c.triangles_min,
                         c.triangles_median, c.triangles_max);
  const double base = r.generate_1_thread_s, w1 = r.write_1_thread_wall_s, wn = r.write_parallel_wall_s;
  text += bench_printf("generate only, 1 thread:        %8.3f s  (x1.00)\n", base);
  text += bench_printf("write (gen + PLY), 1 thread:    %8.3f s wall, %.3f s cpu  (x%.2f)\n", w1,
                       r.write_1_thread_cpu_s, w1 / base);
  text += bench_printf("write (gen + PLY), %d threads:   %8.3f s wall, %.3f s cpu  (x%.2f; speed-up x%.2f)\n",
                       r.write_threads, wn, r.write_parallel_cpu_s, wn / base, w1 / wn);
  text += bench_printf("written: %.1f MB; triangles per shape min %ld, median %.0f, mean %.0f, max %ld\n",
                       static_cast<double>(r.bytes_written) / 1e6, r.triangles_min, r.triangles_median,
                       r.triangles_mean, r.triangles_max);
  return text;
}

Json synth_bench_json(const SynthBenchResult& r) {
  Json cats = Json::array();
  for (const SynthBenchCategory& c : r.categories)
    cats.push_back({{"category", c.name},
                    {"ms_per_shape", c.ms_per_shape},
                    {"triangles_min", c.triangles_min},
                    {"triangles_median", c.triangles_median},
                    {"triangles_max", c.triangles_max}});
  const double base = r.generate_1_thread_s, w1 = r.write_1_thread_wall_s, wn = r.write_parallel_wall_s;
  return {{"shapes", r.shapes},
          {"per_category", r.per_category},
          {"reps", r.reps},
          {"categories", cats},
          {"generate_1_thread_s", base},
          {"write_1_thread_wall_s", w1},
          {"write_1_thread_cpu_s", r.write_1_thread_cpu_s},
          {"write_threads", r.write_threads},
          {"write_parallel_wall_s", wn},
          {"write_parallel_cpu_s", r.write_parallel_cpu_s},
          {"write_1_thread_over_generate", w1 / base},
          {"parallel_speedup", w1 / wn},
          {"bytes_written", r.bytes_written},
          {"triangles_min", r.triangles_min},
          {"triangles_median", r.triangles_median},
          {"triangles_mean", r.triangles_mean},
          {"triangles_max", r.triangles_max}};
}

}  // namespace sdfkit
