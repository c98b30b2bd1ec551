#include "train/seg_train.h"

#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "core/random.h"
#include "nets/checkpoint.h"
#include "nets/denormals.h"
#include "nets/optim.h"
#include "nets/plot.h"

#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <numeric>

namespace fs = std::filesystem;

namespace sdfkit {
namespace {

constexpr uint64_t kValStream = 0x4000000000000000ULL;  // composite streams of the validation items

/// The seeded permutation of epoch e of n pairs (Fisher-Yates).
std::vector<long> epoch_permutation(uint64_t seed, long n, long e) {
  std::vector<long> p(static_cast<size_t>(n));
  std::iota(p.begin(), p.end(), 0L);
  Rng rng = Rng::derived(seed ^ 0x5e65e65eULL, static_cast<uint64_t>(e));
  for (long i = n - 1; i > 0; --i) std::swap(p[static_cast<size_t>(i)], p[rng.below(static_cast<uint64_t>(i) + 1)]);
  return p;
}

/// (shape index, view) of every pair of a dataset.
std::vector<std::pair<int, int>> dataset_pairs(const Dataset& d) {
  std::vector<std::pair<int, int>> pairs;
  for (size_t s = 0; s < d.size(); ++s)
    for (int v = 0; v < d.shape(s).num_views; ++v) pairs.emplace_back(static_cast<int>(s), v);
  return pairs;
}

Json settings_json(const SegTrainSettings& s, size_t backgrounds, size_t cutouts) {
  // What must not change across a resume (it would break the bit-exact continuation).
  Json j = {{"train_split", s.train_split},  {"backgrounds", s.backgrounds}, {"background_files", backgrounds},
          {"background_side", s.background_side}, {"composite", s.composite.to_json()}, {"steps", s.steps},
          {"batch", s.batch},              {"lr", s.lr},                   {"lr_min", s.lr_min},
          {"beta1", s.beta1},              {"weight_decay", s.weight_decay}, {"grad_clip", s.grad_clip},
          {"iou_weight", s.iou_weight},    {"max_shapes", s.max_shapes},   {"seed", s.seed},
          {"init", s.init}};
  // Only when on, so that the training states of runs made before the option still resume.
  if (s.thin_weight != 1.0) {
    j["thin_weight"] = s.thin_weight;
    j["thin_radius"] = s.thin_radius;
  }
  if (!s.cutouts.empty()) {
    j["cutouts"] = s.cutouts;
    j["cutout_files"] = cutouts;
  }
  return j;
}

/// A composite as network input and label tensors (item 0 of 1 x 3 x S x S and 1 x 1 x S x S).
void to_tensors(const SegSample& smp, Tensor& x, Tensor& y) {
  const int S = smp.image.width;
  x.resize({1, 3, S, S});
  put_network_rgb(smp.image, x, 0);
  y.resize({1, 1, S, S});
  std::copy(smp.label.data.begin(), smp.label.data.end(), y.data.begin());
}

struct ValItem {
  Tensor x, y;
  int x0 = 0, y0 = 0, w = 0, h = 0;
};

SegScores validate(const std::vector<SegNet*>& nets, const std::vector<ValItem>& items, double iou_weight) {
  const size_t n = items.size(), R = nets.size();
  std::vector<double> loss(n), iou(n);
  tbb::parallel_for(size_t(0), R, [&](size_t r) {
    flush_denormals_on_this_thread();
    for (size_t k = r; k < n; k += R) {
      const ValItem& it = items[k];
      const Tensor& z = nets[r]->forward(it.x, false);
      loss[k] = segmentation_loss(z, it.y, iou_weight, nullptr);
      std::vector<float> p(static_cast<size_t>(z.size()));
      for (int64_t i = 0; i < z.size(); ++i) p[static_cast<size_t>(i)] = 1.0f / (1.0f + std::exp(-z[i]));
      iou[k] = mask_iou(p.data(), it.y.ptr(), static_cast<int>(it.y.dim(3)), it.x0, it.y0, it.w, it.h);
    }
  });
  SegScores s;
  for (size_t k = 0; k < n; ++k) {
    s.loss += loss[k];
    s.iou += iou[k];
  }
  s.items = static_cast<long>(n);
  if (n > 0) {
    s.loss /= static_cast<double>(n);
    s.iou /= static_cast<double>(n);
  }
  return s;
}

void write_curve(const std::string& csv, const std::string& svg, const Json& curve) {
  std::vector<std::vector<double>> rows;
  for (const auto& r : curve) {
    std::vector<double> row;
    for (const auto& v : r) row.push_back(v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>());
    rows.push_back(row);
  }
  write_text_atomic(csv, format_csv({"step", "train_loss", "val_loss", "val_iou", "lr", "seconds"}, rows));
  write_loss_plot_svg(svg, rows, {"step", "train loss", "val loss", "val mask IoU"}, {1, 2, 3},
                      "segmenter: loss and validation IoU (log scale)");
}

}  // namespace

double mask_iou(const float* prob, const float* label, int size, int x0, int y0, int w, int h) {
  long inter = 0, uni = 0;
  for (int y = std::max(0, y0); y < std::min(size, y0 + h); ++y)
    for (int x = std::max(0, x0); x < std::min(size, x0 + w); ++x) {
      const size_t i = static_cast<size_t>(y) * size + x;
      const bool p = prob[i] >= 0.5f, t = label[i] >= 0.5f;
      inter += (p && t) ? 1 : 0;
      uni += (p || t) ? 1 : 0;
    }
  return uni == 0 ? 1.0 : static_cast<double>(inter) / static_cast<double>(uni);
}

long seg_item_pair(uint64_t seed, long n, long g) {
  require(n > 0 && g >= 0, "segmenter items: need pairs and a non-negative item number");
  return epoch_permutation(seed, n, g / n)[static_cast<size_t>(g % n)];
}

SegTrainResult train_seg(const SegTrainSettings& settings, const std::function<void(const SegTrainEvent&)>& on_event) {
  flush_denormals_on_this_thread();
  SegTrainSettings s = settings;
  s.composite.size = s.net.size;
  require(!s.data.empty() && !s.out.empty(), "train seg: --data and -o are required");
  require(s.steps > 0 && s.batch > 0 && s.val_every > 0 && s.val_items > 0,
          "train seg: steps, batch, val-every and val-items must be positive");
  require(s.lr > 0 && s.lr_min >= 0 && s.lr_min <= s.lr, "train seg: need 0 <= lr-min <= lr, lr > 0");
  require(s.iou_weight >= 0 && std::isfinite(s.iou_weight), "train seg: the IoU weight must be >= 0");
  require(s.thin_weight >= 1 && std::isfinite(s.thin_weight), "train seg: the thin-part weight must be >= 1");
  require(s.thin_radius >= 1 && s.thin_radius <= 8, "train seg: the thin-part radius must be in [1, 8] px");
  s.composite.validate();
  require(s.composite.cutouts == 0 || !s.cutouts.empty(),
          "train seg: cut-outs need a set of cut-out images (--cutouts)");
  require(s.cutouts.empty() || s.composite.cutouts > 0, "train seg: --cutouts applies with --cutout-prob above 0");
  SegNet net(s.net, true);  // checks the architecture before any data is read
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };

