#include "core/json.h"
#include "train/pose_train.h"

#include "camera/camera.h"
#include "camera/image.h"
#include "cli_run.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "nets/checkpoint.h"

#include <doctest/doctest.h>
#include <tbb/task_arena.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// Two shapes x 2 views: white renders of a coloured square whose position depends on the view, exact cameras.
fs::path make_pose_dataset() {
  const fs::path root = test::scratch_dir("pose_train");
  fs::remove_all(root);
  int s = 0;
  for (const std::string id : {"car/a", "lamp/b"}) {
    MatrixXfR samples(64, 4);
    Rng rng(s + 1);
    for (int r = 0; r < 64; ++r)
      samples.row(r) << float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)),
          0.f;
    write_npy((root / id / "samples.npy").string(), samples);
    for (int v = 0; v < 2; ++v) {
      const std::string nn = "0" + std::to_string(v);
      write_camera((root / id / "views" / (nn + ".json")).string(), look_at(90.0 * v + 40 * s, 27, 2.7));
      Image img(137, 137, 4, 0.f);
      for (int y = 50 + 10 * v; y < 80; ++y)
        for (int x = 40 + 20 * s; x < 90; ++x) {
          img.at(x, y, 0) = 0.2f + 0.3f * s;
          img.at(x, y, 1) = 0.6f;
          img.at(x, y, 2) = 0.3f;
          img.at(x, y, 3) = 1.f;
        }
      write_image((root / id / "views" / (nn + ".png")).string(), img);
    }
    ++s;
  }
  write_text_atomic((root / "train.lst").string(), "car/a\nlamp/b\n");
  return root;
}

PoseTrainSettings tiny_settings(const fs::path& root, const std::string& out) {
  PoseTrainSettings s;
  s.data = root.string();
  s.train_split = "train";
  s.val_split = "";
  s.out = out;
  s.net.width = 2;
  s.net.feature = 16;
  s.steps = 3;
  s.batch = 2;
  s.points = 16;
  s.val_every = 3;
  s.val_items = 2;
  s.seed = 4;
  return s;
}

std::vector<float> model_params(const std::string& path) {
  auto net = load_pose_model(path);
  return {net->params().values.begin(), net->params().values.end()};
}

}  // namespace

TEST_CASE("train pose with augmentation: seeded, recorded in the model header, changes the training") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "plain.ckpt").string());
  const PoseTrainResult plain = train_pose(s);
  // The curve is named as train sdf names its own: MODEL_STEM.loss.csv / .loss.svg.
  CHECK(plain.csv == (root / "plain.loss.csv").string());
  CHECK(plain.plot == (root / "plain.loss.svg").string());
  CHECK(read_file(plain.csv).rfind("step,train_loss,val_loss,val_d3d,val_d2d,lr,seconds\n", 0) == 0);
  CHECK(fs::exists(plain.plot));
  s.augment.colour = 0.5;
  s.augment.channel_swap = 0.5;
  s.augment.noise = 0.02;
  s.out = (root / "aug1.ckpt").string();
  train_pose(s);
  s.out = (root / "aug2.ckpt").string();
  train_pose(s);

  CHECK(model_params((root / "aug1.ckpt").string()) == model_params((root / "aug2.ckpt").string()));
  CHECK(model_params((root / "aug1.ckpt").string()) != model_params((root / "plain.ckpt").string()));
  Json training;
  load_pose_model((root / "aug1.ckpt").string(), &training);
  const Json aug = training.at("settings").at("augment");
  CHECK(aug.at("colour").get<double>() == 0.5);
  CHECK(aug.at("channel_swap").get<double>() == 0.5);
  CHECK(aug.at("noise").get<double>() == 0.02);

  // A resume with other augmentation settings is refused (it would not continue the same run).
  s.out = (root / "aug1.ckpt").string();
  s.resume = true;
  s.steps = 3;
  s.augment.noise = 0.05;
  CHECK_THROWS(train_pose(s));
  fs::remove_all(root);
}

