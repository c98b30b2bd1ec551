#include "train/sdf_train.h"

#include "core/error.h"
#include "core/json.h"
#include "core/parallel.h"
#include "core/random.h"
#include "models/critic.h"
#include "nets/checkpoint.h"
#include "nets/comm.h"
#include "nets/denormals.h"
#include "nets/loss.h"
#include "nets/optim.h"
#include "nets/plot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <iomanip>
#include <sstream>

#include <tbb/parallel_for.h>

namespace fs = std::filesystem;

namespace sdfkit {

namespace {

constexpr int kLogEvery = 25;  // CSV rows: mean training loss over this many steps
/// --adversarial: silhouette rays whose prediction is within this many temperatures of 0 are differentiated.
constexpr double kActiveTemperatures = 6.0;
/// --init of a binary network from a two-stream model: logit = -10 x pred = -100 (sdf - 0.003) at the start, i.e.
/// probabilities 0.27-0.73 within 0.01 of the surface and saturated beyond 0.05.
constexpr float kBinaryFromSdfScale = 10.0f;

/// Loss of the variant (value; gradient into grad when not null).
double variant_loss(const SdfNetConfig& c, const Tensor& pred, const Tensor& sdf, Tensor* grad) {
  if (c.variant == SdfVariant::kBinary) {
    Tensor target(sdf.shape);
    for (int64_t i = 0; i < sdf.size(); ++i) target[i] = sdf[i] - c.sdf_offset < 0.f ? 1.f : 0.f;
    return bce_with_logits_loss<float>(pred, target, grad);
  }
  SdfLossSettings ls;
  ls.scale = c.sdf_scale;
  ls.offset = c.sdf_offset;
  return sdf_weighted_l1_loss<float>(pred, sdf, grad, ls);
}

/// --adversarial: the factor from the network's output to the value the silhouette render reads (negative inside,
/// in SDF-prediction units): 1 for an SDF network; -1 / kBinaryFromSdfScale for a binary one, whose logit is positive
/// inside and about -10 x an SDF network's prediction near the surface (adopt_as_binary), so the temperature keeps
/// its meaning.
float render_value_factor(const SdfNetConfig& c) {
  return c.variant == SdfVariant::kBinary ? -1.0f / kBinaryFromSdfScale : 1.0f;
}

bool predicted_inside(const SdfNetConfig& c, float pred) {
  return c.variant == SdfVariant::kBinary ? pred > 0.f : pred < 0.f;
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

}  // namespace

Json SdfAdversarialSettings::to_json() const {
  return {{"weight", weight},
          {"critic", critic.to_json()},
          {"render", {{"size", render.size}, {"radius", render.radius}, {"samples", render.samples},
                      {"refine", render.refine}}},
          {"temperature", temperature}};
}

namespace {

/// One channel (S * S, row by row) resized to R x R by area averaging (network_image of a grey image).
Eigen::VectorXf resize_channel(const float* values, int S, int R) {
  Image grey(S, S, 1);
  std::copy(values, values + static_cast<size_t>(S) * S, grey.data.begin());
  return network_image(grey, R).head(static_cast<Eigen::Index>(R) * R);
}

}  // namespace

// ------------------------------------------------------------------------------------------------ validation
SdfValidation validate_sdf(const SdfNet& net, const Dataset& data, int shapes, int points, uint64_t seed) {
  SdfValidation v;
  const SdfNetConfig& c = net.config();
  const int n_shapes = std::min<int>(shapes, static_cast<int>(data.size()));
  // One task per shape (image decoding, encoding and prediction); the per-shape figures are added in shape order.
  struct PerShape {
    double loss = 0;
    long right = 0, total = 0, inter = 0, uni = 0;
  };
  std::vector<PerShape> per(static_cast<size_t>(std::max(0, n_shapes)));
  parallel_for_ordered_errors(0, n_shapes, [&](int s) {  // a bad shape's error: the first one in list order
    flush_denormals_on_this_thread();
    PerShape& r = per[static_cast<size_t>(s)];
    PointsF pts;
    Eigen::VectorXf sdf;
    draw_samples(data.samples(s), points, Rng::mix(seed + 77 * static_cast<uint64_t>(s)), pts, sdf);
    // An object-channel network reads the object's exact mask on the white view.
    const Eigen::VectorXf rgb = data.input(s, 0);
    const Eigen::VectorXf object = c.reads_context() ? ink_mask(rgb) : Eigen::VectorXf();
    const Eigen::VectorXf img = network_input(rgb, c.reads_context() ? &object : nullptr, c.input_channels);
    const auto code = net.encode(img.data(), data.camera(s, 0));
    Eigen::VectorXf pred;
    net.predict(code, pts, pred);
    Tensor tp({1, pred.size()}), ts({1, sdf.size()});
    std::copy(pred.data(), pred.data() + pred.size(), tp.ptr());
    std::copy(sdf.data(), sdf.data() + sdf.size(), ts.ptr());
    r.loss = variant_loss(c, tp, ts, nullptr);
    for (Eigen::Index i = 0; i < pred.size(); ++i) {
      const bool gt_in = sdf[i] - c.sdf_offset < 0.f, pr_in = predicted_inside(c, pred[i]);
      r.right += gt_in == pr_in;
      r.inter += gt_in && pr_in;
      r.uni += gt_in || pr_in;
      ++r.total;
    }
  });
  double loss = 0;
  long right = 0, total = 0, inter = 0, uni = 0;
  for (const PerShape& r : per) {
    loss += r.loss;
    right += r.right;
    total += r.total;
    inter += r.inter;
    uni += r.uni;
  }
  v.shapes = n_shapes;
  v.loss = n_shapes ? loss / n_shapes : 0;
  v.sign_accuracy = total ? static_cast<double>(right) / total : 0;
  v.sample_iou = uni ? static_cast<double>(inter) / uni : 1.0;
  return v;
}

void jitter_cameras(std::vector<Camera>& cameras, double sigma_deg, uint64_t seed, long step, int first_item) {
  Rng rng = Rng::derived(seed ^ 0x6a177e5ULL, static_cast<uint64_t>(step));
  for (int skip = 0; skip < first_item; ++skip) (void)rng.normal();
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
  require(st.ema == 0 || (st.ema > 0 && st.ema < 1), "train sdf: --ema must be 0 (off) or a decay in (0, 1)");
  require(st.zoom.camera == ZoomAugmentSettings::CameraFollow::kFocal,
          "train sdf: the zoom augmentation must move the intrinsics (the network projects with the camera)");
  st.reframe.validate();
  st.mask_error.validate();
  st.context.validate();
  require(st.context.band == st.net.context_band,
          "train sdf: the context augmentation's band must be the network's (SdfNetConfig::context_band)");
  if (st.net.reads_context()) {
    require(!st.occlusion.enabled(), "train sdf: an object-channel network takes no --occlusion (its fourth channel "
                                     "is the object's mask, not the missing pixels')");
    require(!st.mask_error.enabled(), "train sdf: with an object-channel network the segmentation error goes to the "
                                      "mask channel (--context-mask-error), not --aug-mask-error");
  } else {
    require(st.context.prob == 0 && st.context.mask_error == 0 && st.context_backgrounds.empty(),
            "train sdf: --aug-context, --context-mask-error and --context-backgrounds need an object-channel network "
            "(--object-channel)");
  }
  std::unique_ptr<BackgroundSet> context_backgrounds;
  if (!st.context_backgrounds.empty()) context_backgrounds = std::make_unique<BackgroundSet>(st.context_backgrounds);
  require(st.reframe.camera == ZoomAugmentSettings::CameraFollow::kFocal,
          "train sdf: the reframing must move the intrinsics (the network projects with the camera)");
  const SdfAdversarialSettings& adv = st.adversarial;
  const float value_factor = render_value_factor(st.net);  // the render's reading of the network output
  if (adv.enabled()) {
    require(Comm::world().size() == 1, "train sdf: --adversarial runs in one process (no MPI ranks)");
    require(adv.render.size == adv.critic.size, "train sdf: the render and the critic need the same size");
    require(adv.temperature > 0, "train sdf: the silhouette temperature must be positive");
    (void)adv.critic.pools();  // validates the size
  }
  SdfNet net(st.net);
  net.allocate_grads(true);
  net.init(st.seed);
  if (!st.init.empty()) {
    const auto start = load_sdf_model(st.init);
    if (SdfNet::can_adopt(start->config(), st.net)) {
      net.adopt_parameters(*start);  // an RGB model for an RGB + mask network, or one without mirror features
    } else if (SdfNet::can_adopt_as_binary(start->config(), st.net)) {
      net.adopt_as_binary(*start, kBinaryFromSdfScale);  // a two-stream model turned into an occupancy classifier
    } else if (start->config().input_channels == 4 && st.net.reads_context() && [&] {
                 SdfNetConfig c = start->config();
                 c.mask_channel = st.net.mask_channel;
                 c.context_band = st.net.context_band;
                 return c.to_json() == st.net.to_json();
               }()) {
      // A missing-data-mask model (or another band's) for an object-channel network: the same weights, the fourth
      // channel re-learnt.
      std::copy(start->params().values.begin(), start->params().values.end(), net.params().values.begin());
    } else if (start->config().to_json() != st.net.to_json()) {
      throw InvalidInput(st.init + ": --init model has another configuration than the network being trained (" +
                         start->config().to_json().dump() + " vs " + st.net.to_json().dump() + ")");
    } else {
      std::copy(start->params().values.begin(), start->params().values.end(), net.params().values.begin());
    }
  }
  OptimizerSettings os;
  os.beta1 = 0.5;
  os.weight_decay = st.weight_decay;
  Optimizer opt(os, net.n_params());
  // The weights' moving average starts from the starting weights (--init's or the seeded ones).
  std::unique_ptr<WeightAverage> average;
  if (st.ema > 0) average = std::make_unique<WeightAverage>(st.ema, net.params().values.data(), net.n_params());
  LrSchedule sched;
  sched.kind = st.lr_min < st.lr ? LrSchedule::Kind::kCosine : LrSchedule::Kind::kConstant;
  sched.base = st.lr;
  sched.min_lr = st.lr_min;
  sched.total_steps = st.lr_steps > 0 ? st.lr_steps : st.steps;

  SdfTrainResult res;
  res.model = st.out;
  res.csv = loss_curve_path(st.out, "csv");
  res.plot = loss_curve_path(st.out, "svg");
  // Temporary files of a run killed while writing (core/files.h): nobody else will remove them.
  if (Comm::world().is_root())
    for (const std::string& path : {st.out, res.csv, res.plot}) remove_stale_temporaries(path);
  std::vector<std::string> header = {"step", "train_loss", "lr", "seconds", "val_loss", "val_sign_accuracy",
                                     "val_sample_iou"};
  // With the critic: the generator's adversarial loss and the critic's loss (mean over the logged steps).
  if (adv.enabled()) header.insert(header.end(), {"adv_generator", "adv_critic"});
  // With a weight average: the raw weights' validation (the other columns score the average).
  const size_t raw_column = header.size();
  if (average) header.insert(header.end(), {"val_loss_raw", "val_sign_accuracy_raw", "val_sample_iou_raw"});
  std::unique_ptr<PatchCritic> critic;
  if (adv.enabled()) critic = std::make_unique<PatchCritic>(adv.critic, st.seed ^ 0xc717c5ULL);
  std::vector<std::vector<double>> rows;
  long step = 0;
  double seconds_before = 0;  // training time of earlier (resumed) runs

  Json train_json = {{"data", st.data},          {"train_split", st.train_split}, {"batch", st.batch},
                           {"points", st.points},      {"lr", st.lr},                   {"lr_min", st.lr_min},
                           {"lr_steps", st.lr_steps},
                           {"weight_decay", st.weight_decay}, {"grad_clip", st.grad_clip},
                           {"seed", st.seed},          {"max_shapes", st.max_shapes},   {"steps", st.steps},
                           {"train_shapes", train.size()}, {"init", st.init},
                           {"camera_jitter_deg", st.camera_jitter_deg}, {"zoom", st.zoom.to_json()},
                           {"reframe", st.reframe.to_json()},
                           {"occlusion", st.occlusion.to_json()},
                           {"adversarial", adv.to_json()}};
  if (st.mask_error.enabled()) train_json["mask_error"] = st.mask_error.to_json();
  if (average) train_json["ema"] = st.ema;
  if (st.net.reads_context()) {
    train_json["context"] = st.context.to_json();
    train_json["context_backgrounds"] = st.context_backgrounds;
  }
  if (st.resume && fs::exists(st.out)) {
    Checkpoint ck = load_checkpoint(st.out);
    // A configuration written before a field existed reads as that field's default (SdfNetConfig::from_json).
    if (ck.header.contains("config")) {
      try {
        ck.header["config"] = SdfNetConfig::from_json(ck.header["config"]).to_json();
      } catch (const IoError&) {  // left as it is: require_header_match names the difference
      }
    }
    require_header_match(ck, "config", st.net.to_json(), st.out);
    const bool averaged = ck.header.contains("weight_average");
    if (averaged != (average != nullptr))
      throw InvalidInput(st.out + ": checkpoint was trained " +
                         (averaged ? "with --ema " + std::to_string(ck.header["weight_average"].value("decay", 0.0))
                                   : std::string("without --ema")) +
                         "; resume with the same --ema");
    // A model with a weight average holds the average as its parameters and the weights training continues as
    // raw_params.
    const auto& p = ck.block(averaged ? "raw_params" : "params", static_cast<long>(net.n_params()));
    std::copy(p.begin(), p.end(), net.params().values.begin());
    ck.get_optimizer(opt);
    if (average) {
      try {
        ck.get_average(*average);
      } catch (const IoError& e) {
        throw InvalidInput(st.out + ": " + e.what() + "; resume with the same --ema");
      }
    }
    const Json& tr = ck.header.at("training");
    step = tr.at("step").get<long>();
    seconds_before = tr.value("seconds", 0.0);
    if (tr.value("seed", st.seed) != st.seed)
      throw InvalidInput(st.out + ": checkpoint was trained with seed " + std::to_string(tr.value("seed", 0ULL)) +
                         "; resume with the same --seed");
    if (critic && ck.header.contains("critic_settings")) get_patch_critic(ck, *critic, "critic_", st.out);
    std::vector<std::string> h;
    for (auto& r : read_csv_numbers(res.csv, &h))
      if (!r.empty() && r[0] <= static_cast<double>(step)) {
        r.resize(header.size(), std::nan(""));  // rows of a run without the critic's columns
        rows.push_back(std::move(r));
      }
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
    if (average)
      tr["val_raw"] = {{"loss", res.val_raw.loss}, {"sign_accuracy", res.val_raw.sign_accuracy},
                       {"sample_iou", res.val_raw.sample_iou}, {"shapes", res.val_raw.shapes}};
    ck.header["training"] = tr;
    if (average) {
      ck.set_block("params", average->values());
      ck.set_block("raw_params", std::vector<float>(net.params().values.begin(), net.params().values.end()));
      ck.put_average(*average);
    } else {
      ck.set_block("params", std::vector<float>(net.params().values.begin(), net.params().values.end()));
    }
    ck.put_optimizer(opt);
    if (critic) put_patch_critic(ck, *critic, "critic_");
    // The curves first, the checkpoint last: a run killed in between resumes from the previous checkpoint and
    // drops the curve rows past it, so curve and checkpoint always agree.
    write_text_atomic(res.csv, format_csv(header, rows));
    write_loss_plot_svg(res.plot, rows, header, {1, 4}, "SDF network: training and validation loss");
    save_checkpoint(st.out, ck);
  };

  // Data-parallel steps (nets/comm.h): this rank's items [i0, i1) of every batch, one replica of the network per
  // item (sharing net's values, owning a gradient buffer), run in parallel; the step's gradient is the sum of the
  // item gradients in item order, the same bytes for any thread count and any number of ranks.
  const Comm& comm = Comm::world();
  require(comm.size() <= st.batch, "train sdf: more MPI ranks (" + std::to_string(comm.size()) +
                                       ") than items per batch (" + std::to_string(st.batch) + ")");
  const auto [i0, i1] = comm.item_range(st.batch);
  const int local = i1 - i0;
  struct Item {
    std::unique_ptr<SdfNet> net;
    SdfNet::Workspace ws;
    Tensor image, points, sdf, pred, dpred;
    double loss = 0;
    // --adversarial: the silhouette rays, the rendered coverage and its derivative by the network's output.
    FieldSilhouetteRays rays;
    std::vector<int> active;  // rays in the training forward (after the item's N samples, in this order)
    Eigen::VectorXf alpha, dalpha;
    Tensor pred_samples, dpred_samples;
  };
  std::vector<Item> items(static_cast<size_t>(local));
  std::vector<float*> item_grads;  // zero between steps: ordered_sum clears them
  for (Item& it : items) {
    it.net = std::make_unique<SdfNet>(st.net);
    it.net->params().share_values(net.params());
    item_grads.push_back(it.net->params().grads.data());
  }
  const float inv_batch = 1.0f / static_cast<float>(st.batch);
  // The next step's batch is read while this one trains.
  struct Loaded {
    SdfBatch batch;
    MatrixXfR silhouettes;  // --adversarial: the object's pixels (is_ink) before occlusion, B x (S * S)
  };
  auto load = [&sampler, &st, &context_backgrounds, i0 = i0, i1 = i1](long at) {
    Loaded l;
    SdfBatch& batch = l.batch;
    batch = sampler.batch(at, i0, i1);
    const uint64_t stream = static_cast<uint64_t>(at) * st.batch + i0;
    mask_error_images(batch.images, st.mask_error, st.seed, stream);
    zoom_images(batch.images, batch.cameras, st.zoom, st.seed, stream);
    reframe_images(batch.images, batch.cameras, st.reframe, st.seed, stream);
    if (st.adversarial.enabled()) {
      l.silhouettes.resize(batch.images.rows(), batch.images.cols() / 3);
      for (Eigen::Index b = 0; b < batch.images.rows(); ++b)
        l.silhouettes.row(b) = ink_mask(batch.images.row(b).transpose()).transpose();
    }
    occlude_images(batch.images, batch.masks, st.occlusion, st.seed, stream);
    if (st.net.reads_context())
      context_images(batch.images, batch.masks, st.context, context_backgrounds.get(), st.seed, stream);
    return l;
  };
  std::future<Loaded> next;
  if (step < st.steps) next = std::async(std::launch::async, load, step);

  double interval_loss = 0, interval_adv_g = 0, interval_adv_d = 0;
  int interval_n = 0;
  const int S = kNetImageSize, C = st.net.input_channels;
  while (step < st.steps) {
    Loaded loaded = next.get();
    SdfBatch& b = loaded.batch;
    if (step + 1 < st.steps) next = std::async(std::launch::async, load, step + 1);
    if (st.camera_jitter_deg > 0) jitter_cameras(b.cameras, st.camera_jitter_deg, st.seed, step, i0);
    const int64_t N = b.points_per_item;
    const int R = adv.render.size;
    const int64_t RR = adv.enabled() ? static_cast<int64_t>(R) * R : 0;
    tbb::parallel_for(0, local, [&](int k) {
      flush_denormals_on_this_thread();
      Item& it = items[static_cast<size_t>(k)];
      it.image.resize({1, C, S, S});
      std::copy(b.images.row(k).data(), b.images.row(k).data() + 3 * S * S, it.image.ptr());
      if (C == 4) std::copy(b.masks.row(k).data(), b.masks.row(k).data() + S * S, it.image.ptr() + 3 * S * S);
      const Camera& cam = b.cameras[static_cast<size_t>(k)];
      if (adv.enabled()) {
        // The silhouette rays' points of smallest predicted value (inference, not differentiated).
        const auto code = net.encode(it.image.ptr(), cam);
        it.rays = find_silhouette_points(cam, adv.render, [&](const PointsF& p, Eigen::VectorXf& v) {
          net.predict(code, p, v);
          v *= value_factor;
        });
      }
      // Only rays whose coverage can still move take part in the training forward: where |prediction| exceeds
      // kActiveTemperatures temperatures, d alpha / d prediction is below 0.25% of its peak and alpha stays the
      // search's value (a constant of the render).
      it.active.clear();
      if (RR)
        for (int64_t i = 0; i < RR; ++i)
          if (it.rays.hit[static_cast<size_t>(i)] && std::abs(it.rays.value[i]) < kActiveTemperatures * adv.temperature)
            it.active.push_back(static_cast<int>(i));
      const auto A = static_cast<int64_t>(it.active.size());
      it.points.resize({1, N + A, 3});
      std::copy(b.points.data() + 3 * k * N, b.points.data() + 3 * (k + 1) * N, it.points.ptr());
      for (int64_t a = 0; a < A; ++a)
        for (int d = 0; d < 3; ++d) it.points[3 * (N + a) + d] = it.rays.points(it.active[static_cast<size_t>(a)], d);
      it.sdf.resize({1, N});
      std::copy(b.sdf.data() + k * N, b.sdf.data() + (k + 1) * N, it.sdf.ptr());
      it.net->forward(it.image, {cam}, it.points, it.ws, it.pred);
      // The step's loss is the mean of the item losses: each item's gradient is weighted by 1 / batch.
      if (!RR) {
        it.loss = variant_loss(st.net, it.pred, it.sdf, &it.dpred);
        for (float& g : it.dpred.data) g *= inv_batch;
        it.net->backward(it.ws, it.dpred);
        return;
      }
      it.pred_samples.resize({1, N});
      std::copy(it.pred.ptr(), it.pred.ptr() + N, it.pred_samples.ptr());
      it.loss = variant_loss(st.net, it.pred_samples, it.sdf, &it.dpred_samples);
      Eigen::VectorXf value = it.rays.value;
      for (int64_t a = 0; a < A; ++a) value[it.active[static_cast<size_t>(a)]] = value_factor * it.pred[N + a];
      it.alpha = soft_coverage(it.rays, value, adv.temperature, &it.dalpha);
    });
    double adv_g = 0, adv_d = 0;
    if (adv.enabled()) {
      // The critic's inputs: the image as the network saw it (RGB, R x R) stacked with the render (fake) or the
      // unoccluded object's silhouette (real).
      Tensor fake({local, 4, R, R}), real({local, 4, R, R}), logits, dlogits, dfake;
      for (int k = 0; k < local; ++k) {
        const Eigen::VectorXf rgb = network_image(
            [&] {
              Image im(S, S, 3);
              for (int y = 0; y < S; ++y)
                for (int x = 0; x < S; ++x)
                  for (int c = 0; c < 3; ++c) im.at(x, y, c) = b.images(k, (c * S + y) * S + x);
              return im;
            }(),
            R);
        const Eigen::VectorXf sil = resize_channel(loaded.silhouettes.row(k).data(), S, R);
        std::copy(rgb.data(), rgb.data() + 3 * RR, fake.item(k));
        std::copy(rgb.data(), rgb.data() + 3 * RR, real.item(k));
        std::copy(items[static_cast<size_t>(k)].alpha.data(), items[static_cast<size_t>(k)].alpha.data() + RR,
                  fake.item(k) + 3 * RR);
        std::copy(sil.data(), sil.data() + RR, real.item(k) + 3 * RR);
      }
      // Generator: d (weight * BCE(critic(fake), 1)) / d render; then the critic's own step.
      critic->forward(fake, logits);
      adv_g = critic_loss(logits, 1.0f, &dlogits);
      critic->backward(fake, logits, dlogits, &dfake);
      critic->zero_grad();
      adv_d = critic_loss(logits, 0.0f, &dlogits);
      critic->backward(fake, logits, dlogits, nullptr);
      critic->forward(real, logits);
      adv_d += critic_loss(logits, 1.0f, &dlogits);
      critic->backward(real, logits, dlogits, nullptr);
      critic->step();
      tbb::parallel_for(0, local, [&](int k) {
        flush_denormals_on_this_thread();
        Item& it = items[static_cast<size_t>(k)];
        const auto A = static_cast<int64_t>(it.active.size());
        it.dpred.resize({1, N + A});
        for (int64_t i = 0; i < N; ++i) it.dpred[i] = it.dpred_samples[i] * inv_batch;
        const float* dr = dfake.item(k) + 3 * RR;
        for (int64_t a = 0; a < A; ++a) {
          const int i = it.active[static_cast<size_t>(a)];
          it.dpred[N + a] = static_cast<float>(adv.weight) * dr[i] * it.dalpha[i] * value_factor;
        }
        it.net->backward(it.ws, it.dpred);
      });
    }
    std::vector<double> mine;
    for (const Item& it : items) mine.push_back(it.loss);
    double loss = 0;
    for (const double l : comm.gather(mine)) loss += l;
    loss /= st.batch;
    interval_adv_g += adv_g;
    interval_adv_d += adv_d;
    if (!std::isfinite(loss)) throw Error("train sdf: loss became non-finite at step " + std::to_string(step));
    comm.ordered_sum(item_grads, net.params().grads.data(), net.n_params(), true);
    if (st.grad_clip > 0) clip_grad_norm(net.params().grads.data(), net.n_params(), st.grad_clip);
    const double lr = sched.at(step);
    opt.step(net.params().values.data(), net.params().grads.data(), lr);
    if (average) average->update(net.params().values.data());
    ++step;
    interval_loss += loss;
    ++interval_n;
    // Rank 0 decides when time is up, so that every rank stops after the same step.
    const bool out_of_time =
        st.time_limit_seconds > 0 && comm.broadcast(elapsed() >= st.time_limit_seconds);
    const bool do_val = step % std::max(1, st.val_every) == 0 || step == st.steps || out_of_time;
    SdfTrainEvent ev{step, st.steps, loss, lr, seconds_before + elapsed()};
    if (step % kLogEvery == 0 || do_val) {
      std::vector<double> row = {static_cast<double>(step), interval_loss / interval_n, lr, ev.seconds,
                                 std::nan(""), std::nan(""), std::nan("")};
      if (adv.enabled()) row.insert(row.end(), {interval_adv_g / interval_n, interval_adv_d / interval_n});
      row.resize(header.size(), std::nan(""));
      res.final_loss = interval_loss / interval_n;
      interval_loss = interval_adv_g = interval_adv_d = 0;
      interval_n = 0;
      if (do_val && comm.is_root()) {
        res.val = res.val_raw = validate_sdf(net, *val, st.val_shapes, st.val_points, st.seed + 1);
        if (average) {
          // The average in the network's place for its validation, then the raw weights back.
          std::vector<float> raw(net.params().values.begin(), net.params().values.end());
          std::copy(average->values().begin(), average->values().end(), net.params().values.begin());
          res.val = validate_sdf(net, *val, st.val_shapes, st.val_points, st.seed + 1);
          std::copy(raw.begin(), raw.end(), net.params().values.begin());
          row[raw_column] = res.val_raw.loss;
          row[raw_column + 1] = res.val_raw.sign_accuracy;
          row[raw_column + 2] = res.val_raw.sample_iou;
          ev.averaged = true;
        }
        row[4] = res.val.loss;
        row[5] = res.val.sign_accuracy;
        row[6] = res.val.sample_iou;
        ev.validated = true;
        ev.val = res.val;
        ev.val_raw = res.val_raw;
      }
      rows.push_back(row);
      if (do_val && comm.is_root()) save(step, res.val);
    }
    if (on_event) on_event(ev);
    if (out_of_time) break;
  }
  res.steps = step;
  res.seconds = elapsed();
  return res;
}

}  // namespace sdfkit
