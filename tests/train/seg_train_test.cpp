#include "train/seg_train.h"

#include "camera/camera.h"
#include "camera/image.h"
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "nets/checkpoint.h"
#include "scratch.h"
#include "train/seg_data.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <set>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const float kObject[3] = {0.8f, 0.2f, 0.3f};

/// A 137 px RGBA render: an opaque single-colour rectangle (or disc) with an anti-aliased border, alpha 0 elsewhere.
Image make_render(int shape, int view) {
  Image img(137, 137, 4, 0.f);
  const double cx = 60 + 10 * view, cy = 70 - 5 * shape, rx = 30 + 8 * shape, ry = 22 + 6 * view;
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x) {
      // Coverage by 4 x 4 sub-samples: anti-aliased edges as a renderer's.
      int in = 0;
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
          const double px = x + (i + 0.5) / 4 - cx, py = y + (j + 0.5) / 4 - cy;
          in += shape % 2 == 0 ? (std::abs(px) < rx && std::abs(py) < ry) : (px * px / (rx * rx) + py * py / (ry * ry) < 1);
        }
      const float a = in / 16.0f;
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = a > 0 ? kObject[c] : 0.f;
      img.at(x, y, 3) = a;
    }
  return img;
}

/// Two shapes x 2 views of make_render (samples.npy only so that the dataset reader accepts the folders).
fs::path make_seg_dataset(const std::string& tag) {
  const fs::path root = test::scratch_dir(tag);
  int s = 0;
  for (const std::string id : {"box/a", "disc/b"}) {
    MatrixXfR samples(8, 4);
    samples.setZero();
    write_npy((root / id / "samples.npy").string(), samples);
    for (int v = 0; v < 2; ++v) {
      const std::string nn = "0" + std::to_string(v);
      write_camera((root / id / "views" / (nn + ".json")).string(), look_at(40.0 * v, 27, 2.7));
      write_image((root / id / "views" / (nn + ".png")).string(), make_render(s, v));
    }
    ++s;
  }
  write_text_atomic((root / "train.lst").string(), "box/a\ndisc/b\n");
  // Two background photos: a colour ramp and a noise image.
  Image ramp(90, 60, 3), noise(50, 70, 3);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 90; ++x) ramp.at(x, y, 0) = x / 90.f, ramp.at(x, y, 1) = y / 60.f, ramp.at(x, y, 2) = 0.5f;
  Rng rng(3);
  for (float& v : noise.data) v = static_cast<float>(rng.uniform());
  write_image((root / "bg" / "ramp.png").string(), ramp);
  write_image((root / "bg" / "sub" / "noise.jpg").string(), noise);
  return root;
}

SegTrainSettings tiny_run(const fs::path& root, const std::string& out) {
  SegTrainSettings s;
  s.data = root.string();
  s.backgrounds = (root / "bg").string();
  s.val_split = "";
  s.out = (root / out).string();
  s.net.size = 32;
  s.net.encoder = {4, 8};
  s.net.extra_convs = 1;
  s.net.decoder = {8};
  s.batch = 3;
  s.steps = 6;
  s.val_every = 3;
  s.val_items = 4;
  s.lr = s.lr_min = 3e-3;
  s.seed = 5;
  return s;
}

}  // namespace

