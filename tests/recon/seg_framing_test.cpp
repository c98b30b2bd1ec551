// recon's framing with the segmenter network (`recon --segment net`, FramingSettings::segmenter).
#include "recon/framing.h"

#include "cli_run.h"
#include "core/error.h"
#include "core/random.h"
#include "nets/seg_net.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A cluttered 160 x 120 photo (noise) with a red disc of radius 25 at (100, 60).
Image cluttered_photo() {
  Image img(160, 120, 3);
  Rng rng(4);
  for (float& v : img.data) v = static_cast<float>(rng.uniform());
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if ((x - 100) * (x - 100) + (y - 60) * (y - 60) < 25 * 25) img.at(x, y, 0) = 0.9f, img.at(x, y, 1) = img.at(x, y, 2) = 0.1f;
  return img;
}

/// A stand-in for the network: probability 0.9 inside the disc, 0.4 on a ring around it, 0.1 elsewhere.
Image disc_probability(const Image& rgb) {
  Image p(rgb.width, rgb.height, 1, 0.1f);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) {
      const double r = std::hypot(x - 100, y - 60);
      p.at(x, y) = r < 25 ? 0.9f : r < 28 ? 0.4f : 0.1f;
    }
  return p;
}

}  // namespace

TEST_CASE("recon framing with the segmenter: net and auto use it, the ramp keeps soft edges, no model is an error") {
  const Image photo = cluttered_photo();
  FramingSettings st;
  st.segmenter = disc_probability;
  for (const Segmentation s : {Segmentation::kNet, Segmentation::kAuto}) {
    CAPTURE(segmentation_name(s));
    st.segment = s;
    const FramedInput f = frame_input(photo, nullptr, st, "photo.png");
    CHECK(f.mask.at(100, 60) == 1.0f);
    CHECK(f.mask.at(5, 5) == 0.0f);
    CHECK(f.reframed);
    const bool warned = std::any_of(f.warnings.begin(), f.warnings.end(),
                                    [](const std::string& w) { return w.find("segmenter network") != std::string::npos; });
    CHECK(warned == (s == Segmentation::kAuto));
    if (s == Segmentation::kNet) {  // the network's mask as it is
      CHECK(f.mask_source == "net");
      CHECK(f.mask.at(100 + 25, 60) == doctest::Approx(0.25));  // (0.4 - 0.3) / 0.4, next to the disc: kept
      CHECK(f.mask.at(100 + 27, 60) == 0.0f);                   // soft, but not touching the disc: a speck
      // The disc's box: 49 px around (100, 60).
      CHECK(f.object_box.x == 76);
      CHECK(f.object_box.w == 49);
    } else {  // auto: GrabCut seeded with it keeps the disc
      CHECK(f.mask_source == "net+grabcut");
      CHECK(std::abs(f.object_box.x - 76) <= 2);
      CHECK(std::abs(f.object_box.w - 49) <= 3);
    }
  }
  // A rough network (a square 1.6 times the disc's size): --segment net keeps the square, auto's GrabCut cuts it
  // down to the red disc, whose colours differ from the noise around it.
  st.segmenter = [](const Image& rgb) {
    Image p(rgb.width, rgb.height, 1, 0.1f);
    for (int y = 20; y < 100; ++y)
      for (int x = 60; x < 140; ++x) p.at(x, y) = 0.9f;
    return p;
  };
  const auto disc_iou = [](const Image& m) {
    long inter = 0, uni = 0;
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x) {
        const bool a = m.at(x, y) > 0.5f, b = (x - 100) * (x - 100) + (y - 60) * (y - 60) < 25 * 25;
        inter += a && b;
        uni += a || b;
      }
    return static_cast<double>(inter) / static_cast<double>(uni);
  };
  st.segment = Segmentation::kNet;
  CHECK(disc_iou(frame_input(photo, nullptr, st, "photo.png").mask) < 0.5);
  st.segment = Segmentation::kAuto;
  const FramedInput refined = frame_input(photo, nullptr, st, "photo.png");
  CHECK(refined.mask_source == "net+grabcut");
  CHECK(disc_iou(refined.mask) > 0.9);
  // A network that sees nothing: auto falls back to GrabCut from the rectangle (--segment grabcut's mask).
  Image textured = photo;  // on a smooth texture GrabCut's rectangle finds the disc
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if ((x - 100) * (x - 100) + (y - 60) * (y - 60) >= 25 * 25) {
        textured.at(x, y, 0) = 0.2f + 0.1f * static_cast<float>(std::sin(x / 7.0));
        textured.at(x, y, 1) = 0.5f + 0.2f * static_cast<float>(std::cos(y / 5.0));
        textured.at(x, y, 2) = 0.6f;
      }
  st.segmenter = [](const Image& rgb) { return Image(rgb.width, rgb.height, 1, 0.1f); };
  const FramedInput fallback = frame_input(textured, nullptr, st, "textured.png");
  FramingSettings gc;
  gc.segment = Segmentation::kGrabCut;
  const FramedInput by_grabcut = frame_input(textured, nullptr, gc, "textured.png");
  CHECK(fallback.mask_source == "grabcut");
  CHECK(fallback.mask.data == by_grabcut.mask.data);
  CHECK(disc_iou(fallback.mask) > 0.8);
  st.segmenter = disc_probability;
  // A plain background is still found without the network in auto mode.
  Image plain(160, 120, 3, 1.0f);
  for (int y = 40; y < 80; ++y)
    for (int x = 50; x < 110; ++x) plain.at(x, y, 1) = 0.2f;
  st.segment = Segmentation::kAuto;
  CHECK(frame_input(plain, nullptr, st, "plain.png").mask_source == "plain-background");
  // --segment net without a network; a network answering with another size.
  st.segment = Segmentation::kNet;
  st.segmenter = nullptr;
  CHECK_THROWS_AS(frame_input(photo, nullptr, st, "photo.png"), InvalidInput);
  st.segmenter = [](const Image&) { return Image(3, 3, 1, 0.9f); };
  CHECK_THROWS_AS(frame_input(photo, nullptr, st, "photo.png"), InvalidInput);
  CHECK(parse_segmentation("net") == Segmentation::kNet);
  CHECK(segmentation_name(Segmentation::kNet) == "net");
}

