#include "nets/sdf_train.h"

#include "core/error.h"
#include "core/random.h"
#include "nets/checkpoint.h"
#include "nets/denormals.h"
#include "nets/loss.h"
#include "nets/optim.h"
#include "nets/plot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit {

namespace {

constexpr int kLogEvery = 25;  // CSV rows: mean training loss over this many steps

std::string stem_path(const std::string& model) {
  fs::path p(model);
  return (p.parent_path() / p.stem()).string();
}

/// Loss of the variant (value; gradient into grad when not null).
double variant_loss(const SdfNetConfig& c, const Tensor& pred, const Tensor& sdf, Tensor* grad) {
  if (c.variant == SdfVariant::Binary) {
    Tensor target(sdf.shape);
    for (int64_t i = 0; i < sdf.size(); ++i) target[i] = sdf[i] - c.sdf_offset < 0.f ? 1.f : 0.f;
    return bce_with_logits_loss<float>(pred, target, grad);
  }
  SdfLossSettings ls;
  ls.scale = c.sdf_scale;
  ls.offset = c.sdf_offset;
  return sdf_weighted_l1_loss<float>(pred, sdf, grad, ls);
}

bool predicted_inside(const SdfNetConfig& c, float pred) {
  return c.variant == SdfVariant::Binary ? pred > 0.f : pred < 0.f;
}

std::vector<std::vector<double>> read_csv_numbers(const std::string& path, std::vector<std::string>* header) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  if (!in) return rows;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (first) {
      first = false;
      if (header) *header = cells;
      continue;
    }
    std::vector<double> r;
    for (const auto& c : cells) r.push_back(c.empty() ? std::nan("") : std::atof(c.c_str()));
    rows.push_back(std::move(r));
  }
  return rows;
}

std::string format_csv(const std::vector<std::string>& header, const std::vector<std::vector<double>>& rows) {
  std::ostringstream o;
  for (size_t i = 0; i < header.size(); ++i) o << (i ? "," : "") << header[i];
  o << '\n';
  o << std::setprecision(7);
  for (const auto& r : rows) {
    for (size_t i = 0; i < r.size(); ++i) {
      if (i) o << ',';
      if (std::isfinite(r[i])) o << r[i];
    }
    o << '\n';
  }
  return o.str();
}

}  // namespace

// ------------------------------------------------------------------------------------------------ model files
void save_sdf_model(const std::string& path, const SdfNet& net, const Json& training) {
  Checkpoint ck;
  ck.header["kind"] = "sdfkit-sdf-net";
  ck.header["config"] = net.config().to_json();
  ck.header["architecture"] = net.params().architecture();
  ck.header["n_params"] = net.n_params();
  ck.header["training"] = training;
  ck.set_block("params", net.params().values);
  save_checkpoint(path, ck);
}

std::unique_ptr<SdfNet> load_sdf_model(const std::string& path, Json* training) {
  const Checkpoint ck = load_checkpoint(path);
  if (ck.header.value("kind", std::string()) != "sdfkit-sdf-net")
    throw IoError(path + ": not an SDF network model (header kind is '" + ck.header.value("kind", std::string()) +
                  "')");
  if (!ck.header.contains("config")) throw IoError(path + ": SDF model without a configuration");
  SdfNetConfig config;
  try {
    config = SdfNetConfig::from_json(ck.header.at("config"));
  } catch (const IoError& e) {
    throw IoError(path + ": " + e.what());
  }
  auto net = std::make_unique<SdfNet>(config);
  const auto& p = ck.block("params", static_cast<long>(net->n_params()));
  std::copy(p.begin(), p.end(), net->params().values.begin());
  if (training) *training = ck.header.value("training", Json::object());
  return net;
}

// ------------------------------------------------------------------------------------------------ validation
SdfValidation validate_sdf(const SdfNet& net, const Dataset& data, int shapes, int points, uint64_t seed) {
  SdfValidation v;
  const SdfNetConfig& c = net.config();
  const int n_shapes = std::min<int>(shapes, static_cast<int>(data.size()));
  double loss = 0;
  long right = 0, total = 0, inter = 0, uni = 0;
  for (int s = 0; s < n_shapes; ++s) {
    PointsF pts;
    Eigen::VectorXf sdf;
    draw_samples(data.samples(s), points, Rng::mix(seed + 77 * static_cast<uint64_t>(s)), pts, sdf);
    const Eigen::VectorXf img = data.input(s, 0);
    const auto code = net.encode(img.data(), data.camera(s, 0));
    Eigen::VectorXf pred;
    net.predict(code, pts, pred);
    Tensor tp({1, pred.size()}), ts({1, sdf.size()});
    std::copy(pred.data(), pred.data() + pred.size(), tp.ptr());
    std::copy(sdf.data(), sdf.data() + sdf.size(), ts.ptr());
    loss += variant_loss(c, tp, ts, nullptr);
    for (Eigen::Index i = 0; i < pred.size(); ++i) {
      const bool gt_in = sdf[i] - c.sdf_offset < 0.f, pr_in = predicted_inside(c, pred[i]);
      right += gt_in == pr_in;
      inter += gt_in && pr_in;
      uni += gt_in || pr_in;
      ++total;
    }
  }
  v.shapes = n_shapes;
  v.loss = n_shapes ? loss / n_shapes : 0;
  v.sign_accuracy = total ? static_cast<double>(right) / total : 0;
  v.sample_iou = uni ? static_cast<double>(inter) / uni : 1.0;
  return v;
}


