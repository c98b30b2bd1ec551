#include "train/pose_train.h"

#include "core/json.h"
#include "core/parallel.h"
#include "nets/checkpoint.h"
#include "nets/comm.h"
#include "nets/denormals.h"
#include "nets/plot.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <atomic>
#include <tuple>
#include <future>
#include <mutex>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace fs = std::filesystem;

namespace sdfkit {
namespace {

Json settings_json(const PoseTrainSettings& s) {
  // What must not change across a resume (changing it would break the bit-exact continuation). Keys of newer options
  // appear only when they are used, so that states written before them still resume.
  Json j = {{"train_split", s.train_split}, {"steps", s.steps},   {"batch", s.batch},
            {"points", s.points},           {"lr", s.lr},         {"lr_min", s.lr_min},
            {"beta1", s.beta1},             {"weight_decay", s.weight_decay}, {"grad_clip", s.grad_clip},
            {"max_shapes", s.max_shapes},   {"seed", s.seed}, {"augment", s.augment.to_json()},
            {"init", s.init}, {"azimuth_weight", s.azimuth_weight}, {"symmetries", s.symmetry_tag},
            {"zoom", s.zoom.to_json()}};
  if (s.reframe.enabled()) j["reframe"] = s.reframe.to_json();
  if (s.mask_error.enabled()) j["mask_error"] = s.mask_error.to_json();
  if (s.net.centre_head) j["centre_weight"] = s.centre_weight;
  if (s.ema > 0) j["ema"] = s.ema;
  return j;
}

std::vector<PointsF> split_points(const SdfBatch& batch) {
  std::vector<PointsF> pts(static_cast<size_t>(batch.size()));
  const int N = batch.points_per_item;
  for (int b = 0; b < batch.size(); ++b) pts[b] = batch.points.middleRows(static_cast<Eigen::Index>(b) * N, N);
  return pts;
}

Points to_double(const PointsF& p) { return p.cast<double>(); }

using SymmetrySource = std::function<std::vector<Mat3>(const ShapeEntry&)>;

/// Each entry's symmetry group from `source` (empty groups without one), asked once per shape folder and for
/// several shapes at once: a list that names a shape several times (to draw it more often) shares the first entry's
/// group. *first_entries (when given) gets the first entry of each shape.
std::vector<std::vector<Mat3>> symmetry_groups(const Dataset& data, const SymmetrySource& source,
                                               std::vector<size_t>* first_entries = nullptr) {
  std::vector<std::vector<Mat3>> groups(data.size());
  std::vector<size_t> unique, first_of(data.size());
  std::map<std::string, size_t> first;
  for (size_t i = 0; i < data.size(); ++i) {
    const auto [it, fresh] = first.emplace(data.shape(i).dir, i);
    first_of[i] = it->second;
    if (fresh) unique.push_back(i);
  }
  if (source) {
    // A failing shape's error is the first failing shape's in list order, whatever the scheduling.
    parallel_for_ordered_errors(size_t(0), unique.size(),
                                [&](size_t k) { groups[unique[k]] = source(data.shape(unique[k])); });
    for (size_t i = 0; i < data.size(); ++i)
      if (first_of[i] != i) groups[i] = groups[first_of[i]];
  }
  if (first_entries) *first_entries = std::move(unique);
  return groups;
}

struct ValSet {
  MatrixXfR images;
  std::vector<PointsF> points;
  std::vector<Camera> cameras;
};

ValSet make_val_set(const Dataset& data, int items, int points, uint64_t seed) {
  ValSet v;
  std::vector<std::pair<int, int>> pairs;
  Rng rng = Rng::derived(seed, 0x7a1);
  const int n = static_cast<int>(data.size());
  for (int k = 0; k < items; ++k) {
    const int s = k % n;
    const int views = std::max(1, data.shape(s).num_views);
    pairs.emplace_back(s, static_cast<int>(rng.below(static_cast<uint64_t>(views))));
  }
  v.images.resize(items, 3 * kNetImageSize * kNetImageSize);
  for (int k = 0; k < items; ++k) {
    const auto [s, view] = pairs[k];
    v.images.row(k) = data.input(s, view).transpose();
    v.cameras.push_back(data.camera(s, view));
    PointsF p;
    Eigen::VectorXf d;
    draw_samples(data.samples(s), points, Rng::mix(seed + 1000003ULL * static_cast<uint64_t>(s)), p, d);
    v.points.push_back(p);
  }
  return v;
}

PoseScores score_batch(PoseNet& net, const MatrixXfR& images, const std::vector<PointsF>& points,
                       const std::vector<Camera>& truth, std::vector<PoseErrors>* each = nullptr,
                       std::vector<double>* losses = nullptr, std::vector<Camera>* predicted = nullptr) {
  const PosePrediction p = net.predict(images);
  if (predicted) *predicted = p.cameras;
  PoseScores sc;
  for (size_t b = 0; b < p.cameras.size(); ++b) {
    const PoseErrors e = pose_errors(to_double(points[b]), p.cameras[b], truth[b]);
    const double l = pose_point_loss(p.cameras[b].R, p.cameras[b].t.z(), points[b], truth[b], nullptr, nullptr);
    sc.loss += l;
    if (losses) losses->push_back(l);
    sc.d3d += e.d3d;
    sc.d2d += e.d2d;
    ++sc.items;
    if (each) each->push_back(e);
  }
  return sc;
}

/// Validation scores, one item at a time on the replicas in parallel (item k on replica k mod R); the item scores
/// are added in item order.
PoseScores validate(const std::vector<PoseNet*>& nets, const ValSet& v) {
  const auto n = static_cast<size_t>(v.images.rows()), R = nets.size();
  std::vector<PoseScores> each(n);
  tbb::parallel_for(size_t(0), R, [&](size_t r) {
    flush_denormals_on_this_thread();
    for (size_t k = r; k < n; k += R) {
      const auto i = static_cast<Eigen::Index>(k);
      each[k] = score_batch(*nets[r], v.images.middleRows(i, 1), {v.points[k]}, {v.cameras[k]});
    }
  });
  PoseScores total;
  for (const PoseScores& s : each) {
    total.loss += s.loss;
    total.d3d += s.d3d;
    total.d2d += s.d2d;
    total.items += s.items;
  }
  if (total.items > 0) {
    total.loss /= static_cast<double>(total.items);
    total.d3d /= static_cast<double>(total.items);
    total.d2d /= static_cast<double>(total.items);
  }
  return total;
}

/// Rows: step, train loss, val L_cam, d3D, d2D, lr, seconds, and with a weight average the raw weights' d3D, d2D.
void write_curve(const std::string& csv, const std::string& svg, const Json& curve, bool averaged) {
  std::ostringstream o;
  o << "step,train_loss,val_loss,val_d3d,val_d2d,lr,seconds" << (averaged ? ",val_d3d_raw,val_d2d_raw" : "") << "\n";
  std::vector<std::vector<double>> rows;
  for (const auto& r : curve) {
    std::vector<double> row;
    for (size_t c = 0; c < r.size(); ++c) {
      const double v = r[c].is_null() ? std::numeric_limits<double>::quiet_NaN() : r[c].get<double>();
      row.push_back(v);
      if (c) o << ',';
      if (std::isfinite(v)) o << std::setprecision(8) << v;
    }
    o << '\n';
    rows.push_back(row);
  }
  write_text_atomic(csv, o.str());
  if (averaged)
    write_loss_plot_svg(svg, rows,
                        {"step", "train L_cam", "val L_cam (average)", "val d3D (average)", "val d2D (px, average)", "lr",
                         "seconds", "val d3D (raw)", "val d2D (px, raw)"},
                        {1, 2, 3, 4, 8}, "pose network: loss (log scale)");
  else
    write_loss_plot_svg(svg, rows, {"step", "train L_cam", "val L_cam", "val d3D", "val d2D (px)"}, {1, 2, 3, 4},
                        "pose network: loss (log scale)");
}

}  // namespace

PoseTrainSettings shipped_pose_recipe() {
  PoseTrainSettings s;
  s.steps = 28000;
  s.net.width = 32;
  s.net.azimuth_bins = 36;
  s.azimuth_weight = 0.1;
  return s;
}

PoseTrainResult train_pose(const PoseTrainSettings& s, const std::function<void(const PoseTrainEvent&)>& on_event) {
  flush_denormals_on_this_thread();  // same arithmetic from the first step, resumed or not
  require(!s.data.empty() && !s.out.empty(), "train pose: --data and -o are required");
  require(s.steps > 0 && s.batch > 0 && s.points > 0 && s.val_every > 0 && s.val_items > 0,
          "train pose: steps, batch, points, val-every and val-items must be positive");
  require(s.lr > 0 && s.lr_min >= 0 && s.lr_min <= s.lr, "train pose: need 0 <= lr-min <= lr, lr > 0");
  require(s.azimuth_weight >= 0 && std::isfinite(s.azimuth_weight), "train pose: the azimuth weight must be >= 0");
  require(s.azimuth_weight == 0 || s.net.azimuth_bins > 0, "train pose: --azimuth-weight needs --azimuth-bins > 0");
  s.reframe.validate();
  s.mask_error.validate();
  require(!s.reframe.enabled() || s.net.centre_head,
          "train pose: --aug-reframe needs --centre-head (the reframed images' principal point is off the centre)");
  require(s.reframe.camera == ZoomAugmentSettings::CameraFollow::kDistance,
          "train pose: the reframing must move the distance (the network's focal length is DISN's)");
  require(s.centre_weight >= 0 && std::isfinite(s.centre_weight), "train pose: the centre weight must be >= 0");
  require(s.ema == 0 || (s.ema > 0 && s.ema < 1), "train pose: --ema must be 0 (off) or a decay in (0, 1)");
  PoseNet net(s.net, true);  // checks the network settings before any data is read
  const auto t0 = std::chrono::steady_clock::now();
  DatasetSettings ds;
  ds.root = s.data;
  ds.split = s.train_split;
  ds.max_shapes = s.max_shapes;
  const Dataset train(ds);
  require(train.size() > 0, s.data + ": the training split has no shapes");
  DatasetSettings vs = ds;
  vs.split = s.val_split;
  vs.max_shapes = 0;
  const Dataset val = s.val_split.empty() ? Dataset(ds) : Dataset(vs);
  require(val.size() > 0, s.data + ": the validation split has no shapes");
  const ValSet val_set = make_val_set(val, s.val_items, s.points, s.seed);

  BatchSettings bs;
  bs.batch_size = s.batch;
  bs.points_per_shape = s.points;
  bs.seed = s.seed;
  const BatchSampler sampler(train, bs);
  // Each training shape's symmetry group (read from its files by the caller's function).
  std::vector<size_t> unique;  // the first entry of each shape
  const std::vector<std::vector<Mat3>> groups = symmetry_groups(train, s.symmetries, &unique);

  net.init(s.seed);
  if (!s.init.empty()) {
    const auto start = load_pose_model(s.init);
    if (start->architecture() == net.architecture()) {
      std::copy(start->params().values.begin(), start->params().values.end(), net.params().values.begin());
    } else {
      try {
        net.adopt_parameters(*start);  // another distance range only
      } catch (const InvalidInput& e) {
        throw InvalidInput(s.init + ": --init model has another architecture than the network being trained (" +
                           e.what() + ")");
      }
    }
  }
  OptimizerSettings os;
  os.beta1 = s.beta1;
  os.weight_decay = s.weight_decay;
  Optimizer opt(os, net.n_params());
  // The weights' moving average starts from the starting weights (--init's or the seeded ones).
  std::unique_ptr<WeightAverage> average;
  if (s.ema > 0) average = std::make_unique<WeightAverage>(s.ema, net.params().values.data(), net.n_params());
  LrSchedule lr;
  lr.kind = LrSchedule::Kind::kCosine;
  lr.base = s.lr;
  lr.min_lr = s.lr_min;
  lr.total_steps = s.steps;

  const std::string state_path = s.out + ".train.ckpt";
  PoseTrainResult result;
  for (const size_t i : unique) result.symmetric_shapes += groups[i].empty() ? 0 : 1;
  result.model = s.out;
  result.csv = loss_curve_path(s.out, "csv");
  result.plot = loss_curve_path(s.out, "svg");
  // Temporary files of a run killed while writing (core/files.h): nobody else will remove them.
  if (Comm::world().is_root())
    for (const std::string& path : {state_path, s.out, result.csv, result.plot}) remove_stale_temporaries(path);
  long step = 0;
  double prior_seconds = 0;
  Json curve = Json::array();
  if (s.resume && fs::exists(state_path)) {
    const Checkpoint ck = load_checkpoint(state_path);
    require_header_match(ck, "architecture", net.architecture(), state_path);
    // States written before --aug-* and --init existed lack those keys; they continue as runs with both off.
    Json expected = settings_json(s);
    const Json& stored = ck.header.value("settings", Json::object());
    if (stored.is_object() && !stored.contains("augment") && !s.augment.enabled()) expected.erase("augment");
    if (stored.is_object() && !stored.contains("init") && s.init.empty()) expected.erase("init");
    if (stored.is_object() && !stored.contains("azimuth_weight") && s.azimuth_weight == 0) expected.erase("azimuth_weight");
    if (stored.is_object() && !stored.contains("symmetries") && s.symmetry_tag.empty()) expected.erase("symmetries");
    if (stored.is_object() && !stored.contains("zoom") && !s.zoom.enabled()) expected.erase("zoom");
    require_header_match(ck, "settings", expected, state_path);
    TrainingProgress done = restore_training_state(ck, net.params().values.data(), net.n_params(), opt);
    if (average) ck.get_average(*average);
    step = done.step;
    prior_seconds = done.seconds;
    curve = std::move(done.curve);
  }
  result.start_step = step;

  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  // Data-parallel steps (nets/comm.h): this rank's items [i0, i1) of every batch, one replica per item (sharing
  // net's values, owning activations and a gradient buffer), run in parallel; the step's gradient is the sum of the
  // item gradients in item order: the same bytes for any thread count and any number of ranks.
  const Comm& comm = Comm::world();
  require(comm.size() <= s.batch, "train pose: more MPI ranks (" + std::to_string(comm.size()) +
                                      ") than items per batch (" + std::to_string(s.batch) + ")");
  const auto [i0, i1] = comm.item_range(s.batch);
  const int local = i1 - i0;
  std::vector<std::unique_ptr<PoseNet>> replicas;
  std::vector<PoseNet*> replica_ptrs;
  std::vector<float*> item_grads;  // zero between steps: ordered_sum clears them
  for (int k = 0; k < local; ++k) {
    replicas.push_back(std::make_unique<PoseNet>(s.net, true));
    replicas.back()->share_parameters(net);
    replica_ptrs.push_back(replicas.back().get());
    item_grads.push_back(replicas.back()->params().grads.data());
  }
  auto load = [&sampler, &s, i0 = i0, i1 = i1](long at) {
    SdfBatch batch = sampler.batch(at, i0, i1);
    const uint64_t stream = static_cast<uint64_t>(at) * static_cast<uint64_t>(s.batch) + i0;
    mask_error_images(batch.images, s.mask_error, s.seed, stream);
    zoom_images(batch.images, batch.cameras, s.zoom, s.seed, stream);
    reframe_images(batch.images, batch.cameras, s.reframe, s.seed, stream);
    augment_images(batch.images, s.augment, s.seed, stream);
    return batch;
  };
  std::future<SdfBatch> next;
  if (step < s.steps) next = std::async(std::launch::async, load, step);
  double interval_ce = 0, interval_centre = 0;
  long interval_n = 0;
  bool stop = false;
  std::vector<double> item_loss(static_cast<size_t>(local)), item_ce(static_cast<size_t>(local)),
      item_centre(static_cast<size_t>(local));
  while (step < s.steps && !stop) {
    SdfBatch batch = next.get();
    if (step + 1 < s.steps) next = std::async(std::launch::async, load, step + 1);
    const std::vector<PointsF> points = split_points(batch);
    tbb::parallel_for(0, local, [&](int k) {
      flush_denormals_on_this_thread();
      PoseNet& r = *replicas[static_cast<size_t>(k)];
      const std::vector<std::vector<Mat3>> g = {groups[static_cast<size_t>(batch.shape_index[static_cast<size_t>(k)])]};
      PoseLossOptions lo;
      lo.symmetries = &g;
      lo.azimuth_weight = s.azimuth_weight;
      lo.centre_weight = s.centre_weight;
      item_loss[static_cast<size_t>(k)] =
          r.forward_backward(batch.images.middleRows(k, 1), {points[static_cast<size_t>(k)]},
                             {batch.cameras[static_cast<size_t>(k)]}, 1.0 / s.batch, lo, &item_ce[static_cast<size_t>(k)],
                             &item_centre[static_cast<size_t>(k)]);
    });
    double loss = 0, ce = 0, centre = 0;
    for (const double l : comm.gather(item_loss)) loss += l;
    for (const double l : comm.gather(item_ce)) ce += l;
    for (const double l : comm.gather(item_centre)) centre += l;
    loss /= s.batch;
    ce /= s.batch;
    centre /= s.batch;
    interval_ce += ce;
    interval_centre += centre;
    comm.ordered_sum(item_grads, net.params().grads.data(), net.params().size(), true);
    if (s.grad_clip > 0) clip_grad_norm(net.params().grads.data(), net.params().size(), s.grad_clip);
    const double rate = lr.at(step);
    opt.step(net.params().values.data(), net.params().grads.data(), rate);
    if (average) average->update(net.params().values.data());
    ++step;
    ++interval_n;
    // Rank 0 decides when time is up, so that every rank stops after the same step.
    if (s.time_limit_seconds > 0 && comm.broadcast(elapsed() > s.time_limit_seconds)) stop = true;
    PoseTrainEvent ev{step, s.steps, loss, rate, prior_seconds + elapsed()};
    Json row = {step, loss, nullptr, nullptr, nullptr, rate, ev.seconds};
    if (average) {
      row.push_back(nullptr);
      row.push_back(nullptr);
    }
    if ((step % s.val_every == 0 || step == s.steps || stop) && comm.is_root()) {
      ev.validated = true;
      // With a weight average: the raw weights are scored, then the average takes their place (the replicas read
      // net's values) to be scored and saved as the model, and the raw weights come back for the training state.
      std::vector<float> raw;
      if (average) {
        ev.averaged = true;
        ev.val_raw = validate(replica_ptrs, val_set);
        raw.assign(net.params().values.begin(), net.params().values.end());
        std::copy(average->values().begin(), average->values().end(), net.params().values.begin());
      }
      ev.val = validate(replica_ptrs, val_set);
      if (!average) ev.val_raw = ev.val;
      result.val = ev.val;
      result.val_raw = ev.val_raw;
      row[2] = ev.val.loss;
      row[3] = ev.val.d3d;
      row[4] = ev.val.d2d;
      if (average) {
        row[7] = ev.val_raw.d3d;
        row[8] = ev.val_raw.d2d;
      }
      curve.push_back(row);
      result.train_azimuth_ce = interval_n > 0 ? interval_ce / static_cast<double>(interval_n) : 0.0;
      result.train_centre_loss = interval_n > 0 ? interval_centre / static_cast<double>(interval_n) : 0.0;
      interval_ce = 0;
      interval_centre = 0;
      interval_n = 0;
      Json training = {{"step", step},       {"seconds", ev.seconds},     {"val_loss", ev.val.loss},
                       {"val_d3d", ev.val.d3d}, {"val_d2d", ev.val.d2d}, {"settings", settings_json(s)},
                       {"data", s.data},     {"val_split", s.val_split}};
      if (average) {
        training["val_d3d_raw"] = ev.val_raw.d3d;
        training["val_d2d_raw"] = ev.val_raw.d2d;
      }
      // The small model file (the average when there is one), then the resumable state (raw parameters, optimizer,
      // average, curve).
      save_pose_model(s.out, net, training);
      if (average) std::copy(raw.begin(), raw.end(), net.params().values.begin());
      Checkpoint state = training_state_checkpoint("pose_training_state", net.architecture(), settings_json(s),
                                                   {step, ev.seconds, curve}, net.params().values.data(),
                                                   net.n_params(), opt);
      if (average) state.put_average(*average);
      save_checkpoint(state_path, state);
      write_curve(result.csv, result.plot, curve, average != nullptr);
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

PoseScores evaluate_pose(PoseNet& net, const Dataset& data, const PoseEvalSettings& es,
                         std::map<std::string, PoseScores>* per_category,
                         const std::function<void(long, long)>& progress, std::vector<PoseItemScore>* per_item) {
  require(es.points > 0 && es.batch > 0, "eval-pose: points and batch must be positive");
  require(std::isfinite(es.zoom) && es.zoom > 0, "eval-pose: the zoom must be positive");
  std::vector<std::pair<int, int>> items;
  for (size_t s = 0; s < data.size(); ++s) {
    const int nv = es.views < 0 ? data.shape(s).num_views : std::min(es.views, data.shape(s).num_views);
    for (int v = 0; v < nv; ++v) items.emplace_back(static_cast<int>(s), v);
  }
  require(!items.empty(), data.root() + ": no views to evaluate");
  std::vector<PointsF> shape_points(data.size());
  parallel_for_ordered_errors(size_t(0), data.size(), [&](size_t s) {
    Eigen::VectorXf d;
    draw_samples(data.samples(s), es.points, Rng::mix(es.seed + 1000003ULL * s), shape_points[s], d);
  });
  const std::vector<std::vector<Mat3>> shape_symmetries = symmetry_groups(data, es.symmetries);
  // Fixed chunks of es.batch items, chunk c on replica c mod R (replicas share net's values): every chunk is computed
  // as in a serial run, so the scores do not depend on the thread count.
  const int S = net.settings().image_size;
  const size_t chunks = (items.size() + static_cast<size_t>(es.batch) - 1) / static_cast<size_t>(es.batch);
  const size_t R = std::max<size_t>(1, std::min<size_t>(chunks, static_cast<size_t>(tbb::this_task_arena::max_concurrency())));
  std::vector<std::unique_ptr<PoseNet>> replicas;
  std::vector<PoseNet*> nets = {&net};
  for (size_t r = 1; r < R; ++r) {
    replicas.push_back(std::make_unique<PoseNet>(net.settings(), true));
    replicas.back()->share_parameters(net);
    replicas.back()->set_flip_check(net.flip_check());
    replicas.back()->set_mirror_tta(net.mirror_tta());
    replicas.back()->set_mirror_agree(net.mirror_agree());
    replicas.back()->set_zoom_tta(net.zoom_tta());
    nets.push_back(replicas.back().get());
  }
  struct ItemScore {
    double loss = 0;
    PoseErrors plain, sym;
    Camera predicted, truth;
  };
  std::vector<ItemScore> scored(items.size());
  std::atomic<long> done{0};
  std::mutex progress_mutex;
  // Chunk c on replica `replica`. A failing chunk's error (a missing view, a bad camera) is the first failing item's in
  // list order, whatever the scheduling: the items of a chunk are read in order.
  const auto score_chunk = [&](size_t c, size_t replica) {
    const size_t b0 = c * static_cast<size_t>(es.batch);
    const size_t m = std::min(items.size() - b0, static_cast<size_t>(es.batch));
    MatrixXfR images(static_cast<Eigen::Index>(m), 3 * S * S);
    std::vector<PointsF> pts;
    std::vector<Camera> cams;
    for (size_t k = 0; k < m; ++k) {
      const auto [s, v] = items[b0 + k];
      images.row(static_cast<Eigen::Index>(k)) = network_image(data.image(s, v), S).transpose();
      pts.push_back(shape_points[s]);
      cams.push_back(data.camera(s, v));
    }
    if (es.zoom != 1) {
      ZoomAugmentSettings z;
      z.prob = 1;
      z.min = z.max = es.zoom;
      zoom_images(images, cams, z, es.seed, b0);
    }
    if (es.reframe) {
      ReframeAugmentSettings r;
      r.prob = 1;
      r.camera = ZoomAugmentSettings::CameraFollow::kDistance;
      reframe_images(images, cams, r, es.seed, b0);
    }
    std::vector<PoseErrors> each;
    std::vector<double> losses;
    std::vector<Camera> predicted;
    score_batch(*nets[replica], images, pts, cams, &each, &losses, &predicted);
    for (size_t k = 0; k < m; ++k) {
      const std::vector<Mat3>& g = shape_symmetries[static_cast<size_t>(items[b0 + k].first)];
      scored[b0 + k] = {losses[k], each[k],
                        g.empty() ? each[k] : pose_errors_modulo(to_double(pts[k]), predicted[k], cams[k], g),
                        predicted[k], cams[k]};
    }
    const long now = done += static_cast<long>(m);
    if (progress) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      progress(now, static_cast<long>(items.size()));
    }
  };
  FirstFailure failure;
  tbb::parallel_for(size_t(0), R, [&](size_t r) {
    flush_denormals_on_this_thread();
    for (size_t c = r; c < chunks; c += R) failure.run(c, [&] { score_chunk(c, r); });
  });
  failure.rethrow();
  PoseScores total;
  if (per_item) per_item->clear();
  for (size_t i = 0; i < items.size(); ++i) {
    const ItemScore& it = scored[i];
    const int s = items[i].first;
    const double centre_px =
        std::hypot(it.predicted.K(0, 2) - it.truth.K(0, 2), it.predicted.K(1, 2) - it.truth.K(1, 2));
    const double distance_error = std::abs(it.predicted.t.norm() / it.truth.t.norm() - 1.0);
    PoseErrors twin = it.plain;
    if (es.twins) {
      const std::vector<Mat3> g = es.twins(static_cast<size_t>(s), items[i].second, it.truth, it.predicted);
      if (!g.empty())
        twin = pose_errors_modulo(to_double(shape_points[static_cast<size_t>(s)]), it.predicted, it.truth, g);
    }
    if (per_item) {
      PoseItemScore p;
      p.id = data.shape(s).id;
      p.view = items[i].second;
      p.plain = it.plain;
      p.sym = it.sym;
      p.twin = twin;
      std::tie(p.rotation_deg, p.azimuth_deg) = rotation_error_degrees(it.predicted.R, it.truth.R);
      p.distance = it.truth.t.norm();
      p.distance_est = it.predicted.t.norm();
      p.centre_px = centre_px;
      per_item->push_back(std::move(p));
    }
    for (PoseScores* p : {&total, per_category ? &(*per_category)[data.shape(s).category] : nullptr}) {
      if (!p) continue;
      p->loss += it.loss;
      p->d3d += it.plain.d3d;
      p->d2d += it.plain.d2d;
      p->d3d_sym += it.sym.d3d;
      p->d2d_sym += it.sym.d2d;
      p->d3d_twin += twin.d3d;
      p->d2d_twin += twin.d2d;
      p->large += it.plain.d2d > kLargePoseError ? 1.0 : 0.0;
      p->centre_px += centre_px;
      p->distance_error += distance_error;
      ++p->items;
    }
  }
  auto finish = [](PoseScores& p) {
    if (p.items == 0) return;
    p.loss /= static_cast<double>(p.items);
    p.d3d /= static_cast<double>(p.items);
    p.d2d /= static_cast<double>(p.items);
    p.d3d_sym /= static_cast<double>(p.items);
    p.d2d_sym /= static_cast<double>(p.items);
    p.d3d_twin /= static_cast<double>(p.items);
    p.d2d_twin /= static_cast<double>(p.items);
    p.large /= static_cast<double>(p.items);
    p.centre_px /= static_cast<double>(p.items);
    p.distance_error /= static_cast<double>(p.items);
  };
  finish(total);
  if (per_category)
    for (auto& [k, v] : *per_category) finish(v);
  return total;
}

}  // namespace sdfkit