TEST_CASE("recon --segment net: the model is loaded from --seg-model, a missing one is named") {
  const fs::path dir = test::scratch_dir("recon_seg_net");
  write_image((dir / "photo.png").string(), cluttered_photo());
  const std::string missing = (dir / "none.ckpt").string();
  const test::CliRun r = test::run_sdfkit("recon " + (dir / "photo.png").string() + " -o " +
                                          (dir / "out.obj").string() + " --segment net --seg-model " + missing);
  CHECK(r.code == 1);
  CHECK(r.err.find(missing) != std::string::npos);
  // A segmenter that calls every pixel the object: its mask covers the whole image, which recon refuses, naming the
  // mask source.
  SegNetConfig c;
  c.size = 32;
  c.encoder = {4, 8};
  c.decoder = {4};
  SegNet net(c, false);
  std::fill(net.params().values.begin(), net.params().values.end(), 0.0f);
  net.params().values.back() = 3.0f;  // the logit's bias
  save_seg_model((dir / "all.ckpt").string(), net);
  const test::CliRun all = test::run_sdfkit("recon " + (dir / "photo.png").string() + " -o " +
                                            (dir / "out.obj").string() + " --segment net --seg-model " +
                                            (dir / "all.ckpt").string());
  CHECK(all.code == 1);
  CHECK(all.err.find("net mask covers") != std::string::npos);
  const test::CliRun with_mask = test::run_sdfkit("recon " + (dir / "photo.png").string() + " -o " +
                                                  (dir / "out.obj").string() + " --mask " +
                                                  (dir / "photo.png").string() + " --seg-model " +
                                                  (dir / "all.ckpt").string());
  CHECK(with_mask.code == 1);
  CHECK(with_mask.err.find("--seg-model") != std::string::npos);
  // auto takes the model folder's seg.ckpt when it exists ($SDFKIT_MODEL_DIR here, with the shipped SDF and pose
  // models beside it).
  const fs::path models = dir / "models";
  fs::create_directories(models);
  for (const char* m : {"sdf.ckpt", "pose.ckpt"})
    fs::create_symlink(fs::path(SDFKIT_SOURCE_DIR) / "data" / "models" / m, models / m);
  fs::copy_file(dir / "all.ckpt", models / "seg.ckpt");
  const test::CliRun by_default = test::run_sdfkit_under("SDFKIT_MODEL_DIR=" + models.string(),
                                                         "recon " + (dir / "photo.png").string() + " -o " +
                                                             (dir / "out.obj").string());
  CHECK(by_default.code == 1);
  CHECK(by_default.err.find("net mask covers") != std::string::npos);
  const test::CliRun with_grabcut = test::run_sdfkit("recon " + (dir / "photo.png").string() + " -o " +
                                                     (dir / "out.obj").string() + " --segment grabcut --seg-model " +
                                                     (dir / "all.ckpt").string());
  CHECK(with_grabcut.code == 1);
  CHECK(with_grabcut.err.find("--seg-model applies") != std::string::npos);
}