TEST_CASE("SegData: composites are seeded, the label is the object's coverage, whatever the background") {
  const fs::path root = make_seg_dataset("seg_data");
  const BackgroundSet photos((root / "bg").string());
  REQUIRE(photos.size() == 2);
  CHECK(fs::path(photos.path(0)).filename() == "ramp.png");  // sorted, sub-folders searched
  for (size_t i = 0; i < 2; ++i) CHECK(std::max(photos.image(i).width, photos.image(i).height) <= 256);

  SegCompositeSettings flat;
  flat.size = 64;
  flat.procedural = 1;
  flat.kinds = {ProceduralBackground::kFlat};
  flat.procedural_noise = 0;
  flat.object_jitter = 0;
  SegCompositeSettings mixed;
  mixed.size = 64;
  mixed.procedural = 0.5;
  int photo_count = 0;
  for (uint64_t stream = 0; stream < 24; ++stream) {
    const Image render = make_render(static_cast<int>(stream % 2), static_cast<int>(stream / 2 % 2));
    const SegSample a = make_composite(render, nullptr, flat, 7, stream);
    const SegSample again = make_composite(render, nullptr, flat, 7, stream);
    CHECK(a.image.data == again.image.data);
    CHECK(a.label.data == again.label.data);
    CHECK(make_composite(render, nullptr, flat, 8, stream).image.data != a.image.data);
    // The same canvas, object place and size with photo or other procedural backgrounds: the label is the same.
    const SegSample b = make_composite(render, &photos, mixed, 7, stream);
    CHECK(b.label.data == a.label.data);
    photo_count += b.background.rfind("photo:", 0) == 0 ? 1 : 0;
    CHECK(a.image.width == 64);
    CHECK(a.label.channels == 1);
    const int x0 = a.canvas_x0, y0 = a.canvas_y0, w = a.canvas_width, h = a.canvas_height;
    CHECK(std::max(w, h) == 64);
    CHECK(static_cast<double>(std::max(w, h)) / std::min(w, h) <= 16.0 / 9.0 + 0.05);
    // On a flat background without jitter every canvas pixel is label x object + (1 - label) x background.
    float bg[3] = {-1, -1, -1};
    int bx0 = 64, by0 = 64, bx1 = -1, by1 = -1;
    for (int y = y0; y < y0 + h; ++y)
      for (int x = x0; x < x0 + w; ++x)
        if (a.label.at(x, y) == 0 && bg[0] < 0)
          for (int c = 0; c < 3; ++c) bg[c] = a.image.at(x, y, c);
    REQUIRE(bg[0] >= 0);
    double worst = 0;
    for (int y = y0; y < y0 + h; ++y)
      for (int x = x0; x < x0 + w; ++x) {
        const float l = a.label.at(x, y);
        CHECK((l >= 0 && l <= 1));
        if (l > 0.5f) bx0 = std::min(bx0, x), by0 = std::min(by0, y), bx1 = std::max(bx1, x), by1 = std::max(by1, y);
        for (int c = 0; c < 3; ++c)
          worst = std::max(worst, std::abs(static_cast<double>(a.image.at(x, y, c)) - (l * kObject[c] + (1 - l) * bg[c])));
      }
    CHECK(worst < 1e-5);
    // The object's box spans 0.2-0.95 of the canvas's longer side (up to a pixel and what leaves the canvas).
    REQUIRE(bx1 >= bx0);
    const double extent = std::max(bx1 - bx0 + 1, by1 - by0 + 1) / 64.0;
    CHECK(extent <= 0.95 + 2.0 / 64);
    CHECK(extent >= 0.2 * 0.9 - 2.0 / 64);
    // The letterbox's padding repeats the canvas's edge pixels.
    for (int x = 0; x < 64; ++x) {
      CHECK(a.label.at(x, 0) == a.label.at(std::clamp(x, x0, x0 + w - 1), y0));
      CHECK(a.image.at(x, 63, 1) == a.image.at(std::clamp(x, x0, x0 + w - 1), y0 + h - 1, 1));
    }
  }
  CHECK(photo_count > 3);
  CHECK(photo_count < 21);
  CHECK_THROWS_AS(BackgroundSet((root / "nothing").string()), IoError);
  write_text_atomic((root / "bgs.lst").string(), "# two\nbg/ramp.png\n\nbg/missing.png\n");
  CHECK_THROWS_AS(BackgroundSet((root / "bgs.lst").string()), IoError);
}

