#include "core/json.h"
#include "train/sdf_train.h"

#include "camera/camera.h"
#include "camera/image.h"
#include "cli_run.h"
#include "core/error.h"
#include "core/files.h"
#include "core/primitives.h"
#include "core/random.h"
#include "nets/checkpoint.h"
#include "scratch.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const Vec3 kTorusCenter(0.05, -0.02, 0.0);
constexpr double kR = 0.5, kr = 0.2;

/// A one-shape prepared dataset of a torus: exact SDF samples (near-surface and uniform) and one view.
fs::path make_torus_dataset(const std::string& name) {
  const fs::path root = test::scratch_dir(name);
  fs::remove_all(root);
  const fs::path dir = root / "ring" / "torus";
  Rng rng(5);
  MatrixXfR s(6000, 4);
  int n = 0;
  while (n < 6000) {
    const Vec3 p(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const double d = torus_sdf(p, kTorusCenter, kR, kr);
    if (n >= 2000 && std::abs(d) > 0.1) continue;  // 2000 uniform, then near-surface only
    s.row(n++) << float(p.x()), float(p.y()), float(p.z()), float(d);
  }
  write_npy((dir / "samples.npy").string(), s);
  const Camera cam = look_at(30, 25, 2.7);
  write_camera((dir / "views" / "00.json").string(), cam);
  Image img(137, 137, 4, 0.f);
  for (int y = 30; y < 100; ++y)
    for (int x = 20; x < 117; ++x) img.at(x, y, 0) = img.at(x, y, 3) = 1.f;
  write_image((dir / "views" / "00.png").string(), img);
  write_text_atomic((root / "train.lst").string(), "ring/torus\n");
  return root;
}

SdfNetConfig small_config(SdfVariant v) {
  SdfNetConfig c;
  c.variant = v;
  c.encoder_channels = {4, 6, 8};
  c.extra_convs = 0;
  c.global_features = 16;
  c.point_mlp = {32, 64};
  c.decoder = {64, 32};
  c.one_stream_maps = 2;
  return c;
}

/// A tiny constant-rate training run on the dataset at `root` (no validation split, 2 items x 64 points a step).
SdfTrainSettings tiny_run(const fs::path& root, SdfVariant v) {
  SdfTrainSettings st;
  st.data = root.string();
  st.val_split = "";
  st.net = small_config(v);
  st.batch = 2;
  st.points = 64;
  st.val_every = 3;
  st.val_shapes = 1;
  st.val_points = 64;
  st.lr_min = st.lr;
  return st;
}

/// The parameter block of checkpoint ROOT/NAME.
std::vector<float> params(const fs::path& root, const std::string& name) {
  return load_checkpoint((root / name).string()).block("params");
}

/// Trains `st` for 6 steps into ROOT/NAME_straight.ckpt, and for 3 steps then resumed to 6 into
/// ROOT/NAME_split.ckpt; returns the resumed run's result.
SdfTrainResult straight_and_split(SdfTrainSettings st, const fs::path& root, const std::string& name) {
  st.resume = false;
  st.out = (root / (name + "_straight.ckpt")).string();
  st.steps = 6;
  train_sdf(st);
  st.out = (root / (name + "_split.ckpt")).string();
  st.steps = 3;
  train_sdf(st);
  st.steps = 6;
  st.resume = true;
  return train_sdf(st);
}

}  // namespace

