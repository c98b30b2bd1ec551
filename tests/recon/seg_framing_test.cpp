// recon's framing with the segmenter network (`recon --segment net`, FramingSettings::segmenter).
#include "recon/framing.h"

#include "cli_run.h"
#include "core/error.h"
#include "core/random.h"
#include "models/seg_net.h"
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

/// A stand-in for the network: probability 0.95 inside the disc, 0.6 on a ring around it, 0.1 elsewhere.
Image disc_probability(const Image& rgb) {
  Image p(rgb.width, rgb.height, 1, 0.1f);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) {
      const double r = std::hypot(x - 100, y - 60);
      p.at(x, y) = r < 25 ? 0.95f : r < 28 ? 0.6f : 0.1f;
    }
  return p;
}

}  // namespace

TEST_CASE("recon framing with the segmenter: net and auto use it, the ramp keeps soft edges, no model is an error") {
  const Image photo = cluttered_photo();
  FramingSettings st;
  st.segmenter = disc_probability;
  st.segmenter_zoom_rounds = 0;  // these stand-ins answer in the whole image's coordinates (zoom: the next test)
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
      CHECK(f.mask.at(100 + 25, 60) == doctest::Approx(0.25));  // (0.6 - 0.5) / 0.4, next to the disc: kept
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
  const FramedInput square = frame_input(photo, nullptr, st, "photo.png");
  CHECK(disc_iou(square.mask) < 0.5);
  st.segment = Segmentation::kAuto;
  // GrabCut's disc departs too far from the network's square (IoU 0.31, under grabcut_min_agreement 0.6): on a busy
  // photo that is GrabCut straying, and the network's mask is kept as it is.
  REQUIRE(st.grabcut_min_agreement == 0.6);
  const FramedInput kept = frame_input(photo, nullptr, st, "photo.png");
  CHECK(kept.mask_source == "net");
  CHECK(kept.mask.data == square.mask.data);
  // Without the agreement test GrabCut's mask replaces it.
  st.grabcut_min_agreement = 0;
  const FramedInput refined = frame_input(photo, nullptr, st, "photo.png");
  CHECK(refined.mask_source == "net+grabcut");
  CHECK(disc_iou(refined.mask) > 0.9);
  st.grabcut_min_agreement = 0.6;
  // A square that hugs the disc (side 50: IoU 0.79 with it): GrabCut's trimmed disc agrees enough and is kept.
  st.segmenter = [](const Image& rgb) {
    Image p(rgb.width, rgb.height, 1, 0.1f);
    for (int y = 35; y < 85; ++y)
      for (int x = 75; x < 125; ++x) p.at(x, y) = 0.9f;
    return p;
  };
  const FramedInput hugging = frame_input(photo, nullptr, st, "photo.png");
  CHECK(hugging.mask_source == "net+grabcut");
  CHECK(disc_iou(hugging.mask) > 0.9);
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
  // A network that marks a thin object GrabCut cannot follow (a 3 px strip with the background's own colours):
  // GrabCut seeded with it keeps nothing, and the network's mask is kept rather than the rectangle's GrabCut,
  // which finds the disc the network did not mark (the order before: GrabCut alone whenever the seeded one failed).
  const Image& lined = textured;  // the line is a strip of the texture itself
  const auto line_net = [](const Image& rgb) {
    Image p(rgb.width, rgb.height, 1, 0.1f);
    for (int x = 20; x < 60; ++x)
      for (int y = 99; y < 102; ++y) p.at(x, y) = 0.95f;
    return p;
  };
  st.segmenter = line_net;
  st.segmenter_zoom_rounds = 0;
  const Image line_seed = [&] {
    Image m = line_net(lined);
    for (float& v : m.data) v = std::clamp((v - 0.5f) / 0.4f, 0.f, 1.f);
    return m;
  }();
  const Image seeded = grabcut_mask(lined, {5, 4, 150, 112}, st.grabcut_max_side, st.grabcut_iterations,
                                    GrabCutSeed::kMask, &line_seed);
  REQUIRE(std::none_of(seeded.data.begin(), seeded.data.end(), [](float v) { return v > 0.5f; }));
  REQUIRE(disc_iou(frame_input(lined, nullptr, gc, "lined.png").mask) > 0.8);  // what the rectangle finds
  // With the sure labels (the default) the strip's pixels, at probability 0.95, stay object in GrabCut's mask;
  // without them GrabCut drops the strip and the network's mask is kept as it is.
  for (const bool sure : {true, false}) {
    CAPTURE(sure);
    FramingSettings t = st;
    if (!sure) t.grabcut_sure_object = 2.0, t.grabcut_sure_background = 0.0;
    const FramedInput thin = frame_input(lined, nullptr, t, "lined.png");
    CHECK(thin.mask_source == (sure ? "net+grabcut" : "net"));
    CHECK(thin.mask.at(40, 100) == 1.0f);
    CHECK(thin.mask.at(100, 60) == 0.0f);
    CHECK(thin.object_box.x == 20);
    CHECK(thin.object_box.w == 40);
  }
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

TEST_CASE("recon framing: GrabCut's sure labels (--seg-sure) hold the network's confident object and far background") {
  const Image photo = cluttered_photo();
  FramingSettings st;
  st.segment = Segmentation::kAuto;
  st.segmenter_zoom_rounds = 0;
  st.grabcut_min_agreement = 0;  // GrabCut's mask whenever it keeps an object: the sure labels decide alone
  const auto count = [](const Image& m, int x0, int y0, int x1, int y1) {
    int n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) n += m.at(x, y) > 0.5f;
    return n;
  };
  // A confident rough network: a square 1.6 times the disc at probability 0.99. Free, GrabCut cuts it down to the
  // disc; with pixels at 0.97 and over sure object, the square stays whole.
  st.segmenter = [](const Image& rgb) {
    Image p(rgb.width, rgb.height, 1, 0.1f);
    for (int y = 20; y < 100; ++y)
      for (int x = 60; x < 140; ++x) p.at(x, y) = 0.99f;
    return p;
  };
  st.grabcut_sure_object = 2.0;  // none
  st.grabcut_sure_background = 0;
  const FramedInput free = frame_input(photo, nullptr, st, "photo.png");
  CHECK(free.mask_source == "net+grabcut");
  CHECK(count(free.mask, 62, 22, 70, 30) == 0);  // a corner of the square, off the disc
  st.grabcut_sure_object = 0.97;
  const FramedInput held = frame_input(photo, nullptr, st, "photo.png");
  CHECK(held.mask_source == "net+grabcut");
  CHECK(count(held.mask, 60, 20, 140, 100) == 80 * 80);
  // A second red disc far from the network's object: free, GrabCut takes it in with the object's colour; beyond 0.3
  // times the object's size (15 px) it is sure background.
  Image two = photo;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if ((x - 30) * (x - 30) + (y - 30) * (y - 30) < 12 * 12) two.at(x, y, 0) = 0.9f, two.at(x, y, 1) = two.at(x, y, 2) = 0.1f;
  st.segmenter = disc_probability;
  st.grabcut_sure_object = 2.0;
  st.grabcut_sure_background = 0;
  const FramedInput taken = frame_input(two, nullptr, st, "two.png");
  CHECK(count(taken.mask, 24, 24, 36, 36) > 100);
  st.grabcut_sure_background = 0.3;
  const FramedInput apart = frame_input(two, nullptr, st, "two.png");
  CHECK(count(apart.mask, 18, 18, 42, 42) == 0);
  CHECK(count(apart.mask, 90, 50, 110, 70) == 400);
}

