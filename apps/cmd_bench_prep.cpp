// `sdfkit bench prep`: dataset preparation against a dense baseline, grid error against brute force
// (bench/prep_bench.h).
#include "apps/command.h"
#include "bench/prep_bench.h"
#include "core/json.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace sdfkit::app {
namespace {

std::function<int()> setup_bench_prep(CLI::App& app) {
  struct Opts {
    PrepBenchSettings s;
    std::string sign = "auto";
    bool json = false;
    bool no_dense = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("meshes", o->s.meshes, "extra meshes to time (default: the built-in 50k closed mesh and soup, and "
                                        "data/examples/meshes/*)");
  app.add_option("--repeats", o->s.repeats, "timed runs per shape and thread count (median reported)")
      ->check(positive())
      ->capture_default_str();
  app.add_option("--dense-res", o->s.dense_res, "resolution of the dense baseline grid over [-1.2, 1.2]^3")
      ->check(in_range(2, 1025))
      ->capture_default_str();
  app.add_option("--band-points", o->s.band_points, "random band points for the error against brute force")
      ->check(non_negative())
      ->capture_default_str();
  app.add_flag("--no-dense", o->no_dense, "skip the dense baseline");
  app.add_option("--band", o->s.band, "grid band half-width as in `sdfkit prep --band` (0 = 3 voxels)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--sign", o->sign, "sign method as in `sdfkit prep --sign`: auto, winding or flood")
      ->check(CLI::IsMember({"auto", "winding", "flood"}))
      ->capture_default_str();
  app.add_flag("--tree-memory", o->s.tree_memory,
               "also report the memory of the same active voxels in non-standard OpenVDB trees with 4^3 leaves "
               "(5,4,2 and 4,3,2 log2 node sizes; such trees are not FloatGrids other tools read)");
  app.add_option("--only", o->s.only, "time only the shapes whose name contains this text (e.g. torus, soup)");
  app.add_flag("--json", o->json, "print the results as JSON on stdout (the table then goes to stderr)");
  return [o] {
    std::FILE* text = o->json ? stderr : stdout;
    o->s.sign = o->sign == "winding" ? SignMethod::kWindingNumber : SignMethod::kAuto;
    o->s.seal = o->sign == "flood";
    o->s.dense_baseline = !o->no_dense;
    o->s.example_meshes = (std::filesystem::path(SDFKIT_SOURCE_DIR) / "data" / "examples" / "meshes").string();
    // The header is printed once the meshes are read (an unreadable mesh fails before any output).
    bool header = false;
    const PrepBenchResult r = run_prep_bench(o->s, [&](const PrepBenchRow& row) {
      if (!header) std::fputs(prep_bench_header().c_str(), text);
      header = true;
      std::fputs(prep_bench_row_text(row).c_str(), text);
      std::fflush(text);
    });
    if (!header) std::fputs(prep_bench_header().c_str(), text);
    std::fputs(prep_bench_footer(r).c_str(), text);
    if (o->json) std::cout << prep_bench_json(r).dump(2) << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench prep", "time dataset preparation against a dense baseline; error vs brute force",
                        setup_bench_prep);

}  // namespace
}  // namespace sdfkit::app