TEST_CASE("train sdf overfits one shape: IoU > 0.95 on a grid against the exact torus") {
  const fs::path root = make_torus_dataset("sdf_train_overfit");
  SdfTrainSettings st;
  st.data = root.string();
  st.val_split = "";
  st.out = (root / "m.ckpt").string();
  st.net = small_config(SdfVariant::kTwoStream);
  st.steps = 600;
  st.batch = 1;
  st.points = 1024;
  st.lr = 2e-3;
  st.lr_min = 1e-4;
  st.weight_decay = 0;
  st.val_every = 600;
  st.val_shapes = 1;
  const SdfTrainResult r = train_sdf(st);
  CHECK(r.steps == 600);
  CHECK(fs::exists(r.csv));
  CHECK(fs::exists(r.plot));
  CHECK(r.val.sign_accuracy > 0.9);

  const auto net = load_sdf_model(st.out);
  DatasetSettings ds;
  ds.root = root.string();
  const Dataset data(ds);
  const auto code = net->encode(data.input(0, 0).data(), data.camera(0, 0));
  const int G = 40;
  Points P(G * G * G, 3);
  for (int i = 0, k = 0; i < G; ++i)
    for (int j = 0; j < G; ++j)
      for (int l = 0; l < G; ++l, ++k) P.row(k) << -0.8 + 1.6 * (i + 0.5) / G, -0.8 + 1.6 * (j + 0.5) / G,
                                                  -0.8 + 1.6 * (l + 0.5) / G;
  Eigen::VectorXd f;
  net->field(code, P, f);
  long inter = 0, uni = 0;
  for (Eigen::Index k = 0; k < P.rows(); ++k) {
    const bool gt = torus_sdf(P.row(k).transpose(), kTorusCenter, kR, kr) < 0.003;  // the 0 level is sdf 0.003
    const bool pr = f[k] < 0;
    inter += gt && pr;
    uni += gt || pr;
  }
  const double iou = double(inter) / double(uni);
  MESSAGE("overfit IoU " << iou);
  CHECK(iou > 0.95);
  fs::remove_all(root);
}

TEST_CASE("resumed training continues bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_resume");
  // Constant rate (tiny_run): the schedule must not depend on --steps, which differs between the runs.
  SdfTrainSettings st = tiny_run(root, SdfVariant::kOneStream);
  const SdfTrainResult r = straight_and_split(st, root, "const");
  CHECK(r.start_step == 3);
  CHECK(params(root, "const_straight.ckpt") == params(root, "const_split.ckpt"));
  // A decaying rate with its horizon fixed by lr_steps: a 3-step run resumed to 6 steps equals 6 straight steps
  // (without lr_steps the 3-step run would decay over 3 steps, and the runs would differ).
  st.lr_min = st.lr / 10;
  st.lr_steps = 6;
  straight_and_split(st, root, "cos");
  CHECK(params(root, "cos_straight.ckpt") == params(root, "cos_split.ckpt"));
  CHECK(params(root, "const_straight.ckpt") != params(root, "cos_straight.ckpt"));
  // A different configuration refuses to resume.
  st.out = (root / "cos_split.ckpt").string();
  st.steps = 6;
  st.resume = true;
  st.net.decoder = {16, 8};
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("a run killed while saving resumes from its checkpoint, drops later curve rows, removes temporaries") {
  const fs::path root = make_torus_dataset("sdf_train_killed");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 6;
  st.out = (root / "straight.ckpt").string();
  train_sdf(st);
  // The killed run: saved at step 3; then killed while saving step 6, after the curve was written (curves go
  // first) and while the checkpoint's temporary was being written.
  st.steps = 3;
  st.out = (root / "killed.ckpt").string();
  const SdfTrainResult first = train_sdf(st);
  {
    std::ofstream csv(first.csv, std::ios::app);
    csv << "6,99,0.001,1,99,0,0\n";
  }
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  const std::string tmp = st.out + ".tmp." + std::to_string(child);
  { std::ofstream(tmp) << "half a checkpoint"; }
  st.steps = 6;
  st.resume = true;
  const SdfTrainResult r = train_sdf(st);
  CHECK(r.start_step == 3);
  CHECK_FALSE(fs::exists(tmp));
  CHECK(params(root, "straight.ckpt") == params(root, "killed.ckpt"));
  const std::string curve = read_file(r.csv);
  CHECK(curve.find("\n6,99,") == std::string::npos);
  std::vector<double> steps;  // first column of every row after the header
  std::istringstream lines(curve);
  std::string line;
  std::getline(lines, line);
  while (std::getline(lines, line))
    if (!line.empty()) steps.push_back(std::stod(line.substr(0, line.find(','))));
  REQUIRE(!steps.empty());
  CHECK(steps.back() == 6.0);
  for (size_t i = 1; i < steps.size(); ++i) CHECK(steps[i] > steps[i - 1]);  // no step twice
  fs::remove_all(root);
}