TEST_CASE("train pose gives the same model for 1 and 2 threads, and the replicas' gradient is the batch gradient") {
  const fs::path root = make_pose_dataset();
  std::vector<std::vector<float>> params;
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    PoseTrainSettings s = tiny_settings(root, (root / ("threads" + std::to_string(threads) + ".ckpt")).string());
    s.batch = 3;
    train_pose(s);
    params.push_back(model_params(s.out));
  }
  CHECK(params[0] == params[1]);
  // One item per replica with weight 1/B, summed: the gradient of the mean loss over the batch.
  const PoseTrainSettings s = tiny_settings(root, "");
  DatasetSettings ds;
  ds.root = root.string();
  ds.split = "train";
  const Dataset data(ds);
  BatchSettings bs;
  bs.batch_size = 3;
  bs.points_per_shape = 16;
  const SdfBatch b = BatchSampler(data, bs).batch(0);
  std::vector<PointsF> pts;
  for (int k = 0; k < 3; ++k) pts.push_back(b.points.middleRows(16 * k, 16));
  PoseNet whole(s.net, true);
  whole.init(9);
  whole.params().zero_grad();
  const double loss = whole.forward_backward(b.images, pts, b.cameras);
  std::vector<double> summed(whole.n_params(), 0.0);
  double loss_sum = 0;
  for (int k = 0; k < 3; ++k) {
    PoseNet rep(s.net, true);
    rep.share_parameters(whole);
    rep.params().zero_grad();
    loss_sum += rep.forward_backward(b.images.middleRows(k, 1), {pts[k]}, {b.cameras[k]}, 1.0 / 3);
    for (size_t i = 0; i < summed.size(); ++i) summed[i] += rep.params().grads[i];
  }
  CHECK(loss_sum / 3 == doctest::Approx(loss).epsilon(1e-6));
  double num = 0, den = 0;
  for (size_t i = 0; i < summed.size(); ++i) {
    num += (summed[i] - whole.params().grads[i]) * (summed[i] - whole.params().grads[i]);
    den += double(whole.params().grads[i]) * whole.params().grads[i];
  }
  CHECK(den > 0);
  CHECK(std::sqrt(num / den) < 1e-5);
  fs::remove_all(root);
}

TEST_CASE("train pose: a shape listed twice is drawn twice as often, its symmetries found once") {
  const fs::path root = make_pose_dataset();
  write_text_atomic((root / "twice.lst").string(), "car/a\ncar/a\nlamp/b\n");
  Mat3 half;
  half << -1, 0, 0, 0, 1, 0, 0, 0, -1;
  std::atomic<int> car_calls{0}, lamp_calls{0};
  PoseTrainSettings s = tiny_settings(root, (root / "twice.ckpt").string());
  s.train_split = (root / "twice.lst").string();
  s.symmetry_tag = "test";
  s.symmetries = [&](const ShapeEntry& shape) {
    (shape.category == "car" ? car_calls : lamp_calls)++;
    return shape.category == "car" ? std::vector<Mat3>{half} : std::vector<Mat3>{};
  };
  const PoseTrainResult r = train_pose(s);
  CHECK(car_calls == 1);
  CHECK(lamp_calls == 1);
  CHECK(r.symmetric_shapes == 1);  // shapes, not entries
  // The repeated entry changes the draw: another model than the list without it.
  PoseTrainSettings once = s;
  once.train_split = "train";
  once.out = (root / "once.ckpt").string();
  train_pose(once);
  CHECK(model_params(s.out) != model_params(once.out));
  fs::remove_all(root);
}

TEST_CASE("train pose refuses impossible head settings before reading any data") {
  // The data folder does not exist: a check made after loading would report it (IoError) instead.
  PoseTrainSettings s = tiny_settings(test::scratch_dir("pose_no_data") / "missing", "unused.ckpt");
  s.azimuth_weight = 0.1;  // without a head
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  s.net.azimuth_bins = 2;  // too few bins
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  s.net.azimuth_bins = 8;
  s.azimuth_weight = -1;
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  s.azimuth_weight = 0.1;
  CHECK_THROWS_AS(train_pose(s), IoError);  // valid settings: now the missing data is what fails
}