TEST_CASE("SegData: clutter changes the background only, and draws edges on a flat one") {
  const fs::path root = make_seg_dataset("seg_clutter");
  const BackgroundSet photos((root / "bg").string());
  SegCompositeSettings flat;
  flat.size = 64;
  flat.procedural = 1;
  flat.kinds = {ProceduralBackground::kFlat};
  flat.procedural_noise = 0;
  SegCompositeSettings busy = flat;
  busy.clutter = 1;
  SegCompositeSettings textured = busy;
  textured.procedural = 0;
  SegCompositeSettings bad = busy;
  bad.clutter = 1.5;
  CHECK_THROWS_AS(bad.validate(), InvalidInput);
  bad = busy;
  bad.clutter_shapes = 0;
  CHECK_THROWS_AS(bad.validate(), InvalidInput);
  int changed_images = 0;
  for (uint64_t stream = 0; stream < 16; ++stream) {
    const Image render = make_render(static_cast<int>(stream % 2), 0);
    const SegSample a = make_composite(render, nullptr, flat, 3, stream);
    const SegSample b = make_composite(render, nullptr, busy, 3, stream);
    const SegSample c = make_composite(render, &photos, textured, 3, stream);
    CHECK(b.background == "flat+clutter");
    CHECK(c.background.find("+clutter") != std::string::npos);
    CHECK(b.image.data == make_composite(render, nullptr, busy, 3, stream).image.data);  // seeded
    // The clutter is drawn after every choice of the object: same label, same object pixels.
    CHECK(b.label.data == a.label.data);
    CHECK(c.label.data == a.label.data);
    int differ = 0, object_differ = 0;
    std::set<std::array<int, 3>> colours;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const float l = a.label.at(x, y);
        bool d = false;
        std::array<int, 3> q{};
        for (int ch = 0; ch < 3; ++ch) {
          d = d || std::abs(a.image.at(x, y, ch) - b.image.at(x, y, ch)) > 1e-6f;
          q[static_cast<size_t>(ch)] = static_cast<int>(std::lround(b.image.at(x, y, ch) * 255));
        }
        if (l >= 1.0f) object_differ += d ? 1 : 0;
        if (l == 0.0f) {
          differ += d ? 1 : 0;
          colours.insert(q);
        }
      }
    CHECK(object_differ == 0);
    changed_images += differ > 0 ? 1 : 0;
    // A flat background holds one colour; the clutter's shaded shapes many.
    if (differ > 20) CHECK(colours.size() > 3);
  }
  CHECK(changed_images >= 12);  // a shape may fall behind the object or cover little; most composites change
}