TEST_CASE("data-parallel training gives the same checkpoint for 1 and 2 threads") {
  const fs::path root = make_torus_dataset("sdf_train_threads");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.batch = 3;  // odd: the two threads get unequal shares
  st.steps = 4;
  st.camera_jitter_deg = 5;
  std::vector<Checkpoint> cks;
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    st.out = (root / ("threads" + std::to_string(threads) + ".ckpt")).string();
    train_sdf(st);
    cks.push_back(load_checkpoint(st.out));
  }
  for (const char* block : {"params", "opt_m", "opt_v"}) {
    CAPTURE(block);
    REQUIRE(cks[0].has_block(block));
    CHECK(cks[0].block(block) == cks[1].block(block));
  }
  // The training moved the parameters (a run that did nothing would pass the comparison too).
  SdfNet fresh(st.net);
  fresh.init(st.seed);
  CHECK(cks[0].block("params") != std::vector<float>(fresh.params().values.begin(), fresh.params().values.end()));
  fs::remove_all(root);
}

TEST_CASE("camera jitter turns each camera about the object's vertical axis by a seeded Gaussian angle") {
  const Camera base = look_at(40, 28, 2.6);
  std::vector<Camera> cams(4000, base);
  jitter_cameras(cams, 15.0, 7, 11);
  const Vec3 c0 = -base.R.transpose() * base.t;  // camera centre in the object frame
  const Vec3 on_axis(0, 0.4, 0);
  const Eigen::Vector2d px0 = project(base, on_axis);
  double sum = 0, sum2 = 0;
  for (const Camera& c : cams) {
    CHECK((c.R.transpose() * c.R - Mat3::Identity()).norm() < 1e-12);
    CHECK((c.t - base.t).norm() == 0.0);
    const Vec3 c1 = -c.R.transpose() * c.t;
    CHECK(c1.norm() == doctest::Approx(c0.norm()).epsilon(1e-12));  // same distance and elevation:
    CHECK(c1.y() == doctest::Approx(c0.y()).epsilon(1e-12));         // only the azimuth changes
    CHECK((project(c, on_axis) - px0).norm() < 1e-9);                // the vertical axis stays in place
    const double a = std::atan2(c0.x() * c1.z() - c0.z() * c1.x(), c0.x() * c1.x() + c0.z() * c1.z());
    sum += a;
    sum2 += a * a;
  }
  const double n = static_cast<double>(cams.size()), mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  CHECK(std::abs(mean) < 4 * (15.0 * M_PI / 180.0) / std::sqrt(n));
  CHECK(sd * 180.0 / M_PI == doctest::Approx(15.0).epsilon(0.05));
  // Seeded: the same (seed, step) gives the same cameras, another step others; sigma 0 changes nothing.
  std::vector<Camera> again(4000, base), other(4000, base), none(3, base);
  jitter_cameras(again, 15.0, 7, 11);
  jitter_cameras(other, 15.0, 7, 12);
  jitter_cameras(none, 0.0, 7, 11);
  CHECK((again[5].R - cams[5].R).norm() == 0.0);
  CHECK((other[5].R - cams[5].R).norm() > 1e-6);
  CHECK((none[2].R - base.R).norm() == 0.0);
}