  DatasetSettings ds;
  ds.root = s.data;
  ds.split = s.train_split;
  ds.max_shapes = s.max_shapes;
  const Dataset train(ds);
  DatasetSettings vs = ds;
  vs.split = s.val_split;
  vs.max_shapes = 0;
  const Dataset val = s.val_split.empty() ? Dataset(ds) : Dataset(vs);
  const auto train_pairs = dataset_pairs(train), val_pairs = dataset_pairs(val);
  require(!train_pairs.empty(), s.data + ": the training split has no views");
  require(!val_pairs.empty(), s.data + ": the validation split has no views");
  const BackgroundSet backgrounds = s.backgrounds.empty() ? BackgroundSet() : BackgroundSet(s.backgrounds, s.background_side);
  const BackgroundSet val_backgrounds =
      s.val_backgrounds.empty() ? BackgroundSet() : BackgroundSet(s.val_backgrounds, s.background_side);
  const BackgroundSet& val_photos = s.val_backgrounds.empty() ? backgrounds : val_backgrounds;
  const BackgroundSet cutouts = s.cutouts.empty() ? BackgroundSet() : BackgroundSet(s.cutouts, s.background_side, true);

  // The validation composites, once: item k shows a seeded pair on the background drawn from stream kValStream + k.
  std::vector<ValItem> val_items(static_cast<size_t>(s.val_items));
  {
    Rng rng = Rng::derived(s.seed, 0x5e9a1);
    std::vector<std::pair<int, int>> chosen;
    for (int k = 0; k < s.val_items; ++k) chosen.push_back(val_pairs[rng.below(val_pairs.size())]);
    parallel_for_ordered_errors(0, s.val_items, [&](int k) {  // a bad view's error: the first one in order
      const auto [shape, view] = chosen[static_cast<size_t>(k)];
      const SegSample smp = make_composite(val.image(static_cast<size_t>(shape), view), &val_photos, s.composite,
                                           s.seed, kValStream + static_cast<uint64_t>(k));
      ValItem& it = val_items[static_cast<size_t>(k)];
      to_tensors(smp, it.x, it.y);
      it.x0 = smp.canvas_x0, it.y0 = smp.canvas_y0, it.w = smp.canvas_width, it.h = smp.canvas_height;
    });
  }