TEST_CASE("SegData: cut-outs are pasted behind the object, premultiplied, and change nothing when off") {
  const fs::path root = make_seg_dataset("seg_cutouts");
  // One cut-out: a 40 x 20 image, transparent but for an opaque red 20 x 10 block in its middle.
  Image cut(40, 20, 4, 0.0f);
  for (int y = 5; y < 15; ++y)
    for (int x = 10; x < 30; ++x) cut.at(x, y, 0) = 1, cut.at(x, y, 3) = 1;
  for (int y = 0; y < 20; ++y) cut.at(0, y, 1) = 0.8f;  // colour under zero alpha: premultiplied away
  write_image((root / "cut" / "block.png").string(), cut);
  const BackgroundSet cutouts((root / "cut").string(), 256, true);
  REQUIRE(cutouts.size() == 1);
  CHECK(cutouts.image(0).channels == 4);
  CHECK(cutouts.image(0).at(0, 3, 1) == 0.0f);
  CHECK(cutouts.image(0).at(15, 10, 0) == 1.0f);
  CHECK(BackgroundSet((root / "cut").string()).image(0).channels == 3);

  SegCompositeSettings flat;
  flat.size = 64;
  flat.procedural = 1;
  flat.kinds = {ProceduralBackground::kFlat};
  flat.procedural_noise = 0;
  SegCompositeSettings with = flat;
  with.cutouts = 1;
  SegCompositeSettings bad = with;
  bad.cutout_min = 0;
  CHECK_THROWS_AS(bad.validate(), InvalidInput);
  CHECK(!flat.to_json().contains("cutouts"));
  CHECK(with.to_json().at("cutouts").at("prob").get<double>() == 1.0);
  int red_behind = 0, changed = 0;
  for (uint64_t stream = 0; stream < 12; ++stream) {
    const Image render = make_render(static_cast<int>(stream % 2), 0);
    const SegSample a = make_composite(render, nullptr, flat, 3, stream);
    // Off (or without a set), the composite is the one made before cut-outs existed.
    CHECK(make_composite(render, nullptr, flat, 3, stream, &cutouts).image.data == a.image.data);
    CHECK(make_composite(render, nullptr, with, 3, stream).image.data == a.image.data);
    const SegSample b = make_composite(render, nullptr, with, 3, stream, &cutouts);
    CHECK(b.background == "flat+cutouts");
    CHECK(b.label.data == a.label.data);  // drawn after the object's choices, behind it
    changed += b.image.data != a.image.data ? 1 : 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        if (a.label.at(x, y) > 0) {  // the object's pixels stay the object's where it is opaque
          if (a.label.at(x, y) == 1)
            for (int c = 0; c < 3; ++c) CHECK(b.image.at(x, y, c) == doctest::Approx(a.image.at(x, y, c)).epsilon(1e-5));
          continue;
        }
        // The background changed only towards the cut-out's red: R up or kept, G and B down or kept.
        CHECK(b.image.at(x, y, 1) <= a.image.at(x, y, 1) + 1e-5f);
        CHECK(b.image.at(x, y, 2) <= a.image.at(x, y, 2) + 1e-5f);
        red_behind += b.image.at(x, y, 1) < a.image.at(x, y, 1) - 0.1f ? 1 : 0;
      }
  }
  CHECK(red_behind > 100);
  CHECK(changed >= 10);  // a cut-out may fall behind the object or mostly off the canvas
}

TEST_CASE("SegTrain: a few dozen steps on a tiny dataset lower the loss, and validation IoU is measured") {
  const fs::path root = make_seg_dataset("seg_train_loss");
  SegTrainSettings s = tiny_run(root, "seg.ckpt");
  s.steps = 40;
  s.batch = 4;
  s.val_every = 40;
  s.composite.kinds = {ProceduralBackground::kFlat, ProceduralBackground::kGradient};
  std::vector<double> losses;
  const SegTrainResult r = train_seg(s, [&](const SegTrainEvent& e) { losses.push_back(e.loss); });
  REQUIRE(losses.size() == 40);
  double first = 0, last = 0;
  for (int i = 0; i < 8; ++i) first += losses[static_cast<size_t>(i)] / 8, last += losses[losses.size() - 1 - i] / 8;
  INFO("first steps ", first, " last steps ", last);
  CHECK(last < 0.75 * first);
  CHECK(r.val.items == 4);
  CHECK((r.val.iou >= 0 && r.val.iou <= 1));
  CHECK(r.train_items == 4);
  CHECK(r.backgrounds == 2);
  CHECK(read_file(r.csv).rfind("step,train_loss,val_loss,val_iou,lr,seconds\n", 0) == 0);
  CHECK(fs::exists(r.plot));
  CHECK(r.csv == (root / "seg.loss.csv").string());
  // The model file loads and segments an image of any size.
  auto net = load_seg_model(r.model);
  const Image p = predict_foreground(*net, make_render(0, 0));
  CHECK(p.width == 137);
}