TEST_CASE("--init starts from a model's weights, and jittered training is seeded and resumes bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_init");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.out = (root / "a.ckpt").string();
  st.steps = 3;
  train_sdf(st);
  // A step at a vanishing rate from --init leaves the weights where the model had them.
  SdfTrainSettings ft = st;
  ft.init = (root / "a.ckpt").string();
  ft.seed = 9;  // another seeded initialisation, overwritten by the model's weights
  ft.lr = ft.lr_min = 1e-30;
  ft.steps = 1;
  ft.out = (root / "ft.ckpt").string();
  train_sdf(ft);
  {
    // Not bit for bit: a parameter that is exactly 0 (a dead unit's bias) moves by the step's 1e-30 when its
    // gradient is not exactly 0, which depends on the compiler's rounding.
    const std::vector<float> tuned = params(root, "ft.ckpt"), start = params(root, "a.ckpt");
    REQUIRE(tuned.size() == start.size());
    double diff = 0;
    for (size_t i = 0; i < start.size(); ++i) diff = std::max(diff, double(std::abs(tuned[i] - start[i])));
    CHECK(diff < 1e-20);
  }
  ft.init = "";
  ft.out = (root / "scratch.ckpt").string();
  train_sdf(ft);
  CHECK(params(root, "scratch.ckpt") != params(root, "a.ckpt"));
  // A model of another configuration is refused, naming the file.
  ft.init = (root / "a.ckpt").string();
  ft.net.decoder = {16, 8};
  ft.out = (root / "bad.ckpt").string();
  try {
    train_sdf(ft);
    FAIL("expected InvalidInput");
  } catch (const InvalidInput& e) {
    CHECK(std::string(e.what()).find("a.ckpt: --init model has another configuration") != std::string::npos);
  }
  CHECK_FALSE(fs::exists(root / "bad.ckpt"));
  // Jitter changes the training; a jittered run split by a resume equals the straight one.
  st.camera_jitter_deg = 20;
  straight_and_split(st, root, "j");
  CHECK(params(root, "j_straight.ckpt") == params(root, "j_split.ckpt"));
  st.camera_jitter_deg = 0;
  st.steps = 6;
  st.out = (root / "plain.ckpt").string();
  train_sdf(st);
  CHECK(params(root, "plain.ckpt") != params(root, "j_straight.ckpt"));
  st.camera_jitter_deg = -1;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("zoomed training: recorded in the model, changes the training, resumes bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_zoom");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 6;
  st.out = (root / "plain.ckpt").string();
  train_sdf(st);
  st.zoom.prob = 1.0;
  st.zoom.min = 0.7;
  st.zoom.max = 1.4;
  straight_and_split(st, root, "z");
  CHECK(params(root, "z_straight.ckpt") == params(root, "z_split.ckpt"));
  CHECK(params(root, "z_straight.ckpt") != params(root, "plain.ckpt"));
  const Json training = load_checkpoint((root / "z_straight.ckpt").string()).header.at("training");
  CHECK(training.at("zoom").at("camera") == "focal");
  CHECK(training.at("zoom").at("max") == 1.4);
  // The distance mode would teach the local features wrong projections: refused.
  st.zoom.camera = ZoomAugmentSettings::CameraFollow::kDistance;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  fs::remove_all(root);
}

