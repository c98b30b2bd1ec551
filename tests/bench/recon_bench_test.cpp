#include "bench/recon_bench.h"

#include "core/files.h"
#include "core/json.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

using namespace sdfkit;

namespace {

ReconBenchResult two_rows() {
  ReconBenchResult r;
  r.data = "out/prepared";
  r.split = "test";
  r.cam = "gt";
  r.safety = 2;
  r.shapes = 2;
  ReconBenchRow adaptive;
  adaptive.resolution = 65;
  adaptive.seconds = {0.25, 0.75};  // median 0.5
  adaptive.field_seconds = {0.125, 0.125};
  adaptive.evaluations = {1000, 3000};
  adaptive.cd = {2, 4};
  adaptive.iou = {50, 60};
  adaptive.f1 = {30, 40};
  ReconBenchRow dense = adaptive;
  dense.dense = true;
  dense.seconds = {1, 2};
  dense.evaluations = {274625, 274625};
  r.rows = {adaptive, dense};
  return r;
}

}  // namespace

TEST_CASE("recon bench formatters: heading, one Markdown line, JSON object and CSV line per row") {
  const ReconBenchResult r = two_rows();
  CHECK(recon_bench_text(r) ==
        "bench recon: 2 shapes of out/prepared (test, view 0), camera gt, safety 2\n\n"
        "| resolution | extraction | s/image (median) | field s (median) | evaluations (mean) | CD x1000 | IoU % | "
        "F-score(1%) |\n|---|---|---|---|---|---|---|---|\n"
        "| 65^3 | adaptive | 0.500 | 0.125 | 2000 | 3.000 | 55.00 | 35.00 |\n"
        "| 65^3 | dense | 1.500 | 0.125 | 274625 | 3.000 | 55.00 | 35.00 |\n");
  CHECK(recon_bench_csv(r) ==
        "resolution,extraction,seconds,field_seconds,evaluations,cd,iou,f1\n"
        "65,adaptive,0.5,0.125,2000,3,55,35\n"
        "65,dense,1.5,0.125,274625,3,55,35\n");
  const Json j = recon_bench_json(r);
  REQUIRE(j.size() == 2);
  CHECK(j[0]["resolution"] == 65);
  CHECK(j[0]["extraction"] == "adaptive");
  CHECK(j[0]["seconds"] == 0.5);
  CHECK(j[0]["evaluations"] == 2000.0);
  CHECK(j[0]["shapes"] == 2);
  CHECK(j[1]["extraction"] == "dense");
  CHECK(j[1]["seconds"] == 1.5);
  CHECK(j[1]["iou"] == 55.0);
}

TEST_CASE("recon bench files: OUT.csv holds the CSV, OUT.svg the plot") {
  const std::filesystem::path dir = test::scratch_dir("recon_bench_files");
  const std::string out = (dir / "bench").string();
  const ReconBenchResult r = two_rows();
  write_recon_bench_files(r, out);
  CHECK(read_file(out + ".csv") == recon_bench_csv(r));
  const std::string svg = read_file(out + ".svg");
  CHECK(svg.find("<svg") != std::string::npos);
  CHECK(svg.find("CD x1000 adaptive") != std::string::npos);
}