void jitter_cameras(std::vector<Camera>& cameras, double sigma_deg, uint64_t seed, long step) {
  Rng rng = Rng::derived(seed ^ 0x6a177e5ULL, static_cast<uint64_t>(step));
  for (Camera& c : cameras) {
    const double angle = rng.normal() * sigma_deg * M_PI / 180.0;
    c.R = c.R * Mat3(Eigen::AngleAxisd(angle, Vec3::UnitY()));
  }
}

// ------------------------------------------------------------------------------------------------ training
SdfTrainResult train_sdf(const SdfTrainSettings& st, const std::function<void(const SdfTrainEvent&)>& on_event) {
  flush_denormals_on_this_thread();  // same arithmetic from the first step, resumed or not
  require(!st.out.empty(), "train sdf: an output model path is required");
  require(st.steps > 0 && st.batch > 0 && st.points > 0, "train sdf: steps, batch and points must be positive");
  require(st.lr > 0 && std::isfinite(st.lr), "train sdf: learning rate must be positive");
  require(st.lr_steps >= 0, "train sdf: --lr-steps must be >= 0");
  require(st.net.image_size == kNetImageSize,
          "train sdf: the dataset reader produces " + std::to_string(kNetImageSize) + " px inputs");
  const auto t_start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(); };

  DatasetSettings ds;
  ds.root = st.data;
  ds.split = st.train_split;
  ds.max_shapes = st.max_shapes;
  Dataset train(ds);
  std::unique_ptr<Dataset> val_owned;
  const Dataset* val = &train;
  if (!st.val_split.empty()) {
    DatasetSettings vs = ds;
    vs.split = st.val_split;
    vs.max_shapes = st.val_shapes;
    val_owned = std::make_unique<Dataset>(vs);
    val = val_owned.get();
  }

  require(st.camera_jitter_deg >= 0 && st.camera_jitter_deg <= 180, "train sdf: --camera-jitter must be in [0, 180]");
  SdfNet net(st.net);
  net.allocate_grads(true);
  net.init(st.seed);
  if (!st.init.empty()) {
    const auto start = load_sdf_model(st.init);
    if (start->config().to_json() != st.net.to_json())
      throw InvalidInput(st.init + ": --init model has another configuration than the network being trained (" +
                         start->config().to_json().dump() + " vs " + st.net.to_json().dump() + ")");
    std::copy(start->params().values.begin(), start->params().values.end(), net.params().values.begin());
  }
  OptimizerSettings os;
  os.beta1 = 0.5;
  os.weight_decay = st.weight_decay;
  Optimizer opt(os, net.n_params());
  LrSchedule sched;
  sched.kind = st.lr_min < st.lr ? LrSchedule::Kind::Cosine : LrSchedule::Kind::Constant;
  sched.base = st.lr;
  sched.min_lr = st.lr_min;
  sched.total_steps = st.lr_steps > 0 ? st.lr_steps : st.steps;

  SdfTrainResult res;
  res.model = st.out;
  res.csv = stem_path(st.out) + ".loss.csv";
  res.plot = stem_path(st.out) + ".loss.svg";
  const std::vector<std::string> header = {"step", "train_loss", "lr", "seconds", "val_loss", "val_sign_accuracy",
                                           "val_sample_iou"};
  std::vector<std::vector<double>> rows;
  long step = 0;
  double seconds_before = 0;  // training time of earlier (resumed) runs

  const Json train_json = {{"data", st.data},          {"train_split", st.train_split}, {"batch", st.batch},
                           {"points", st.points},      {"lr", st.lr},                   {"lr_min", st.lr_min},
                           {"lr_steps", st.lr_steps},
                           {"weight_decay", st.weight_decay}, {"grad_clip", st.grad_clip},
                           {"seed", st.seed},          {"max_shapes", st.max_shapes},   {"steps", st.steps},
                           {"train_shapes", train.size()}, {"init", st.init},
                           {"camera_jitter_deg", st.camera_jitter_deg}};
  if (st.resume && fs::exists(st.out)) {
    const Checkpoint ck = load_checkpoint(st.out);
    require_header_match(ck, "config", st.net.to_json(), st.out);
    const auto& p = ck.block("params", static_cast<long>(net.n_params()));
    std::copy(p.begin(), p.end(), net.params().values.begin());
    ck.get_optimizer(opt);
    const Json& tr = ck.header.at("training");
    step = tr.at("step").get<long>();
    seconds_before = tr.value("seconds", 0.0);
    if (tr.value("seed", st.seed) != st.seed)
      throw InvalidInput(st.out + ": checkpoint was trained with seed " + std::to_string(tr.value("seed", 0ULL)) +
                         "; resume with the same --seed");
    std::vector<std::string> h;
    for (auto& r : read_csv_numbers(res.csv, &h))
      if (!r.empty() && r[0] <= static_cast<double>(step)) rows.push_back(std::move(r));
  }
  res.start_step = step;

  BatchSettings bs;
  bs.batch_size = st.batch;
  bs.points_per_shape = st.points;
  bs.seed = st.seed;
  BatchSampler sampler(train, bs);

  auto save = [&](long at_step, const SdfValidation& v) {
    Checkpoint ck;
    ck.header["kind"] = "sdfkit-sdf-net";
    ck.header["config"] = st.net.to_json();
    ck.header["architecture"] = net.params().architecture();
    ck.header["n_params"] = net.n_params();
    Json tr = train_json;
    tr["step"] = at_step;
    tr["seconds"] = seconds_before + elapsed();
    tr["val"] = {{"loss", v.loss}, {"sign_accuracy", v.sign_accuracy}, {"sample_iou", v.sample_iou},
                 {"shapes", v.shapes}};
    ck.header["training"] = tr;
    ck.set_block("params", net.params().values);
    ck.put_optimizer(opt);
    save_checkpoint(st.out, ck);
    write_text_atomic(res.csv, format_csv(header, rows));
    write_loss_plot_svg(res.plot, rows, header, {1, 4}, "SDF network: training and validation loss");
  };

  SdfNet::Workspace ws;
  Tensor images, points, sdf, pred, dpred;
  double interval_loss = 0;
  int interval_n = 0;
  const int S = kNetImageSize;
  while (step < st.steps) {
    SdfBatch b = sampler.batch(step);
    if (st.camera_jitter_deg > 0) jitter_cameras(b.cameras, st.camera_jitter_deg, st.seed, step);
    const int64_t B = b.size(), N = b.points_per_item;
    images.resize({B, 3, S, S});
    std::copy(b.images.data(), b.images.data() + b.images.size(), images.ptr());
    points.resize({B, N, 3});
    std::copy(b.points.data(), b.points.data() + b.points.size(), points.ptr());
    sdf.resize({B, N});
    std::copy(b.sdf.data(), b.sdf.data() + b.sdf.size(), sdf.ptr());
    net.forward(images, b.cameras, points, ws, pred);
    const double loss = variant_loss(st.net, pred, sdf, &dpred);
    if (!std::isfinite(loss)) throw Error("train sdf: loss became non-finite at step " + std::to_string(step));
    net.params().zero_grad();
    net.backward(ws, dpred);
    if (st.grad_clip > 0) clip_grad_norm(net.params().grads.data(), net.n_params(), st.grad_clip);
    const double lr = sched.at(step);
    opt.step(net.params().values.data(), net.params().grads.data(), lr);
    ++step;
    interval_loss += loss;
    ++interval_n;
    const bool out_of_time = st.time_limit_seconds > 0 && elapsed() >= st.time_limit_seconds;
    const bool do_val = step % std::max(1, st.val_every) == 0 || step == st.steps || out_of_time;
    SdfTrainEvent ev{step, st.steps, loss, lr, seconds_before + elapsed()};
    if (step % kLogEvery == 0 || do_val) {
      std::vector<double> row = {static_cast<double>(step), interval_loss / interval_n, lr, ev.seconds,
                                 std::nan(""), std::nan(""), std::nan("")};
      res.final_loss = interval_loss / interval_n;
      interval_loss = 0;
      interval_n = 0;
      if (do_val) {
        res.val = validate_sdf(net, *val, st.val_shapes, st.val_points, st.seed + 1);
        row[4] = res.val.loss;
        row[5] = res.val.sign_accuracy;
        row[6] = res.val.sample_iou;
        ev.validated = true;
        ev.val = res.val;
      }
      rows.push_back(row);
      if (do_val) save(step, res.val);
    }
    if (on_event) on_event(ev);
    if (out_of_time) break;
  }
  res.steps = step;
  res.seconds = elapsed();
  return res;
}

}  // namespace sdfkit