// --ema: the model's parameters are the moving average of the raw weights (block raw_params), step by step by the
// formula of WeightAverage; resumed runs continue both bit for bit; a resume must keep the decay.
TEST_CASE("training with a weight average: the model is the average, recorded, resumes bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_ema");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);  // constant rate: runs of any length agree
  st.ema = 0.5;
  st.val_every = 1;
  SdfNet start(st.net);
  start.init(st.seed);
  std::vector<float> average(start.params().values.begin(), start.params().values.end());
  const WeightAverage formula(st.ema, average.data(), average.size());
  st.out = (root / "steps.ckpt").string();
  for (long k = 1; k <= 3; ++k) {  // one step per run, each resuming the previous
    st.steps = k;
    st.resume = k > 1;
    const SdfTrainResult r = train_sdf(st);
    REQUIRE(r.steps == k);
    const Checkpoint ck = load_checkpoint(st.out);
    const std::vector<float>& raw = ck.block("raw_params");
    const std::vector<float>& model = ck.block("params");
    REQUIRE(model.size() == average.size());
    const double d = formula.decay_at(k);
    double worst = 0, moved = 0;
    for (size_t i = 0; i < model.size(); ++i) {
      const double expected = d * average[i] + (1 - d) * raw[i];
      worst = std::max(worst, std::abs(model[i] - expected) / (1e-3 + std::abs(expected)));
      moved = std::max(moved, double(std::abs(model[i] - raw[i])));
    }
    CHECK(worst < 1e-5);
    CHECK(moved > 1e-5);
    average = model;
    // What recon reads is the average.
    const auto net = load_sdf_model(st.out);
    CHECK(std::equal(model.begin(), model.end(), net->params().values.begin()));
  }
  // Straight and split runs agree in both blocks; the validation of both weights is recorded.
  const SdfTrainResult r = straight_and_split(st, root, "ema");
  CHECK(params(root, "ema_straight.ckpt") == params(root, "ema_split.ckpt"));
  CHECK(load_checkpoint((root / "ema_straight.ckpt").string()).block("raw_params") ==
        load_checkpoint((root / "ema_split.ckpt").string()).block("raw_params"));
  CHECK(r.val.loss != r.val_raw.loss);
  const Json training = load_checkpoint((root / "ema_split.ckpt").string()).header.at("training");
  CHECK(training.at("ema").get<double>() == 0.5);
  CHECK(training.at("val_raw").at("loss").get<double>() == r.val_raw.loss);
  std::ifstream csv(r.csv);
  std::string header;
  std::getline(csv, header);
  CHECK(header.find(",val_loss_raw,val_sign_accuracy_raw,val_sample_iou_raw") != std::string::npos);
  // A resume without the average, with another decay, or of a run without one, is refused.
  st.out = (root / "ema_split.ckpt").string();
  st.resume = true;
  st.steps = 7;
  st.ema = 0;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  st.ema = 0.9;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  st.ema = 1;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  SdfTrainSettings plain = tiny_run(root, SdfVariant::kTwoStream);
  plain.out = (root / "plain.ckpt").string();
  plain.steps = 2;
  train_sdf(plain);
  plain.ema = 0.5;
  plain.resume = true;
  plain.steps = 3;
  CHECK_THROWS_AS(train_sdf(plain), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("reframed training: recorded in the model, changes the training, resumes bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_reframe");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 6;
  st.out = (root / "plain.ckpt").string();
  train_sdf(st);
  st.reframe.prob = 1.0;
  st.reframe.extent = 0.5;
  straight_and_split(st, root, "r");
  CHECK(params(root, "r_straight.ckpt") == params(root, "r_split.ckpt"));
  CHECK(params(root, "r_straight.ckpt") != params(root, "plain.ckpt"));
  const Json training = load_checkpoint((root / "r_straight.ckpt").string()).header.at("training");
  CHECK(training.at("reframe").at("prob") == 1.0);
  CHECK(training.at("reframe").at("extent") == 0.5);
  st.reframe.extent = 1.5;
  st.out = (root / "bad.ckpt").string();
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  CHECK(!fs::exists(st.out));
  fs::remove_all(root);
}