TEST_CASE("SegTrain: a resumed run gives the bytes of an uninterrupted one, for 1 and 2 threads") {
  const fs::path root = make_seg_dataset("seg_train_resume");
  std::vector<std::vector<float>> params;
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    SegTrainSettings s = tiny_run(root, "straight" + std::to_string(threads) + ".ckpt");
    train_seg(s);
    params.push_back(load_checkpoint(s.out).block("params"));
  }
  CHECK(params[0] == params[1]);
  // Stopped by the time limit after its first step, then resumed to the end.
  SegTrainSettings s = tiny_run(root, "split.ckpt");
  s.time_limit_seconds = 1e-9;
  const SegTrainResult first = train_seg(s);
  CHECK(first.steps == 1);
  s.time_limit_seconds = 0;
  s.resume = true;
  const SegTrainResult second = train_seg(s);
  CHECK(second.start_step == 1);
  CHECK(second.steps == 6);
  CHECK(load_checkpoint(s.out).block("params") == params[0]);
  const Checkpoint a = load_checkpoint((root / "straight1.ckpt.train.ckpt").string());
  const Checkpoint b = load_checkpoint((root / "split.ckpt.train.ckpt").string());
  CHECK(a.block("params") == b.block("params"));
  CHECK(a.header.at("optimizer") == b.header.at("optimizer"));
  // A resume with other settings is refused, naming the state file.
  s.iou_weight = 0;
  s.steps = 7;
  try {
    train_seg(s);
    CHECK(false);
  } catch (const InvalidInput& e) {
    CHECK(std::string(e.what()).find("split.ckpt.train.ckpt") != std::string::npos);
  }
}

TEST_CASE("SegTrain: the thin-part weight changes the training, is recorded only when on, and must match to resume") {
  const fs::path root = make_seg_dataset("seg_train_thin");
  SegTrainSettings plain = tiny_run(root, "plain.ckpt");
  train_seg(plain);
  SegTrainSettings thin = tiny_run(root, "thin.ckpt");
  thin.thin_weight = 4;
  thin.thin_radius = 2;
  train_seg(thin);
  SegTrainSettings again = thin;
  again.out = (root / "thin2.ckpt").string();
  train_seg(again);
  const auto plain_params = load_checkpoint(plain.out).block("params");
  const auto thin_params = load_checkpoint(thin.out).block("params");
  CHECK(thin_params != plain_params);
  CHECK(load_checkpoint(again.out).block("params") == thin_params);
  // The resumable state records the setting only when it is on (states written before it existed still resume).
  const Json plain_settings = load_checkpoint(plain.out + ".train.ckpt").header.at("settings");
  const Json thin_settings = load_checkpoint(thin.out + ".train.ckpt").header.at("settings");
  CHECK(!plain_settings.contains("thin_weight"));
  CHECK(thin_settings.at("thin_weight").get<double>() == 4.0);
  CHECK(thin_settings.at("thin_radius").get<int>() == 2);
  // Resuming with another weight is refused; out-of-range settings too.
  thin.resume = true;
  thin.steps = 8;
  thin.thin_weight = 2;
  CHECK_THROWS_AS(train_seg(thin), InvalidInput);
  SegTrainSettings bad = tiny_run(root, "bad.ckpt");
  bad.thin_weight = 0.5;
  CHECK_THROWS_AS(train_seg(bad), InvalidInput);
  bad.thin_weight = 2;
  bad.thin_radius = 0;
  CHECK_THROWS_AS(train_seg(bad), InvalidInput);
  CHECK(!fs::exists(bad.out));
}