namespace {

/// A 320 x 224 grey photo with a red object: a disc of radius 20 at (120, 80) on a leg 4 px wide down to y = 140.
Image disc_on_leg() {
  Image img(320, 224, 3, 0.5f);
  for (int y = 0; y < 224; ++y)
    for (int x = 0; x < 320; ++x)
      if ((x - 120) * (x - 120) + (y - 80) * (y - 80) < 20 * 20 || (x >= 118 && x < 122 && y >= 80 && y < 140))
        img.at(x, y, 0) = 0.9f, img.at(x, y, 1) = img.at(x, y, 2) = 0.1f;
  return img;
}

/// A stand-in for a network of limited resolution: the image letterboxed to 32 px, each pixel's redness, mapped back.
Image coarse_redness(const Image& rgb) {
  Letterbox g;
  const Image lb = letterbox(rgb, 32, &g);
  Image p(32, 32, 1);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) p.at(x, y) = std::clamp((lb.at(x, y, 0) - lb.at(x, y, 1)) / 0.8f, 0.f, 1.f);
  return unletterbox(p, g);
}

}  // namespace

TEST_CASE("recon framing: the segmenter zooms in on its answer and finds what its resolution lost") {
  const Image photo = disc_on_leg();
  const auto leg_found = [](const Image& p) {
    long n = 0;
    for (int y = 105; y < 140; ++y) n += p.at(120, y) > 0.5f;  // the leg below the disc's blur
    return n;
  };
  const auto iou = [&](const Image& p) {
    long inter = 0, uni = 0;
    for (int y = 0; y < 224; ++y)
      for (int x = 0; x < 320; ++x) {
        const bool a = p.at(x, y) > 0.5f, b = photo.at(x, y, 0) > 0.5f;
        inter += a && b;
        uni += a || b;
      }
    return static_cast<double>(inter) / static_cast<double>(uni);
  };
  // One reading of the whole image (10 px to a letterbox pixel): the disc, not the leg (0.4 letterbox pixels wide).
  int zooms = -1;
  const Image once = zoomed_foreground(coarse_redness, photo, 0, 0.7, "photo.png", &zooms);
  CHECK(zooms == 0);
  CHECK(once.data == coarse_redness(photo).data);
  CHECK(leg_found(once) == 0);
  // Zoomed in around the disc (a 57 px square: 1.8 px to a letterbox pixel), the leg appears; the second round's
  // square, around the disc and that part of the leg, reaches further down it.
  const Image zoomed = zoomed_foreground(coarse_redness, photo, 2, 0.7, "photo.png", &zooms);
  CHECK(zooms == 2);
  CHECK(leg_found(zoomed) >= 12);
  CHECK(iou(zoomed) > iou(once) + 0.05);
  CHECK(zoomed.at(5, 5) == 0.0f);  // outside the last square
  // An object as large as the image: no smaller square to read, no zoom.
  Image big(64, 48, 3, 0.5f);
  for (int y = 2; y < 46; ++y)
    for (int x = 2; x < 62; ++x) big.at(x, y, 0) = 0.9f, big.at(x, y, 1) = big.at(x, y, 2) = 0.1f;
  zoomed_foreground(coarse_redness, big, 2, 0.7, "big.png", &zooms);
  CHECK(zooms == 0);
  // Nothing found: nothing to zoom in on.
  zoomed_foreground(coarse_redness, Image(64, 48, 3, 0.5f), 2, 0.7, "grey.png", &zooms);
  CHECK(zooms == 0);
  // frame_input zooms by default and says so; a segmenter answering a zoomed square with another size is named.
  FramingSettings st;
  st.segment = Segmentation::kNet;
  st.segmenter = coarse_redness;
  const FramedInput f = frame_input(photo, nullptr, st, "photo.png");
  CHECK(f.segmenter_zooms == 2);
  CHECK(leg_found(f.mask) >= 12);
  st.segmenter = [](const Image& rgb) {
    return rgb.width == 320 ? coarse_redness(rgb) : Image(rgb.width + 1, rgb.height, 1, 0.9f);
  };
  try {
    (void)frame_input(photo, nullptr, st, "photo.png");
    FAIL("no error");
  } catch (const InvalidInput& e) {
    CHECK(std::string(e.what()).find("photo.png: the segmenter answered with a map of another size") != std::string::npos);
  }
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
  // --seg-zoom: rounds of the segmenter, refused where no segmenter reads the image, and bounded.
  const std::string base = "recon " + (dir / "photo.png").string() + " -o " + (dir / "out.obj").string();
  const test::CliRun zoom_grabcut = test::run_sdfkit(base + " --segment grabcut --seg-zoom 1");
  CHECK(zoom_grabcut.code != 0);
  CHECK(zoom_grabcut.err.find("--seg-zoom applies with --segment net or auto") != std::string::npos);
  const test::CliRun zoom_far = test::run_sdfkit(base + " --seg-zoom 5");
  CHECK(zoom_far.code != 0);
  CHECK(zoom_far.err.find("--seg-zoom") != std::string::npos);
  // --seg-agreement: GrabCut refining the network's mask, so --segment auto only; an IoU in [0, 1].
  const test::CliRun agree_net = test::run_sdfkit(base + " --segment net --seg-agreement 0.5");
  CHECK(agree_net.code == 1);
  CHECK(agree_net.err.find("--seg-agreement applies with --segment auto") != std::string::npos);
  const test::CliRun agree_far = test::run_sdfkit(base + " --seg-agreement 1.5");
  CHECK(agree_far.code != 0);
  CHECK(agree_far.err.find("--seg-agreement") != std::string::npos);
  // --seg-sure: the same; P,F within their ranges or none.
  const test::CliRun sure_net = test::run_sdfkit(base + " --segment net --seg-sure 0.9,0.05");
  CHECK(sure_net.code == 1);
  CHECK(sure_net.err.find("--seg-sure applies with --segment auto") != std::string::npos);
  for (const char* bad : {"0.4,0.05", "0.9", "0.9,0", "0.9;0.05", "0.9,0.05,1", "none,0.05"}) {
    const test::CliRun r = test::run_sdfkit(base + " --seg-sure '" + bad + "'");
    CHECK_MESSAGE(r.code == 1, bad);
    CHECK_MESSAGE(r.err.find("--seg-sure '" + std::string(bad) + "': give P,F") != std::string::npos, r.err);
  }
}