TEST_CASE("occluded training with a mask channel: recorded, starts from an RGB model, resumes bit for bit") {
  const fs::path root = make_torus_dataset("sdf_train_occlusion");
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 6;
  st.out = (root / "rgb.ckpt").string();
  train_sdf(st);
  st.net.input_channels = 4;
  st.init = st.out;
  st.occlusion.kind = OcclusionAugmentSettings::Kind::kMixed;
  st.occlusion.prob = 1.0;
  straight_and_split(st, root, "o");
  CHECK(params(root, "o_straight.ckpt") == params(root, "o_split.ckpt"));
  const Checkpoint ck = load_checkpoint((root / "o_straight.ckpt").string());
  CHECK(ck.header.at("config").at("input_channels") == 4);
  CHECK(ck.header.at("training").at("occlusion").at("kind") == "mixed");
  // A network with mirror features starts from the same RGB model (its new weights at 0) and resumes bit for bit.
  {
    SdfTrainSettings sym = st;
    sym.net.mirror_features = true;
    straight_and_split(sym, root, "m");
    CHECK(params(root, "m_straight.ckpt") == params(root, "m_split.ckpt"));
    CHECK(load_checkpoint((root / "m_straight.ckpt").string()).header.at("config").at("mirror_features") == true);
    CHECK(params(root, "m_straight.ckpt").size() > params(root, "o_straight.ckpt").size());
  }
  // The occluded images changed the training: the same run without occlusion ends elsewhere.
  st.occlusion.prob = 0;
  st.out = (root / "o_plain.ckpt").string();
  st.resume = false;
  st.steps = 6;
  train_sdf(st);
  CHECK(params(root, "o_straight.ckpt") != params(root, "o_plain.ckpt"));
  // An RGB model of another architecture cannot start a mask-channel one.
  st.net.global_features = 8;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("object-channel training: recorded, starts from a mask-channel model, resumes bit for bit, refuses mixes") {
  const fs::path root = make_torus_dataset("sdf_train_context");
  // Two background photographs (a gradient and stripes) for the drawn backgrounds.
  const fs::path photos = root / "photos";
  for (int k = 0; k < 2; ++k) {
    Image p(64, 48, 3);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x)
        for (int c = 0; c < 3; ++c) p.at(x, y, c) = k == 0 ? float(x) / 63.f * (c + 1) / 3.f : float((x / 4 + c) % 2);
    write_image((photos / ("p" + std::to_string(k) + ".png")).string(), p);
  }
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 6;
  st.net.input_channels = 4;
  st.out = (root / "missing.ckpt").string();
  train_sdf(st);
  st.init = st.out;
  st.net.mask_channel = SdfNetConfig::MaskChannel::kObject;
  st.context.prob = 1.0;
  st.context.mask_error = 1.0;
  st.context_backgrounds = photos.string();
  straight_and_split(st, root, "c");
  CHECK(params(root, "c_straight.ckpt") == params(root, "c_split.ckpt"));
  const Checkpoint ck = load_checkpoint((root / "c_straight.ckpt").string());
  CHECK(ck.header.at("config").at("mask_channel") == "object");
  CHECK(ck.header.at("training").at("context").at("prob") == 1.0);
  CHECK(ck.header.at("training").at("context_backgrounds") == photos.string());
  CHECK(load_sdf_model((root / "c_straight.ckpt").string())->config().reads_context());
  // A banded network starts from the whole-image one; its band is recorded; a band the network lacks is refused.
  {
    SdfTrainSettings banded = st;
    banded.init = (root / "c_straight.ckpt").string();
    banded.net.context_band = banded.context.band = 4;
    banded.out = (root / "c_band.ckpt").string();
    banded.steps = 3;
    train_sdf(banded);
    CHECK(load_checkpoint(banded.out).header.at("config").at("context_band") == 4);
    banded.context.band = 0;
    banded.out = (root / "c_band_bad.ckpt").string();
    CHECK_THROWS_AS(train_sdf(banded), InvalidInput);
  }
  // The drawn backgrounds changed the training.
  st.context.prob = 0;
  st.context.mask_error = 0;
  st.out = (root / "c_white.ckpt").string();
  st.resume = false;
  train_sdf(st);
  CHECK(params(root, "c_straight.ckpt") != params(root, "c_white.ckpt"));
  // Mixes refused before anything is written: occlusion or the image-side mask error with an object channel, the
  // context options without one, a missing background folder.
  st.out = (root / "bad.ckpt").string();
  {
    SdfTrainSettings bad = st;
    bad.occlusion.kind = OcclusionAugmentSettings::Kind::kHalf;
    CHECK_THROWS_AS(train_sdf(bad), InvalidInput);
  }
  {
    SdfTrainSettings bad = st;
    bad.mask_error.prob = 0.5;
    CHECK_THROWS_AS(train_sdf(bad), InvalidInput);
  }
  {
    SdfTrainSettings bad = st;
    bad.net.mask_channel = SdfNetConfig::MaskChannel::kMissing;
    bad.context.prob = 0.5;
    CHECK_THROWS_AS(train_sdf(bad), InvalidInput);
  }
  {
    SdfTrainSettings bad = st;
    bad.context.prob = 0.5;
    bad.context_backgrounds = (root / "no_such_folder").string();
    CHECK_THROWS_AS(train_sdf(bad), IoError);
  }
  CHECK(!fs::exists(st.out));
  fs::remove_all(root);
}