TEST_CASE("SegTrain: validation backgrounds change the validation composites only, and are recorded") {
  const fs::path root = make_seg_dataset("seg_train_valbg");
  SegTrainSettings plain = tiny_run(root, "plain.ckpt");
  plain.composite.procedural = 0;  // every composite on a photo, so the validation set's photos matter
  const SegTrainResult a = train_seg(plain);
  SegTrainSettings held = plain;
  held.out = (root / "held.ckpt").string();
  held.val_backgrounds = (root / "bg" / "sub").string();  // the noise photo alone
  const SegTrainResult b = train_seg(held);
  CHECK(a.val_backgrounds == 0);
  CHECK(b.val_backgrounds == 1);
  CHECK(b.backgrounds == 2);
  // The same training bytes, other validation composites (so another validation loss).
  CHECK(load_checkpoint(held.out).block("params") == load_checkpoint(plain.out).block("params"));
  CHECK(b.val.loss != a.val.loss);
  CHECK(load_checkpoint(held.out).header.at("training").at("val_backgrounds").get<std::string>() ==
        held.val_backgrounds);
  CHECK(!load_checkpoint(plain.out).header.at("training").contains("val_backgrounds"));
  // A missing folder is an error naming it, before any training.
  SegTrainSettings bad = tiny_run(root, "bad.ckpt");
  bad.val_backgrounds = (root / "no_such_folder").string();
  try {
    train_seg(bad);
    CHECK(false);
  } catch (const std::exception& e) {
    CHECK(std::string(e.what()).find("no_such_folder") != std::string::npos);
  }
  CHECK(!fs::exists(bad.out));
}

TEST_CASE("SegTrain: cut-outs change the training and are recorded, and need both the set and a probability") {
  const fs::path root = make_seg_dataset("seg_train_cutouts");
  Image cut(30, 30, 4, 0.0f);
  for (int y = 5; y < 25; ++y)
    for (int x = 8; x < 22; ++x) cut.at(x, y, 2) = 0.9f, cut.at(x, y, 3) = 1;
  write_image((root / "cut" / "a.png").string(), cut);
  SegTrainSettings plain = tiny_run(root, "plain.ckpt");
  const SegTrainResult a = train_seg(plain);
  SegTrainSettings with = tiny_run(root, "with.ckpt");
  with.cutouts = (root / "cut").string();
  with.composite.cutouts = 1;
  const SegTrainResult b = train_seg(with);
  CHECK(a.cutouts == 0);
  CHECK(b.cutouts == 1);
  CHECK(load_checkpoint(with.out).block("params") != load_checkpoint(plain.out).block("params"));
  const Json rec = load_checkpoint(with.out + ".train.ckpt").header.at("settings");
  CHECK(rec.at("cutout_files").get<long>() == 1);
  CHECK(!load_checkpoint(plain.out + ".train.ckpt").header.at("settings").contains("cutouts"));
  SegTrainSettings bad = tiny_run(root, "bad.ckpt");
  bad.composite.cutouts = 0.5;
  CHECK_THROWS_AS(train_seg(bad), InvalidInput);
  bad.composite.cutouts = 0;
  bad.cutouts = with.cutouts;
  CHECK_THROWS_AS(train_seg(bad), InvalidInput);
  CHECK(!fs::exists(bad.out));
}

TEST_CASE("SegTrain: --init adds the fine branch to a trained coarse model, and refuses other architectures") {
  const fs::path root = make_seg_dataset("seg_train_fine");
  SegTrainSettings coarse = tiny_run(root, "coarse.ckpt");
  train_seg(coarse);
  const auto start = load_seg_model(coarse.out);
  SegTrainSettings s = tiny_run(root, "fine.ckpt");
  s.net.fine = 4;
  s.init = coarse.out;
  s.steps = 1;
  s.lr = s.lr_min = 1e-12;  // one step that barely moves: the result is the starting point
  const SegTrainResult r = train_seg(s);
  const auto fine = load_seg_model(r.model);
  CHECK(fine->config().fine == 4);
  REQUIRE(fine->n_params() > start->n_params());
  for (size_t i = 0; i < start->n_params(); ++i)
    CHECK(fine->params().values[i] == doctest::Approx(start->params().values[i]).epsilon(1e-6));
  // The projection of the fine map starts at zero (the last fine x decoder[0] parameters).
  for (size_t i = fine->n_params() - 4 * 8; i < fine->n_params(); ++i) CHECK(std::abs(fine->params().values[i]) < 1e-9);
  // Trained further, the fine model segments like any other, at the input's size.
  s.steps = 6;
  s.lr = s.lr_min = 3e-3;
  s.out = (root / "fine2.ckpt").string();
  const Image p = predict_foreground(*load_seg_model(train_seg(s).model), make_render(0, 0));
  CHECK(p.width == 137);
  // A model with other settings than the fine branch's, or a fine model into a coarse one, is refused.
  SegTrainSettings wide = tiny_run(root, "wide.ckpt");
  wide.net.decoder = {6};
  wide.net.fine = 4;
  wide.init = coarse.out;
  CHECK_THROWS_AS(train_seg(wide), InvalidInput);
  SegTrainSettings back = tiny_run(root, "back.ckpt");
  back.init = r.model;
  CHECK_THROWS_AS(train_seg(back), InvalidInput);
}