namespace {

/// A 320 x 224 grey photo with a small red square (the object: 20 x 20 px at 150-169, 40-59) and a large blue
/// region (the salient part of the photo: 0-79, 150-223).
Image small_object_photo() {
  Image img(320, 224, 3, 0.5f);
  for (int y = 40; y < 60; ++y)
    for (int x = 150; x < 170; ++x) img.at(x, y, 0) = 0.9f, img.at(x, y, 1) = img.at(x, y, 2) = 0.1f;
  for (int y = 150; y < 224; ++y)
    for (int x = 0; x < 80; ++x) img.at(x, y, 0) = img.at(x, y, 1) = 0.1f, img.at(x, y, 2) = 0.9f;
  return img;
}

/// A stand-in for a network whose resolution loses small objects: it answers the red pixels when they cover at
/// least 1% of what it reads, else the blue ones (every reading finds "an object", as the trained network does).
Image red_unless_small(const Image& rgb) {
  long red = 0;
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) red += rgb.at(x, y, 0) > 0.8f;
  const bool see_red = red >= 0.01 * rgb.width * rgb.height;
  Image p(rgb.width, rgb.height, 1, 0.05f);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x)
      if (see_red ? rgb.at(x, y, 0) > 0.8f : rgb.at(x, y, 2) > 0.8f) p.at(x, y) = 0.95f;
  return p;
}

}  // namespace