TEST_CASE("train sdf CLI: the object-channel flags train, conflicting ones fail with one line before any file") {
  const fs::path root = make_torus_dataset("sdf_train_context_cli");
  const std::string base = "train sdf --data " + root.string() + " --val-split \"\" --steps 2 --batch 2 --points 64 "
                           "--encoder 4,6,8 --global 16 --point-mlp 8 --decoder 8 --val-every 2 --val-shapes 1 ";
  const std::string model = (root / "m.ckpt").string();
  const test::CliRun ok = test::run_sdfkit(base + "--object-channel --aug-context 1 --context-mask-error 1 "
                                           "--context-band 5 -o " + model + " --json");
  REQUIRE_MESSAGE(ok.code == 0, ok.err);
  const Json config = load_checkpoint(model).header.at("config");
  CHECK(config.at("mask_channel") == "object");
  CHECK(config.at("context_band") == 5);
  for (const std::string flag : {"--mask-channel --object-channel", "--context-band 5", "--aug-context 0.5",
                                 "--object-channel --occlusion half", "--object-channel --aug-mask-error 0.5"}) {
    CAPTURE(flag);
    const std::string bad = (root / "bad.ckpt").string();
    const test::CliRun r = test::run_sdfkit(base + flag + " -o " + bad);
    CHECK(r.code == 1);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(!fs::exists(bad));
  }
  // --ema: --json reports both validations, the progress line the raw one; a decay of 1 is a one-line error.
  const test::CliRun ema = test::run_sdfkit(base + "--ema 0.5 -o " + (root / "ema.ckpt").string() + " --json");
  REQUIRE_MESSAGE(ema.code == 0, ema.err);
  const Json j = Json::parse(ema.out);
  CHECK(j.at("val").at("loss").get<double>() != j.at("val_raw").at("loss").get<double>());
  CHECK(ema.err.find("(raw weights: loss") != std::string::npos);
  const test::CliRun one = test::run_sdfkit(base + "--ema 1 -o " + (root / "bad.ckpt").string());
  CHECK(one.code == 1);
  CHECK(std::count(one.err.begin(), one.err.end(), '\n') == 1);
  fs::remove_all(root);
}

namespace {

/// A two-stream model trained for 3 steps in ROOT/start.ckpt, and the settings that fine-tune it with a small critic
/// (14 px renders, weight 0.5).
SdfTrainSettings adversarial_run(const fs::path& root) {
  SdfTrainSettings st = tiny_run(root, SdfVariant::kTwoStream);
  st.steps = 3;
  st.out = (root / "start.ckpt").string();
  train_sdf(st);
  st.init = st.out;
  st.adversarial.critic.size = st.adversarial.render.size = 14;
  st.adversarial.critic.widths = {4, 4, 4, 4};
  st.adversarial.render.samples = 6;
  st.adversarial.weight = 0.5;
  return st;
}

}  // namespace

TEST_CASE("adversarial fine-tuning: the critic trains, its state resumes bit for bit, its gradient moves the net") {
  const fs::path root = make_torus_dataset("sdf_train_adversarial");
  SdfTrainSettings st = adversarial_run(root);
  st.occlusion.kind = OcclusionAugmentSettings::Kind::kHalf;
  st.occlusion.prob = 1.0;
  const SdfTrainResult r = straight_and_split(st, root, "a");
  CHECK(r.steps == 6);
  const Checkpoint a = load_checkpoint((root / "a_straight.ckpt").string());
  const Checkpoint b = load_checkpoint((root / "a_split.ckpt").string());
  CHECK(a.block("params") == b.block("params"));
  CHECK(a.block("critic_params") == b.block("critic_params"));
  CHECK(a.header.at("training").at("adversarial").at("weight") == 0.5);
  // The curve carries the two adversarial losses, finite on every logged row.
  std::ifstream csv(loss_curve_path((root / "a_straight.ckpt").string(), "csv"));
  std::string header;
  std::getline(csv, header);
  CHECK(header.find("adv_generator,adv_critic") != std::string::npos);
  // Weight 0 is plain training: the critic's gradient changed the network.
  st.adversarial.weight = 0;
  st.out = (root / "a_off.ckpt").string();
  st.resume = false;
  st.steps = 6;
  train_sdf(st);
  CHECK(params(root, "a_off.ckpt") != a.block("params"));
  CHECK_FALSE(load_checkpoint(st.out).has_block("critic_params"));
  // Render and critic must agree on the size.
  st.adversarial.weight = 0.5;
  st.adversarial.render.size = 28;
  CHECK_THROWS_AS(train_sdf(st), InvalidInput);
  fs::remove_all(root);
}