TEST_CASE("train pose --init starts from a given model and refuses another architecture") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "start.ckpt").string());
  train_pose(s);
  const std::vector<float> start = model_params(s.out);

  // A vanishing learning rate from the init model leaves its parameters (Adam steps are ~lr in size).
  PoseTrainSettings f = tiny_settings(root, (root / "tuned.ckpt").string());
  f.init = (root / "start.ckpt").string();
  f.seed = 99;  // another seed: the random initialisation must not matter
  f.lr = f.lr_min = 1e-12;
  train_pose(f);
  const std::vector<float> tuned = model_params(f.out);
  REQUIRE(tuned.size() == start.size());
  double diff = 0;
  for (size_t i = 0; i < start.size(); ++i) diff = std::max(diff, double(std::abs(tuned[i] - start[i])));
  CHECK(diff < 1e-8);

  PoseTrainSettings w = tiny_settings(root, (root / "wide.ckpt").string());
  w.net.width = 3;
  w.init = (root / "start.ckpt").string();
  CHECK_THROWS_AS(train_pose(w), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("train pose with zoomed views: recorded, changes the training, --init from another distance range") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "narrow.ckpt").string());
  train_pose(s);
  PoseTrainSettings z = tiny_settings(root, (root / "zoom.ckpt").string());
  z.net.distance_min = 1.4;
  z.net.distance_max = 4.4;
  z.zoom.prob = 1;
  z.zoom.min = 0.8;
  z.zoom.max = 1.5;
  z.init = s.out;  // another distance range: the distance head is re-expressed, not refused
  train_pose(z);
  Json training;
  const auto zoomed = load_pose_model(z.out, &training);
  CHECK(zoomed->settings().distance_min == 1.4);
  CHECK(training.at("settings").at("zoom").at("prob").get<double>() == 1.0);
  CHECK(training.at("settings").at("zoom").at("max").get<double>() == 1.5);
  // The same run without zoom trains to other parameters.
  PoseTrainSettings nz = z;
  nz.out = (root / "nozoom.ckpt").string();
  nz.zoom = {};
  train_pose(nz);
  CHECK(model_params(nz.out) != model_params(z.out));
  // A resume asking for another zoom is refused.
  z.resume = true;
  z.zoom.max = 1.6;
  CHECK_THROWS_AS(train_pose(z), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("train pose with reframed views and a centre head: recorded, resumes bit for bit, refused without the head") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "plain.ckpt").string());
  train_pose(s);
  // From the plain model: the centre head is added (starting at the image centre), the distance range widened.
  PoseTrainSettings r = tiny_settings(root, (root / "reframed.ckpt").string());
  r.net.centre_head = true;
  r.net.distance_min = 0.9;
  r.net.distance_max = 4.4;
  r.reframe.prob = 1;
  r.steps = 4;
  r.val_every = 2;
  r.init = s.out;
  const PoseTrainResult straight = train_pose(r);
  CHECK(straight.train_centre_loss > 0);
  Json training;
  const auto net = load_pose_model(r.out, &training);
  CHECK(net->settings().centre_head);
  CHECK(training.at("settings").at("reframe").at("camera") == "distance");
  CHECK(training.at("settings").at("centre_weight").get<double>() == 1.0);
  // Cut after the first step (the time limit stops and saves) and resumed: the same parameters.
  PoseTrainSettings cut = r;
  cut.out = (root / "cut.ckpt").string();
  cut.time_limit_seconds = 1e-9;
  train_pose(cut);
  cut.time_limit_seconds = 0;
  cut.resume = true;
  const PoseTrainResult resumed = train_pose(cut);
  CHECK(resumed.start_step == 1);
  CHECK(model_params(r.out) == model_params(cut.out));
  // A resume asking for another reframing is refused.
  cut.reframe.extent = 0.5;
  CHECK_THROWS_AS(train_pose(cut), InvalidInput);
  // Without the centre head the reframed targets cannot be met: refused, as is the focal-length mode.
  PoseTrainSettings bad = r;
  bad.out = (root / "bad.ckpt").string();
  bad.net.centre_head = false;
  CHECK_THROWS_AS(train_pose(bad), InvalidInput);
  bad.net.centre_head = true;
  bad.reframe.camera = ZoomAugmentSettings::CameraFollow::kFocal;
  CHECK_THROWS_AS(train_pose(bad), InvalidInput);
  CHECK(!fs::exists(bad.out));
  fs::remove_all(root);
}

TEST_CASE("train pose --resume accepts a state written before the augmentation and --init settings existed") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "old.ckpt").string());
  train_pose(s);
  const std::string state = s.out + ".train.ckpt";
  REQUIRE(fs::exists(state));
  // Rewrite the state as an older sdfkit wrote it: no "augment" and no "init" in its settings.
  Checkpoint ck = load_checkpoint(state);
  ck.header["settings"].erase("augment");
  ck.header["settings"].erase("init");
  ck.header["settings"].erase("zoom");
  save_checkpoint(state, ck);
  s.resume = true;
  CHECK(train_pose(s).start_step == s.steps);  // the state was taken (a run from scratch would start at 0)
  // ... but not when this run asks for augmentation the old run did not have.
  save_checkpoint(state, ck);
  s.augment.noise = 0.01;
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  fs::remove_all(root);
}