  net.init(s.seed);
  if (!s.init.empty()) {
    const auto start = load_seg_model(s.init);
    if (start->architecture() == net.architecture()) {
      std::copy(start->params().values.begin(), start->params().values.end(), net.params().values.begin());
    } else if (s.net.fine > 0 && start->config().fine == 0) {
      try {
        net.start_from_coarse(*start);  // the fine branch added to a trained network, disconnected at first
      } catch (const InvalidInput&) {
        throw InvalidInput(s.init + ": --init model has other settings than the network being trained (besides the "
                           "fine branch)");
      }
    } else {
      throw InvalidInput(s.init + ": --init model has another architecture than the network being trained");
    }
  }
  OptimizerSettings os;
  os.beta1 = s.beta1;
  os.weight_decay = s.weight_decay;
  Optimizer opt(os, net.n_params());
  LrSchedule lr;
  lr.kind = LrSchedule::Kind::kCosine;
  lr.base = s.lr;
  lr.min_lr = s.lr_min;
  lr.total_steps = s.steps;

  const std::string state_path = s.out + ".train.ckpt";
  SegTrainResult result;
  result.model = s.out;
  result.csv = loss_curve_path(s.out, "csv");
  result.plot = loss_curve_path(s.out, "svg");
  result.train_items = static_cast<long>(train_pairs.size());
  result.backgrounds = static_cast<long>(backgrounds.size());
  result.val_backgrounds = static_cast<long>(val_backgrounds.size());
  result.cutouts = static_cast<long>(cutouts.size());
  for (const std::string& path : {state_path, s.out, result.csv, result.plot}) remove_stale_temporaries(path);
  const Json settings_record = settings_json(s, backgrounds.size(), cutouts.size());
  long step = 0;
  double prior_seconds = 0;
  Json curve = Json::array();
  if (s.resume && fs::exists(state_path)) {
    const Checkpoint ck = load_checkpoint(state_path);
    if (ck.header.value("kind", std::string()) != "seg_training_state")
      throw IoError(state_path + ": not a segmenter training state");
    require_header_match(ck, "architecture", net.architecture(), state_path);
    require_header_match(ck, "settings", settings_record, state_path);
    TrainingProgress done = restore_training_state(ck, net.params().values.data(), net.n_params(), opt);
    step = done.step;
    prior_seconds = done.seconds;
    curve = std::move(done.curve);
  }
  result.start_step = step;