TEST_CASE("adversarial fine-tuning of a binary network renders its occupancy as the SDF model it starts from") {
  // A binary network adopted from a two-stream model has logit = -10 x the model's prediction, so the silhouette the
  // critic judges (value -logit / 10, negative inside) is the two-stream model's: the first step's generator loss
  // agrees. A render reading the logit as an SDF would show the object's complement.
  const fs::path root = make_torus_dataset("sdf_train_adversarial_binary");
  SdfTrainSettings st = adversarial_run(root);
  st.steps = 1;
  st.val_every = 1;
  auto first_generator_loss = [&](SdfVariant v, const std::string& name) {
    st.net.variant = v;
    st.out = (root / name).string();
    train_sdf(st);
    std::ifstream csv(loss_curve_path(st.out, "csv"));
    std::string header, row;
    std::getline(csv, header);
    std::getline(csv, row);
    auto cells = [](const std::string& line) {
      std::vector<std::string> out;
      std::stringstream in(line);
      for (std::string cell; std::getline(in, cell, ',');) out.push_back(cell);
      return out;
    };
    const std::vector<std::string> names = cells(header), values = cells(row);
    const auto at = std::find(names.begin(), names.end(), "adv_generator");
    REQUIRE(at != names.end());
    return std::stod(values.at(static_cast<size_t>(at - names.begin())));
  };
  const double sdf = first_generator_loss(SdfVariant::kTwoStream, "two_stream.ckpt");
  const double binary = first_generator_loss(SdfVariant::kBinary, "binary.ckpt");
  CHECK(std::isfinite(sdf));
  CHECK(binary == doctest::Approx(sdf).epsilon(1e-4));
  fs::remove_all(root);
}

TEST_CASE("a checkpoint of every variant loads back to the same predictions, damaged files are refused") {
  const fs::path dir = test::scratch_dir("sdf_models");
  fs::create_directories(dir);
  Rng rng(3);
  Eigen::VectorXf img(3 * 137 * 137);
  for (Eigen::Index i = 0; i < img.size(); ++i) img[i] = static_cast<float>(rng.uniform());
  PointsF pts(50, 3);
  for (Eigen::Index i = 0; i < pts.size(); ++i) pts.data()[i] = static_cast<float>(rng.uniform(-0.8, 0.8));
  const Camera cam = look_at(200, 28, 2.6);
  for (SdfVariant v : {SdfVariant::kTwoStream, SdfVariant::kOneStream, SdfVariant::kGlobalOnly, SdfVariant::kBinary}) {
    CAPTURE(to_string(v));
    SdfNet net(small_config(v));
    net.init(17);
    const std::string path = (dir / (to_string(v) + ".ckpt")).string();
    save_sdf_model(path, net, {{"note", "test"}});
    Json training;
    const auto back = load_sdf_model(path, &training);
    CHECK(back->config().variant == v);
    CHECK(training["note"] == "test");
    Eigen::VectorXf a, b;
    net.predict(net.encode(img.data(), cam), pts, a);
    back->predict(back->encode(img.data(), cam), pts, b);
    CHECK((a.array() == b.array()).all());
    // Flip one byte in the payload: the checksum catches it.
    std::string bytes = read_file(path);
    bytes[bytes.size() - 100] ^= 0x20;
    write_text_atomic(path, bytes);
    CHECK_THROWS_AS(load_sdf_model(path), IoError);
  }
  CHECK_THROWS_AS(load_sdf_model((dir / "missing.ckpt").string()), IoError);
  fs::remove_all(dir);
}