TEST_CASE("recon framing: the segmenter's window scan finds a small object the whole image's reading misses") {
  const Image photo = small_object_photo();
  const auto on_red = [](const Image& p) {  // the mask's IoU with the red square
    long inter = 0, uni = 0;
    for (int y = 0; y < 224; ++y)
      for (int x = 0; x < 320; ++x) {
        const bool a = p.at(x, y) > 0.5f, b = x >= 150 && x < 170 && y >= 40 && y < 60;
        inter += a && b;
        uni += a || b;
      }
    return static_cast<double>(inter) / static_cast<double>(uni);
  };
  // The whole image: the red square is 0.56% of it, so the blue region is taken; zooming in on the blue region
  // keeps it.
  int zooms = -1;
  SegmenterScan scan;
  const Image whole = zoomed_foreground(red_unless_small, photo, 2, 0.7, "photo.png", &zooms, false, &scan);
  CHECK(on_red(whole) == 0.0);
  CHECK(whole.at(40, 200) > 0.5f);
  CHECK(scan.candidates == 0);
  // The scan: windows of 192 px (3 x 2 of them), every one of which shows the red square at 1.1% and finds it;
  // those six answers agree, the whole image's blue answer agrees with none: the chosen window's mean IoU with the
  // other six candidates is 5/6.
  const Image scanned = zoomed_foreground(red_unless_small, photo, 2, 0.7, "photo.png", &zooms, true, &scan);
  CHECK(scan.candidates == 7);
  CHECK(scan.chosen == 1);  // the first window; the others tie with it
  CHECK(scan.agreement == doctest::Approx(5.0 / 6.0));
  CHECK(on_red(scanned) == doctest::Approx(1.0));
  CHECK(zooms >= 1);
  // No zoom rounds: no scan (the scan zooms in on each window's answer).
  CHECK(zoomed_foreground(red_unless_small, photo, 0, 0.7, "photo.png", &zooms, true, &scan).data ==
        red_unless_small(photo).data);
  CHECK(scan.candidates == 0);
  // An answer covering the whole image is kept as it is (frame_input refuses it), not replaced by a window's.
  const auto everything = [](const Image& rgb) { return Image(rgb.width, rgb.height, 1, 0.95f); };
  CHECK(zoomed_foreground(everything, photo, 2, 0.7, "photo.png", &zooms, true, &scan).data ==
        everything(photo).data);
  CHECK(scan.candidates == 0);
  // frame_input scans by default and reports it; segmenter_scan = false keeps the whole image's reading.
  FramingSettings st;
  st.segment = Segmentation::kNet;
  st.segmenter = red_unless_small;
  const FramedInput f = frame_input(photo, nullptr, st, "photo.png");
  CHECK(f.segmenter_scan.candidates == 7);
  CHECK(on_red(f.mask) == doctest::Approx(1.0));
  st.segmenter_scan = false;
  const FramedInput g = frame_input(photo, nullptr, st, "photo.png");
  CHECK(g.segmenter_scan.candidates == 0);
  CHECK(on_red(g.mask) == 0.0);
}