TEST_CASE("SegTrain CLI: help, and bad inputs fail with one line naming the file") {
  const fs::path root = make_seg_dataset("seg_train_cli");
  const test::CliRun help = test::run_sdfkit("train seg --help");
  CHECK(help.code == 0);
  CHECK(help.out.find("--backgrounds") != std::string::npos);
  const std::string missing = (root / "no_such_bg").string();
  const test::CliRun bad = test::run_sdfkit("train seg --data " + root.string() + " --backgrounds " + missing +
                                            " -o " + (root / "m.ckpt").string() + " --val-split \"\" --steps 1");
  CHECK(bad.code == 1);
  CHECK(bad.err.find(missing) != std::string::npos);
  CHECK(std::count(bad.err.begin(), bad.err.end(), '\n') == 1);
  const test::CliRun ok = test::run_sdfkit("train seg --data " + root.string() + " --backgrounds " +
                                           (root / "bg").string() + " -o " + (root / "m.ckpt").string() +
                                           " --val-split \"\" --steps 2 --batch 2 --size 32 --encoder 4,8 --decoder 8 "
                                           "--val-items 2 --clutter 0.5 --clutter-shapes 5 --json");
  CHECK(ok.code == 0);
  const Json j = Json::parse(ok.out);
  CHECK(j.at("steps").get<long>() == 2);
  CHECK(fs::exists(root / "m.ckpt"));
  // --thin-radius alone does not apply; with --thin-weight the run trains.
  const std::string base = "train seg --data " + root.string() + " --backgrounds " + (root / "bg").string() +
                           " --val-split \"\" --steps 1 --batch 2 --size 32 --encoder 4,8 --decoder 8 --val-items 2 ";
  const test::CliRun lone = test::run_sdfkit(base + "--thin-radius 2 -o " + (root / "t.ckpt").string());
  CHECK(lone.code == 1);
  CHECK(lone.err.find("--thin-radius applies with --thin-weight") != std::string::npos);
  CHECK(!fs::exists(root / "t.ckpt"));
  const test::CliRun weighted =
      test::run_sdfkit(base + "--thin-weight 4 --thin-radius 2 -o " + (root / "t.ckpt").string());
  CHECK(weighted.code == 0);
  CHECK(fs::exists(root / "t.ckpt"));
  for (const char* flag : {"--clutter 1.5", "--clutter -0.1", "--clutter-shapes 0", "--thin-weight 0.5",
                           "--thin-radius 9"}) {
    const test::CliRun r = test::run_sdfkit("train seg --data " + root.string() + " -o " + (root / "c.ckpt").string() +
                                            " --steps 1 " + flag);
    CHECK(r.code != 0);
    // The parse error names the flag (CLI11 adds its "Run with --help" hint on a second line).
    CHECK(r.err.rfind(std::string(flag).substr(0, std::string(flag).find(' ')) + ":", 0) == 0);
    CHECK(!fs::exists(root / "c.ckpt"));
  }
}
