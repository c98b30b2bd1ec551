// CLI-level tests of `sdfkit segment`: the mask recon would use, written without reconstructing, and scored against
// reference masks (--truth).
#include "camera/image.h"
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const std::string kSource = SDFKIT_SOURCE_DIR;

test::CliRun run(const std::string& args) { return test::run_sdfkit(args); }

/// The plane example pasted at (ox, oy) on a plain blue W x H image (RGB), and its exact mask as an RGBA canvas
/// (the render's alpha at that place, transparent elsewhere), as scripts/framing_results makes its composites.
void paste_plane(const std::string& image_path, const std::string& truth_path, int W, int H, int ox, int oy) {
  const Image plane = read_image(kSource + "/data/examples/plane_0010.png");
  REQUIRE(plane.channels == 4);
  Image comp(W, H, 3), truth(W, H, 4, 0.0f);
  const float bg[3] = {0.15f, 0.3f, 0.75f};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) comp.at(x, y, c) = bg[c];
  for (int y = 0; y < plane.height; ++y)
    for (int x = 0; x < plane.width; ++x) {
      const float a = plane.at(x, y, 3);
      for (int c = 0; c < 3; ++c) {
        comp.at(ox + x, oy + y, c) = a * plane.at(x, y, c) + (1 - a) * bg[c];
        truth.at(ox + x, oy + y, c) = plane.at(x, y, c);
      }
      truth.at(ox + x, oy + y, 3) = a;
    }
  write_image(image_path, comp);
  write_image(truth_path, truth);
}

}  // namespace