TEST_CASE("recon framing: a batch reader gets each round of the window scan in one call, with the same answer") {
  const Image photo = small_object_photo();
  int zooms = -1, zooms_batched = -1;
  SegmenterScan scan, scan_batched;
  const Image one_by_one = zoomed_foreground(red_unless_small, photo, 2, 0.7, "photo.png", &zooms, true, &scan);
  std::vector<size_t> calls;  // images per batch call
  int single_calls = 0;
  const auto single = [&](const Image& rgb) {
    ++single_calls;
    return red_unless_small(rgb);
  };
  const auto batch = [&](const std::vector<Image>& rgbs) {
    calls.push_back(rgbs.size());
    std::vector<Image> out;
    for (const Image& im : rgbs) out.push_back(red_unless_small(im));
    return out;
  };
  const Image batched =
      zoomed_foreground(single, photo, 2, 0.7, "photo.png", &zooms_batched, true, &scan_batched, batch);
  CHECK(batched.data == one_by_one.data);
  CHECK(zooms_batched == zooms);
  CHECK(scan_batched.chosen == scan.chosen);
  CHECK(scan_batched.agreement == scan.agreement);
  // The whole image and its six windows read together, then each zoom round's squares together (a round whose
  // only square is left goes to the single reader).
  REQUIRE_FALSE(calls.empty());
  CHECK(calls[0] == 7);
  CHECK(calls.size() <= 3);
  size_t read = single_calls;
  for (const size_t c : calls) read += c;
  CHECK(read <= 21);
  // Without the scan, one image at a time through the single reader.
  calls.clear();
  single_calls = 0;
  (void)zoomed_foreground(single, photo, 2, 0.7, "photo.png", &zooms, false, nullptr, batch);
  CHECK(calls.empty());
  CHECK(single_calls == 1 + zooms);
  // A batch reader answering for another number of images is an error naming the input.
  const auto short_batch = [](const std::vector<Image>& rgbs) {
    return std::vector<Image>(rgbs.size() - 1, Image(1, 1, 1, 0.0f));
  };
  CHECK_THROWS_WITH_AS(zoomed_foreground(single, photo, 2, 0.7, "photo.png", nullptr, true, nullptr, short_batch),
                       "photo.png: the segmenter answered for another number of images", InvalidInput);
}