  // One replica per item of a batch: each reads net's values and owns its activations and gradient buffer.
  std::vector<std::unique_ptr<SegNet>> replicas;
  std::vector<SegNet*> replica_ptrs;
  for (int k = 0; k < s.batch; ++k) {
    replicas.push_back(std::make_unique<SegNet>(s.net, true));
    replicas.back()->share_parameters(net);
    replica_ptrs.push_back(replicas.back().get());
  }
  const long n_pairs = static_cast<long>(train_pairs.size());
  long cached_epoch = -1;
  std::vector<long> perm;
  std::vector<double> item_loss(static_cast<size_t>(s.batch));
  const double inv_batch = 1.0 / s.batch;
  bool stop = false;
  while (step < s.steps && !stop) {
    // The batch's pairs (in item order), then every item in parallel on its replica.
    std::vector<std::pair<int, int>> items;
    for (int b = 0; b < s.batch; ++b) {
      const long g = step * s.batch + b;
      if (g / n_pairs != cached_epoch) {
        cached_epoch = g / n_pairs;
        perm = epoch_permutation(s.seed, n_pairs, cached_epoch);
      }
      items.push_back(train_pairs[static_cast<size_t>(perm[static_cast<size_t>(g % n_pairs)])]);
    }
    parallel_for_ordered_errors(0, s.batch, [&](int b) {  // a bad view's error: the first one in batch order
      flush_denormals_on_this_thread();
      const auto [shape, view] = items[static_cast<size_t>(b)];
      const uint64_t g = static_cast<uint64_t>(step) * static_cast<uint64_t>(s.batch) + static_cast<uint64_t>(b);
      const SegSample smp =
          make_composite(train.image(static_cast<size_t>(shape), view), &backgrounds, s.composite, s.seed, g, &cutouts);
      Tensor x, y, dz;
      to_tensors(smp, x, y);
      SegNet& r = *replicas[static_cast<size_t>(b)];
      const Tensor& z = r.forward(x, true);
      const bool thin = s.thin_weight != 1.0;
      const Tensor w = thin ? thin_part_weights(y, s.thin_weight, s.thin_radius) : Tensor();
      item_loss[static_cast<size_t>(b)] = segmentation_loss(z, y, s.iou_weight, &dz, nullptr, thin ? &w : nullptr);
      for (float& v : dz.data) v *= static_cast<float>(inv_batch);
      r.backward(dz);
    });
    // The step's gradient: 0 + g_0 + g_1 + ... in item order; the replicas' buffers are cleared for the next step.
    auto& grads = net.params().grads;
    std::fill(grads.begin(), grads.end(), 0.0f);
    double loss = 0;
    for (int b = 0; b < s.batch; ++b) {
      auto& g = replicas[static_cast<size_t>(b)]->params().grads;
      for (size_t i = 0; i < grads.size(); ++i) grads[i] += g[i];
      std::fill(g.begin(), g.end(), 0.0f);
      loss += item_loss[static_cast<size_t>(b)];
    }
    loss *= inv_batch;
    if (s.grad_clip > 0) clip_grad_norm(grads.data(), grads.size(), s.grad_clip);
    const double rate = lr.at(step);
    opt.step(net.params().values.data(), grads.data(), rate);
    ++step;
    if (s.time_limit_seconds > 0 && elapsed() > s.time_limit_seconds) stop = true;
    SegTrainEvent ev{step, s.steps, loss, rate, prior_seconds + elapsed()};
    Json row = {step, loss, nullptr, nullptr, rate, ev.seconds};
    if (step % s.val_every == 0 || step == s.steps || stop) {
      ev.validated = true;
      ev.val = validate(replica_ptrs, val_items, s.iou_weight);
      result.val = ev.val;
      row[2] = ev.val.loss;
      row[3] = ev.val.iou;
      curve.push_back(row);
      Json training = {{"step", step},         {"seconds", ev.seconds}, {"val_loss", ev.val.loss},
                       {"val_iou", ev.val.iou}, {"settings", settings_record}, {"data", s.data},
                       {"val_split", s.val_split}};
      if (!s.val_backgrounds.empty()) training["val_backgrounds"] = s.val_backgrounds;
      save_checkpoint(state_path, training_state_checkpoint("seg_training_state", net.architecture(), settings_record,
                                                            {step, ev.seconds, curve}, net.params().values.data(),
                                                            net.n_params(), opt));
      save_seg_model(s.out, net, training);
      write_curve(result.csv, result.plot, curve);
    } else {
      curve.push_back(row);
    }
    if (on_event) on_event(ev);
  }
  result.steps = step;
  result.seconds = elapsed();
  result.total_seconds = prior_seconds + result.seconds;
  return result;
}

}  // namespace sdfkit