// --ema: the model file holds the average of the raw weights the state keeps, step by step by the formula of
// WeightAverage; a run cut after every step and resumed gives the same model as a straight run.
TEST_CASE("train pose --ema: the model is the weights' moving average, recorded, resumed bit for bit") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "ema.ckpt").string());
  s.ema = 0.5;
  s.steps = 4;
  s.val_every = 1;
  // Cut after every step (the time limit stops and saves), resumed three times.
  PoseTrainSettings cut = s;
  cut.out = (root / "ema_cut.ckpt").string();
  cut.time_limit_seconds = 1e-9;
  PoseNet start(s.net, false);
  start.init(s.seed);
  std::vector<float> average(start.params().values.begin(), start.params().values.end());
  WeightAverage formula(s.ema, average.data(), average.size());
  for (long k = 1; k <= s.steps; ++k) {
    const PoseTrainResult r = train_pose(cut);
    REQUIRE(r.steps == k);
    const Checkpoint state = load_checkpoint(cut.out + ".train.ckpt");
    const std::vector<float>& raw = state.block("params");
    const double d = formula.decay_at(k);
    for (size_t i = 0; i < average.size(); ++i)
      average[i] = static_cast<float>(d) * average[i] + static_cast<float>(1.0 - d) * raw[i];
    // The same formula in this file (floating-point contraction may differ by an ulp).
    const std::vector<float> model = model_params(cut.out);
    REQUIRE(model.size() == average.size());
    double worst = 0, moved = 0;
    for (size_t i = 0; i < model.size(); ++i) {
      worst = std::max(worst, std::abs(double(model[i]) - average[i]) / (1e-3 + std::abs(average[i])));
      moved = std::max(moved, std::abs(double(model[i]) - raw[i]));
    }
    CHECK(worst < 1e-5);
    CHECK(moved > 1e-5);  // the average is not the raw weights (Adam moves each weight by about lr per step)
    average = model;
    cut.resume = true;
  }
  const PoseTrainResult straight = train_pose(s);
  CHECK(model_params(s.out) == model_params(cut.out));
  // Both weights are scored and recorded; the curve has the raw columns.
  Json training;
  load_pose_model(s.out, &training);
  CHECK(training.at("settings").at("ema").get<double>() == 0.5);
  CHECK(training.at("val_d2d").get<double>() == straight.val.d2d);
  CHECK(training.at("val_d2d_raw").get<double>() == straight.val_raw.d2d);
  CHECK(straight.val.d2d != straight.val_raw.d2d);
  std::ifstream csv(straight.csv);
  std::string header;
  std::getline(csv, header);
  CHECK(header == "step,train_loss,val_loss,val_d3d,val_d2d,lr,seconds,val_d3d_raw,val_d2d_raw");
  // A resume with another decay, or without the average, is refused.
  s.resume = true;
  s.ema = 0.9;
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  s.ema = 0;
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  s.ema = 1;
  CHECK_THROWS_AS(train_pose(s), InvalidInput);
  // The command: --json reports both validations, the progress line the raw one; a decay of 1 is a one-line error.
  const std::string cmd = "train pose --data " + root.string() + " --split train --val-split '' --width 2 --feature 16"
                          " --steps 2 --batch 2 --points 16 --val-every 2 --val-items 2 --symmetry-tol 0 -o " +
                          (root / "cli.ckpt").string();
  const test::CliRun r = test::run_sdfkit(cmd + " --ema 0.5 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  CHECK(j.at("val").at("d2d").get<double>() != j.at("val_raw").at("d2d").get<double>());
  CHECK(r.err.find("(raw weights: d3D") != std::string::npos);
  const test::CliRun bad = test::run_sdfkit(cmd + " --ema 1");
  CHECK(bad.code != 0);
  CHECK(bad.err.find("--ema") != std::string::npos);
  fs::remove_all(root);
}

