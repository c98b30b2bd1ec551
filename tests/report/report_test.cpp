// The report folder (report/report.h): the rows, the failures, the scores and the embedded models, and the error
// when the viewer is missing.
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "camera/image.h"
#include "report/report.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
size_t count_of(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

/// The data-v values of the row of item `name`, from its name on (name, category, CD, F, IoU, seconds, faces,
/// warnings).
std::vector<std::string> row_values(const std::string& html, const std::string& name) {
  std::vector<std::string> out;
  size_t at = html.find("data-v=\"" + name + "\"");
  const size_t end = html.find("</tr>", at);
  for (; at < end; at = html.find("data-v=\"", at + 1)) {
    const size_t from = at + 8;
    out.push_back(html.substr(from, html.find('"', from) - from));
  }
  return out;
}

}  // namespace

TEST_CASE("write_report: one row per record, failures shown, scores against the ground truth") {
  const fs::path dir = test::scratch_dir("report_write");
  fs::create_directories(dir / "viewer");
  write_text_atomic((dir / "viewer" / "model-viewer-umd.min.js").string(), "/* stand-in */\n");
  write_text_atomic((dir / "viewer" / "LICENSE").string(), "licence\n");
  // chair_1: reconstructed exactly (its ground truth is the same sphere): CD 0, F 100, IoU 100.
  // car_2: a smaller sphere than its ground truth. car_3: recon failed. sofa_4: its mesh is unreadable.
  write_mesh((dir / "chair_1.ply").string(), make_icosphere(Vec3(0, 0, 0), 0.5, 3));
  write_mesh((dir / "gt" / "chair_1.ply").string(), make_icosphere(Vec3(0, 0, 0), 0.5, 3));
  write_mesh((dir / "car_2.obj").string(), make_icosphere(Vec3(0, 0, 0), 0.3, 3));
  write_mesh((dir / "gt" / "car_2.obj").string(), make_icosphere(Vec3(0, 0, 0), 0.5, 3));
  write_text_atomic((dir / "sofa_4.obj").string(), "v 0 0 0\nf 1 2 3\n");
  write_image((dir / "chair_1.png").string(), Image(300, 200, 3, 0.5f));
  const Json records = Json::array(
      {{{"input", "chair_1.png"}, {"mesh", "chair_1.ply"}, {"warnings", {"a <warning>"}}, {"seconds", {{"total", 1.5}}}},
       {{"input", "car_2.png"}, {"mesh", "car_2.obj"}, {"seconds", {{"total", 2.5}}}},
       {{"input", "car_3.png"}, {"error", "car_3.png: no object found"}},
       {{"input", "sofa_4.png"}, {"mesh", "sofa_4.obj"}}});
  ReportSettings s;
  s.viewer_dir = (dir / "viewer").string();
  s.gt_dir = (dir / "gt").string();
  const fs::path out = dir / "out";
  const ReportSummary sum = write_report(records, dir.string(), out.string(), s);
  CHECK(sum.items == 4);
  CHECK(sum.failed == 2);
  CHECK(sum.scored == 2);
  const std::string html = slurp(out / "index.html");
  CHECK(count_of(html, "<tr><td class=\"num\" data-v=") == 4);
  CHECK(count_of(html, "<div class=\"view\" data-k=") == 2);
  CHECK(html.find("car_3.png: no object found") != std::string::npos);
  CHECK(html.find("a &lt;warning&gt;") != std::string::npos);
  CHECK(fs::exists(out / "items" / "0.js"));
  CHECK(fs::exists(out / "items" / "1.js"));
  CHECK_FALSE(fs::exists(out / "items" / "2.js"));
  CHECK(fs::exists(out / "items" / "0.jpg"));  // the one input image that exists
  const Image thumb = read_image((out / "items" / "0.jpg").string());
  CHECK(thumb.width == 192);
  CHECK(thumb.height == 128);
  CHECK(fs::exists(out / "viewer" / "LICENSE"));
  // chair_1 is its ground truth: IoU 100 (CD is not 0: disn samples the two meshes' vertices with different draws).
  // car_2 is the ground truth scaled by 0.6: IoU 0.6^3 = 21.6%, its CD far larger than chair_1's.
  const auto chair = row_values(html, "chair_1"), car = row_values(html, "car_2");
  REQUIRE(chair.size() == 8);
  REQUIRE(car.size() == 8);
  CHECK(chair[1] == "chair");
  CHECK(std::stod(chair[4]) == doctest::Approx(100.0));
  CHECK(std::stod(car[4]) == doctest::Approx(21.6).epsilon(0.1));
  CHECK(std::stod(car[2]) > 10 * std::stod(chair[2]));
  CHECK(std::stod(chair[5]) == doctest::Approx(1.5));
  CHECK(chair[6] == "1280");
  CHECK(chair[7] == "1");
  CHECK(html.find("<tr><td>chair</td><td class=\"num\">1</td><td class=\"num\">0</td>") != std::string::npos);
  CHECK(html.find("<tr><td>car</td><td class=\"num\">2</td><td class=\"num\">1</td>") != std::string::npos);
  // The embedded model: recon beside its ground truth, so twice the faces of one icosphere (1280 each).
  const std::string js = slurp(out / "items" / "0.js");
  CHECK(js.rfind("sdfkitModel(0,\"Z2xURg", 0) == 0);  // base64 of "glTF"
  // Same input, same bytes.
  const std::string first = html;
  write_report(records, dir.string(), out.string(), s);
  CHECK(slurp(out / "index.html") == first);
  CHECK(slurp(out / "items" / "0.js") == js);
  fs::remove_all(dir);
}

TEST_CASE("write_report: a missing viewer is one clear error naming the fix") {
  ReportSettings s;
  s.viewer_dir = "/nonexistent/viewer";
  CHECK_THROWS_WITH_AS(write_report(Json::array(), "", test::scratch_dir("report_noviewer").string(), s),
                       doctest::Contains("run scripts/vendor_viewer"), InvalidInput);
  s.viewer_dir = "";
  CHECK_THROWS_AS(write_report(Json::array(), "", test::scratch_dir("report_noviewer").string(), s), InvalidInput);
}