TEST_CASE("segment: the mask recon uses, scored against the exact mask") {
  const fs::path dir = test::scratch_dir("segment_cli") / "one";
  fs::remove_all(dir);
  fs::create_directories(dir / "truth");
  const std::string in = (dir / "comp.png").string(), truth = (dir / "truth" / "comp.png").string();
  paste_plane(in, truth, 300, 180, 150, 30);
  const std::string mask = (dir / "comp_mask.png").string();
  const test::CliRun r = run("segment " + in + " -o " + mask + " --truth " + truth + " --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  REQUIRE(j["images"].size() == 1);
  const Json& item = j["images"][0];
  CHECK(item["mask_source"] == "plain-background");
  CHECK(item["mask"] == mask);
  const double iou = item["iou"].get<double>();
  MESSAGE("mask IoU of the plane on blue: " << iou);
  CHECK(iou > 0.95);  // a plain background: the mask is the render's alpha up to anti-aliased edges
  CHECK(iou <= 1.0);
  CHECK(j["summary"]["mean_iou"].get<double>() == doctest::Approx(iou));
  CHECK(j["summary"]["failed"] == 0);
  const Image m = read_image(mask);
  CHECK(m.width == 300);
  CHECK(m.height == 180);

  // recon writes the same mask beside its mesh (one framing code path).
  const test::CliRun rr = run("recon " + in + " -o " + (dir / "comp.obj").string() + " --res 33 --framing-fit 0");
  REQUIRE_MESSAGE(rr.code == 0, rr.err);
  CHECK(read_file((dir / "comp.mask.png").string()) == read_file(mask));

  // The mask scored against itself is a perfect match; against the image's complement it is disjoint.
  const test::CliRun self = run("segment " + in + " -o " + (dir / "again.png").string() + " --truth " + mask + " --json");
  REQUIRE_MESSAGE(self.code == 0, self.err);
  const Json self_item = Json::parse(self.out)["images"][0];
  CHECK(self_item["iou"].get<double>() == doctest::Approx(1.0));
  CHECK(self_item["missed"].get<double>() == 0.0);
  CHECK(self_item["extra"].get<double>() == 0.0);
  Image inverse = m;
  for (float& v : inverse.data) v = 1.0f - v;
  const std::string inv = (dir / "inverse.png").string();
  write_image(inv, inverse);
  const test::CliRun none = run("segment " + in + " -o " + (dir / "again.png").string() + " --truth " + inv + " --json");
  REQUIRE_MESSAGE(none.code == 0, none.err);
  const Json none_item = Json::parse(none.out)["images"][0];
  CHECK(none_item["iou"].get<double>() == doctest::Approx(0.0));
  CHECK(none_item["missed"].get<double>() == doctest::Approx(1.0));  // the reference is all the mask leaves out
  CHECK(none_item["extra"].get<double>() > 0.0);
}

TEST_CASE("segment: a folder reports each failed image, scores it 0 and goes on") {
  const fs::path dir = test::scratch_dir("segment_cli") / "folder";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  fs::create_directories(dir / "truth");
  paste_plane((dir / "in" / "a.png").string(), (dir / "truth" / "a.png").string(), 300, 180, 20, 10);
  Image blank(200, 120, 3, 0.8f);  // only background
  write_image((dir / "in" / "b.png").string(), blank);
  write_image((dir / "truth" / "b.png").string(), Image(200, 120, 1, 0.0f));
  const std::string out = (dir / "masks").string();
  const test::CliRun r =
      run("segment " + (dir / "in").string() + " -o " + out + " --truth " + (dir / "truth").string() + " --json");
  CHECK(r.code == 2);  // some items failed
  CHECK(r.err.find("b.png: the image shows only background") != std::string::npos);
  const Json j = Json::parse(r.out);
  REQUIRE(j["images"].size() == 2);
  CHECK(fs::exists(out + "/a.mask.png"));
  CHECK_FALSE(fs::exists(out + "/b.mask.png"));
  CHECK(j["images"][1].contains("error"));
  CHECK(j["images"][1]["iou"].get<double>() == 0.0);
  const double a = j["images"][0]["iou"].get<double>();
  CHECK(a > 0.95);
  CHECK(j["summary"]["scored"] == 2);
  CHECK(j["summary"]["failed"] == 1);
  CHECK(j["summary"]["below_half"] == 1);
  CHECK(j["summary"]["mean_iou"].get<double>() == doctest::Approx(a / 2));
  CHECK(j["summary"]["median_iou"].get<double>() == doctest::Approx(a / 2));
  // Text mode: one line per image and the summary.
  const test::CliRun t = run("segment " + (dir / "in").string() + " -o " + out + " --truth " + (dir / "truth").string());
  CHECK(t.code == 2);
  CHECK(t.out.find("2 images: mean mask IoU") != std::string::npos);
}

TEST_CASE("segment: bad arguments are one-line errors") {
  const fs::path dir = test::scratch_dir("segment_cli") / "errors";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  const std::string in = (dir / "in" / "a.png").string(), truth = (dir / "a_truth.png").string();
  paste_plane(in, truth, 300, 180, 20, 10);
  write_image((dir / "small.png").string(), Image(100, 60, 1, 0.0f));
  const auto fails = [&](const std::string& args, const std::string& says) {
    const test::CliRun r = run(args);
    CHECK_MESSAGE(r.code == 1, args);
    const std::string context = args + " said: " + r.err;
    CHECK_MESSAGE(r.err.find(says) != std::string::npos, context);
  };
  fails("segment " + in + " -o " + (dir / "m.obj").string(), "give a .png path");
  fails("segment " + (dir / "in").string() + " -o " + (dir / "masks").string() + " --truth " + truth,
        "give a folder of reference masks");
  fails("segment " + (dir / "in").string() + " -o " + (dir / "m.png").string(),
        "holds 1 image; give a folder for their masks");  // a folder of one image, counted in the singular
  fails("segment " + in + " -o " + (dir / "m.png").string() + " --segment grabcut --seg-zoom 1",
        "--seg-zoom applies with --segment net or auto");
  fails("segment " + in + " -o " + (dir / "m.png").string() + " --segment grabcut --seg-agreement 0.5",
        "--seg-agreement applies with --segment auto");
  fails("segment " + in + " -o " + (dir / "m.png").string() + " --segment grabcut --seg-sure none",
        "--seg-sure applies with --segment auto");
  fails("segment " + in + " -o " + (dir / "m.png").string() + " --truth " + (dir / "nothing.png").string(),
        "nothing.png: no such file");
  // A reference of another size: the item fails naming both files (exit 1: the only image failed).
  fails("segment " + in + " -o " + (dir / "m.png").string() + " --truth " + (dir / "small.png").string(),
        "small.png: reference mask is 100x60 but");
}