// A fresh benchmark's symmetries take minutes to find: train pose says so once, and not when every shape has its
// cache (symmetries.json, written beside gt.obj by the first run).
TEST_CASE("train pose CLI: one notice while the training shapes' symmetries are found, none once they are cached") {
  const fs::path root = make_pose_dataset();
  for (const std::string id : {"car/a", "lamp/b"})
    write_mesh((root / id / "gt.obj").string(), make_box(Vec3(-0.3, -0.3, -0.3), Vec3(0.3, 0.3, 0.3)));
  const std::string cmd = "train pose --data " + root.string() + " --split train --val-split '' --width 2 --feature 16"
                          " --steps 1 --batch 2 --points 16 --val-items 2 -o ";
  const std::string notice = "vertical-turn symmetries";
  const test::CliRun first = test::run_sdfkit(cmd + (root / "first.ckpt").string());
  REQUIRE_MESSAGE(first.code == 0, first.err);
  CHECK(first.err.find(notice) != std::string::npos);
  CHECK(first.err.find(notice) == first.err.rfind(notice));  // once, not per shape
  for (const std::string id : {"car/a", "lamp/b"}) CHECK(fs::exists(root / id / "symmetries.json"));
  const test::CliRun second = test::run_sdfkit(cmd + (root / "second.ckpt").string());
  REQUIRE_MESSAGE(second.code == 0, second.err);
  CHECK(second.err.find(notice) == std::string::npos);
  // A cache that does not answer is searched again, with the notice: another tolerance, or a stale entry.
  const test::CliRun other_tol = test::run_sdfkit(cmd + (root / "third.ckpt").string() + " --symmetry-tol 0.02");
  REQUIRE_MESSAGE(other_tol.code == 0, other_tol.err);
  CHECK(other_tol.err.find(notice) != std::string::npos);
  const fs::path gt = root / "lamp/b/gt.obj";
  fs::last_write_time(gt, fs::last_write_time(gt) + std::chrono::seconds(5));
  const test::CliRun stale = test::run_sdfkit(cmd + (root / "fourth.ckpt").string());
  REQUIRE_MESSAGE(stale.code == 0, stale.err);
  CHECK(stale.err.find(notice) != std::string::npos);
  CHECK(stale.err.find(notice) == stale.err.rfind(notice));
  fs::remove_all(root);
}

