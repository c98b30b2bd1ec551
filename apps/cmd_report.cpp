// `sdfkit report RESULTS.json -o DIR`: the HTML report of a batch of reconstructions (report/report.h,
// docs/report.md).
#include "apps/command.h"
#include "core/error.h"
#include "core/json.h"
#include "report/report.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace sdfkit::app {
namespace {

/// The viewer folder: $SDFKIT_VIEWER_DIR when set, else <sdfkit's folder>/../share/sdfkit/viewer (where
/// scripts/vendor_viewer puts it in the build tree and `cmake --install` in a prefix), found as the models are.
std::string default_viewer_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("SDFKIT_VIEWER_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  return (exe.parent_path().parent_path() / "share" / "sdfkit" / "viewer").string();
}

std::function<int()> setup_report(CLI::App& app) {
  struct Opts {
    std::string results, out;
    ReportSettings s;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("results", o->results, "what `sdfkit recon --json` printed, saved to a file")->required();
  app.add_option("-o,--out", o->out, "report folder (index.html, items/, viewer/, curves/)")->required();
  app.add_option("--gt", o->s.gt_dir,
                 "folder of ground truths <input stem>.{obj,ply,off,stl,glb,gltf}: shown beside each reconstruction "
                 "and scored (protocol disn: CD, F-score at 1%, IoU)");
  app.add_option("--curve", o->s.curves, "an SVG loss curve to show (train's and refine's *.loss.svg); repeatable");
  app.add_option("--title", o->s.title, "the page's title")->capture_default_str();
  app.add_option("--max-faces", o->s.max_faces, "faces per mesh in the 3D views (decimated beyond)")
      ->check(in_range(100, 1000000))
      ->capture_default_str();
  app.add_option("--thumbnail", o->s.thumbnail, "longest side of the input images in the page, in pixels")
      ->check(in_range(16, 4096))
      ->capture_default_str();
  return [o] {
    std::ifstream in(o->results);
    if (!in) throw IoError(o->results + ": cannot open");
    std::stringstream text;
    text << in.rdbuf();
    const Json records = Json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
    if (records.is_discarded()) throw InvalidInput(o->results + ": not JSON (save `sdfkit recon --json`'s output)");
    o->s.viewer_dir = default_viewer_dir();
    ReportSummary sum;
    try {
      sum = write_report(records, std::filesystem::path(o->results).parent_path().string(), o->out, o->s);
    } catch (const InvalidInput& e) {
      throw InvalidInput(o->results + ": " + e.what());
    }
    std::cout << (std::filesystem::path(o->out) / "index.html").string() << ": " << sum.items << " items ("
              << sum.failed << " failed, " << sum.scored << " scored), " << sum.bytes / 1024 << " KiB in all, "
              << sum.first_view_bytes / 1024 << " KiB before any 3D model\n";
    return sum.failed > 0 ? 2 : 0;
  };
}

}  // namespace

SDFKIT_REGISTER_COMMAND("report", "an HTML report of a recon batch: input images, turnable meshes beside their ground "
                                  "truth, scores, timings, warnings",
                        setup_report);

}  // namespace sdfkit::app