// Issue 6: eval-pose's symmetry-aware scores. With one view per shape each category holds one item, so the score
// modulo the half turn must be the smaller of the plain score and the score against the half-turned true camera
// (the same images with every camera replaced by its twin, R -> R rot_y(180)).
TEST_CASE("evaluate_pose modulo symmetries: the smaller of the true camera's and its twin's errors, per shape") {
  const fs::path root = make_pose_dataset();
  PoseTrainSettings s = tiny_settings(root, (root / "eval.ckpt").string());
  train_pose(s);
  auto net = load_pose_model(s.out);
  const fs::path twin_root = test::scratch_dir("pose_eval_twin");
  fs::copy(root, twin_root, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  Mat3 half;
  half << -1, 0, 0, 0, 1, 0, 0, 0, -1;
  for (const std::string id : {"car/a", "lamp/b"})
    for (const std::string nn : {"00", "01"}) {
      const std::string path = (twin_root / id / "views" / (nn + ".json")).string();
      Camera cam = read_camera(path);
      cam.R = cam.R * half;
      write_camera(path, cam);
    }
  DatasetSettings ds;
  ds.root = root.string();
  ds.split = "train";
  const Dataset data(ds);
  ds.root = twin_root.string();
  const Dataset twin_data(ds);
  PoseEvalSettings es;
  es.points = 32;
  es.views = 1;
  std::map<std::string, PoseScores> plain, twin, modulo;
  const PoseScores all_plain = evaluate_pose(*net, data, es, &plain);
  evaluate_pose(*net, twin_data, es, &twin);
  CHECK(all_plain.items == 2);
  // One item per category: its large-error share is 0 or 1 by its own d2D; the overall share is their mean.
  for (auto& [c, v] : plain) CHECK(v.large == (v.d2d > kLargePoseError ? 1.0 : 0.0));
  CHECK(all_plain.large == doctest::Approx((plain["car"].large + plain["lamp"].large) / 2));
  CHECK(all_plain.d2d_sym == all_plain.d2d);  // no symmetry source: the plain scores
  CHECK(all_plain.d3d_sym == all_plain.d3d);

  // Chunks of one image on 1 or 2 threads: the same scores, bit for bit.
  {
    PoseEvalSettings each = es;
    each.views = -1;
    each.batch = 1;
    PoseScores one, two;
    tbb::task_arena(1).execute([&] { one = evaluate_pose(*net, data, each); });
    tbb::task_arena(2).execute([&] { two = evaluate_pose(*net, data, each); });
    CHECK(one.items == 4);
    CHECK(one.d2d == two.d2d);
    CHECK(one.d3d == two.d3d);
    CHECK(one.loss == two.loss);
  }

  // Two unreadable cameras (car/a's second view, lamp/b's first): the error names the first in (shape, view) order
  // on any number of threads, whichever chunk fails first.
  {
    const fs::path broken = test::scratch_dir("pose_eval_broken");
    fs::copy(root, broken, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    for (const char* view : {"car/a/views/01.json", "lamp/b/views/00.json"}) std::ofstream(broken / view) << "{ broken";
    DatasetSettings bs;
    bs.root = broken.string();
    bs.split = "train";
    const Dataset bad(bs);
    PoseEvalSettings each = es;
    each.views = -1;
    each.batch = 1;
    for (const int threads : {1, 2, 4})
      for (int run = 0; run < 3; ++run) {
        std::string msg;
        tbb::task_arena(threads).execute([&] {
          try {
            evaluate_pose(*net, bad, each);
          } catch (const std::exception& e) {
            msg = e.what();
          }
        });
        CHECK_MESSAGE(msg.find((fs::path("car") / "a" / "views" / "01.json").string()) != std::string::npos, msg);
      }
  }

  // The half turn for the car only; the source is asked once per shape.
  std::atomic<int> calls{0};  // called from several threads at once
  es.symmetries = [&](const ShapeEntry& shape) {
    ++calls;
    return shape.category == "car" ? std::vector<Mat3>{half} : std::vector<Mat3>{};
  };
  std::vector<PoseItemScore> items;
  const PoseScores all = evaluate_pose(*net, data, es, &modulo, {}, &items);
  CHECK(calls == 2);
  // Per image: (shape, view) order, the category means are their means, the angles those of the cameras.
  REQUIRE(items.size() == 2);
  CHECK(items[0].id == "car/a");
  CHECK(items[1].id == "lamp/b");
  CHECK(items[0].view == 0);
  CHECK(items[0].plain.d2d == doctest::Approx(plain["car"].d2d).epsilon(1e-12));
  CHECK(items[0].sym.d2d == doctest::Approx(modulo["car"].d2d_sym).epsilon(1e-12));
  CHECK(items[1].sym.d3d == items[1].plain.d3d);
  CHECK(items[0].distance == doctest::Approx(2.7).epsilon(1e-12));
  CHECK(items[0].distance_est > 0);
  for (const PoseItemScore& it : items) {
    CHECK(it.rotation_deg >= std::abs(it.azimuth_deg) - 1e-9);  // the vertical turn is part of the whole rotation
    CHECK(it.rotation_deg <= 180.0);
  }
  CHECK(all.d2d == all_plain.d2d);  // the plain scores do not change
  CHECK(all.d3d == all_plain.d3d);
  CHECK(modulo["car"].d2d_sym == doctest::Approx(std::min(plain["car"].d2d, twin["car"].d2d)).epsilon(1e-12));
  CHECK(modulo["car"].d3d_sym == doctest::Approx(std::min(plain["car"].d3d, twin["car"].d3d)).epsilon(1e-12));
  CHECK(twin["car"].d2d != doctest::Approx(plain["car"].d2d));  // the twin really is another camera
  CHECK(modulo["lamp"].d2d_sym == modulo["lamp"].d2d);
  CHECK(modulo["lamp"].d3d_sym == modulo["lamp"].d3d);
  CHECK(all.d2d_sym == doctest::Approx((modulo["car"].d2d_sym + modulo["lamp"].d2d_sym) / 2).epsilon(1e-12));
  CHECK(all.d2d_twin == all.d2d);  // no twin source: the plain scores
  CHECK(items[0].twin.d2d == items[0].plain.d2d);

  // Twins per image: the source is asked once per image, in (shape, view) order, with the camera the image is
  // scored against; the car's view is scored modulo the half turn, the lamp's without twins.
  {
    PoseEvalSettings tw = es;
    tw.symmetries = nullptr;
    std::vector<std::pair<size_t, int>> asked;
    tw.twins = [&](size_t shape, int view, const Camera& truth, const Camera& predicted) {
      asked.emplace_back(shape, view);
      CHECK(truth.R.isApprox(data.camera(shape, view).R, 1e-12));
      CHECK(predicted.t.norm() > 0);
      return shape == 0 ? std::vector<Mat3>{half} : std::vector<Mat3>{};
    };
    std::map<std::string, PoseScores> by_twin;
    std::vector<PoseItemScore> twin_items;
    const PoseScores t = evaluate_pose(*net, data, tw, &by_twin, {}, &twin_items);
    CHECK(asked == std::vector<std::pair<size_t, int>>{{0, 0}, {1, 0}});
    CHECK(by_twin["car"].d2d_twin == doctest::Approx(std::min(plain["car"].d2d, twin["car"].d2d)).epsilon(1e-12));
    CHECK(by_twin["car"].d3d_twin == doctest::Approx(std::min(plain["car"].d3d, twin["car"].d3d)).epsilon(1e-12));
    CHECK(by_twin["lamp"].d2d_twin == by_twin["lamp"].d2d);
    CHECK(twin_items[0].twin.d2d == doctest::Approx(by_twin["car"].d2d_twin).epsilon(1e-12));
    CHECK(t.d2d == all_plain.d2d);
    CHECK(t.d2d_sym == t.d2d);  // twins are not symmetries
  }

  // The centre and distance columns. A network without a centre head puts the principal point at the image centre,
  // as a render has it: no centre error on the views as rendered. Reframed, the true principal point moves with the
  // crop, so the error is its distance from the image centre, taken here from reframe_images on the same images.
  {
    REQUIRE_FALSE(net->settings().centre_head);
    CHECK(all_plain.centre_px == 0.0);
    PoseEvalSettings rf = es;
    rf.reframe = true;
    std::vector<PoseItemScore> rf_items;
    const PoseScores r = evaluate_pose(*net, data, rf, nullptr, {}, &rf_items);
    REQUIRE(rf_items.size() == 2);
    const int S = net->settings().image_size;
    MatrixXfR images(2, 3 * S * S);
    std::vector<Camera> cams;
    for (size_t s2 = 0; s2 < 2; ++s2) {
      images.row(static_cast<Eigen::Index>(s2)) = network_image(data.image(s2, 0), S).transpose();
      cams.push_back(data.camera(s2, 0));
    }
    ReframeAugmentSettings all_framed;
    all_framed.prob = 1;
    all_framed.camera = ZoomAugmentSettings::CameraFollow::kDistance;
    reframe_images(images, cams, all_framed, rf.seed, 0);
    double mean_px = 0, mean_dist = 0;
    for (size_t k = 0; k < 2; ++k) {
      const double expected = std::hypot(cams[k].K(0, 2) - 0.5 * S, cams[k].K(1, 2) - 0.5 * S);
      CHECK(expected > 0.5);  // the crop really moved the origin
      CHECK(rf_items[k].centre_px == doctest::Approx(expected).epsilon(1e-9));
      mean_px += rf_items[k].centre_px / 2;
      mean_dist += std::abs(rf_items[k].distance_est / rf_items[k].distance - 1) / 2;
    }
    CHECK(r.centre_px == doctest::Approx(mean_px).epsilon(1e-12));
    CHECK(r.distance_error == doctest::Approx(mean_dist).epsilon(1e-12));
    CHECK(r.distance_error > 0);
  }

  // The CLI finds the symmetries in each shape's gt.obj: a centred oblong box has the half turn, a box off the
  // axis none; its scores are those of the API with the same symmetries (one reading per view, as the API's net).
  const std::string cmd = "eval-pose --model " + s.out + " --data " + root.string() +
                          " --split train --views 1 --points 32 --symmetry --pose-tta none --json";
  const test::CliRun missing = test::run_sdfkit(cmd);
  CHECK(missing.code == 1);
  CHECK(missing.err.find((root / "car" / "a" / "gt.obj").string()) != std::string::npos);
  write_mesh((root / "car" / "a" / "gt.obj").string(), make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)));
  write_mesh((root / "lamp" / "b" / "gt.obj").string(), make_box(Vec3(-0.1, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)));
  const test::CliRun r = test::run_sdfkit(cmd);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  CHECK(j.at("symmetries").at("car/a") == Json::array({180}));
  CHECK(j.at("symmetries").at("lamp/b") == Json::array());
  CHECK(j.at("per_category").at("car").at("d2d_sym").get<double>() ==
        doctest::Approx(modulo["car"].d2d_sym).epsilon(1e-9));
  CHECK(j.at("per_category").at("lamp").at("d2d_sym").get<double>() ==
        doctest::Approx(modulo["lamp"].d2d).epsilon(1e-9));
  CHECK(j.at("d2d").get<double>() == doctest::Approx(all_plain.d2d).epsilon(1e-9));

  // --per-image: one CSV row per image, whose d2D are the API's.
  const std::string csv = (root / "per_image.csv").string();
  const test::CliRun pr = test::run_sdfkit(cmd + " --per-image " + csv);
  REQUIRE_MESSAGE(pr.code == 0, pr.err);
  std::istringstream lines(read_file(csv));
  std::string line;
  std::getline(lines, line);
  CHECK(line == "id,view,d3d,d2d,d3d_sym,d2d_sym,rotation_deg,azimuth_deg,distance,distance_est,centre_px");
  std::vector<std::string> rows;
  while (std::getline(lines, line)) rows.push_back(line);
  REQUIRE(rows.size() == 2);
  CHECK(rows[0].rfind("car/a,0,", 0) == 0);
  CHECK(rows[1].rfind("lamp/b,0,", 0) == 0);
  const auto field = [](const std::string& row, int k) {
    std::istringstream f(row);
    std::string v;
    for (int i = 0; i <= k; ++i) std::getline(f, v, ',');
    return std::stod(v);
  };
  CHECK(field(rows[0], 3) == doctest::Approx(items[0].plain.d2d).epsilon(1e-5));
  CHECK(field(rows[1], 3) == doctest::Approx(items[1].plain.d2d).epsilon(1e-5));
  CHECK(field(rows[0], 5) == doctest::Approx(items[0].sym.d2d).epsilon(1e-5));

  // --twins renders each shape's source mesh (norm.json's "source") where the estimate is turned by 20 degrees or
  // more: without norm.json it names the file; with it, twin_diff is given exactly for those images and the
  // d2D-twin is never above the d2D.
  const std::string twins_cmd = "eval-pose --model " + s.out + " --data " + root.string() +
                                " --split train --points 32 --pose-tta none --flip-check 0 --twins";
  const test::CliRun tol_alone = test::run_sdfkit("eval-pose --model " + s.out + " --data " + root.string() +
                                                  " --split train --twin-tol 0.5");
  CHECK(tol_alone.code != 0);
  CHECK(tol_alone.err.find("--twin-tol applies with --twins") != std::string::npos);
  const test::CliRun no_norm = test::run_sdfkit(twins_cmd + " --json");
  CHECK(no_norm.code == 1);
  CHECK(no_norm.err.find("norm.json") != std::string::npos);
  // A recorded source that is gone is named (checked for every shape before the network reads any image).
  for (const std::string id : {"car/a", "lamp/b"})
    write_json((root / id / "norm.json").string(),
               Json{{"norm", {0.0, 0.0, 0.0, 1.0}}, {"source", (root / id / "gone.obj").string()}});
  const test::CliRun gone = test::run_sdfkit(twins_cmd + " --json");
  CHECK(gone.code == 1);
  CHECK(gone.err.find("gone.obj") != std::string::npos);
  CHECK(gone.out.empty());
  for (const std::string id : {"car/a", "lamp/b"}) {
    const std::string src = (root / id / "source.obj").string();
    write_mesh(src, id == "car/a" ? make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2))
                                  : make_box(Vec3(-0.1, -0.3, -0.2), Vec3(0.5, 0.3, 0.2)));
    write_json((root / id / "norm.json").string(), Json{{"norm", {0.0, 0.0, 0.0, 1.0}}, {"source", src}});
  }
  const std::string twins_csv = (root / "twins.csv").string();
  const test::CliRun tr = test::run_sdfkit(twins_cmd + " --json --per-image " + twins_csv);
  REQUIRE_MESSAGE(tr.code == 0, tr.err);
  const Json tj = Json::parse(tr.out);
  CHECK(tj.at("twin_tol").get<double>() == doctest::Approx(0.01));
  CHECK(tj.at("d2d_twin").get<double>() <= tj.at("d2d").get<double>() + 1e-12);
  CHECK(tj.at("twinned_images").get<long>() <= tj.at("turned_images").get<long>());
  CHECK(tj.at("per_category").at("car").contains("d2d_twin"));
  std::istringstream twin_lines(read_file(twins_csv));
  std::getline(twin_lines, line);
  CHECK(line == "id,view,d3d,d2d,d3d_sym,d2d_sym,rotation_deg,azimuth_deg,distance,distance_est,centre_px,"
                "d3d_twin,d2d_twin,twin_diff");
  int tested = 0, rows_seen = 0;
  while (std::getline(twin_lines, line)) {
    ++rows_seen;
    const bool has_diff = line.back() != ',';
    CHECK(has_diff == (std::abs(field(line, 7)) >= 20));
    CHECK(field(line, 12) <= field(line, 3) + 1e-9);
    if (has_diff) {
      ++tested;
      CHECK(field(line, 13) >= 0);
      CHECK(field(line, 13) <= 1);
    }
  }
  CHECK(rows_seen == 4);
  CHECK(tested > 0);  // the tiny model turns some view by 20 degrees or more: the renders were compared
  CHECK(tj.at("turned_images").get<long>() == tested);
  fs::remove_all(root);
}
