// `sdfkit train sdf --data DIR -o MODEL`: train the DISN-style SDF network on a prepared dataset.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "nets/comm.h"
#include "recon/framing.h"
#include "train/sdf_train.h"

#include <cstdio>
#include <iostream>
#include <tuple>

namespace sdfkit::app {
namespace {

std::function<int()> setup_train_sdf(CLI::App& app) {
  struct Opts {
    SdfTrainSettings s;
    std::string variant = "two-stream";
    std::string encoder, point_mlp, decoder;
    double minutes = 0;
    std::string zoom_range = "0.7,1.6";
    std::string occlusion = "none";
    bool mask_channel = false;
    bool object_channel = false;
    int critic_size = 56;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  SdfTrainSettings& s = o->s;
  // The command's defaults are the recipe of the shipped model (docs/results/sdf.md, scripts/train_models): the
  // two-stream network with a full-resolution first map for the local features (DISN samples its 137 px conv1
  // stage), decoders 256,128 and a 512-d global feature; 19,000 steps of 8 items x 2048 points, Adam lr 5e-4 on a
  // cosine that ends at 1e-5 with the last step. 0.27 s per step on 2 cores (data/models/sdf.md).
  s.steps = 19000;
  s.points = 2048;
  s.lr = 5e-4;
  s.lr_min = 1e-5;
  s.lr_steps = 0;  // the cosine ends at --steps
  s.net.encoder_channels = {16, 32, 64, 128, 192, 256};
  s.net.first_stride = 1;
  s.net.extra_convs = 0;
  s.net.global_features = 512;
  s.net.point_mlp = {64, 128};
  s.net.decoder = {256, 128};
  o->encoder = join_widths(s.net.encoder_channels);
  o->point_mlp = join_widths(s.net.point_mlp);
  o->decoder = join_widths(s.net.decoder);
  app.add_option("--data", s.data, "prepared dataset folder (sdfkit prep ... --views V)")->required();
  app.add_option("-o,--out", s.out,
                 "model file to write (checkpoint); MODEL_STEM.loss.csv and MODEL_STEM.loss.svg are written beside it")
      ->required();
  app.add_option("--split", s.train_split, "training split: a name (looked up as DATA/NAME.lst or DATA/../NAME.lst) or a list file")
      ->capture_default_str();
  app.add_option("--val-split", s.val_split, "validation split (\"\" = the first training shapes)")->capture_default_str();
  app.add_option("--variant", o->variant, "network variant: two-stream, one-stream, global-only, binary")
      ->capture_default_str();
  app.add_option("--steps", s.steps, "optimisation steps")->capture_default_str()->check(positive());
  app.add_option("--batch", s.batch, "(shape, view) items per step")->capture_default_str()->check(positive());
  app.add_option("--points", s.points, "SDF samples per item per step")->capture_default_str()->check(positive());
  app.add_option("--lr", s.lr, "Adam learning rate (beta1 = 0.5 as DISN)")->capture_default_str();
  app.add_option("--lr-min", s.lr_min,
                 "cosine decay of the learning rate to this value at the end of the decay (= --lr: constant)")
      ->capture_default_str();
  app.add_option("--lr-steps", s.lr_steps,
                 "steps over which the cosine decay runs (0 = --steps; larger: training stops before the decay ends, "
                 "e.g. a first stage of a longer schedule)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--init", s.init,
                 "start from this SDF model's weights (same network flags) instead of the seeded initialisation; "
                 "fresh optimiser (fine-tuning); a binary network may start from a two-stream model (its output "
                 "layers negated and scaled by 10: logit = -10 pred)");
  app.add_option("--camera-jitter", s.camera_jitter_deg,
                 "turn each training camera about the object's vertical axis by a Gaussian angle of this standard "
                 "deviation in degrees (0 = off): teaches the local features to tolerate an estimated camera's "
                 "azimuth error")
      ->capture_default_str()
      ->check(in_range(0.0, 180.0));
  app.add_option("--aug-zoom", s.zoom.prob,
                 "probability of magnifying a training image about its centre by a factor from --zoom-range, the "
                 "camera's intrinsics magnified with it (exact), so that the network meets objects at other scales "
                 "than the renders' (recon's framing of photos); 0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--zoom-range", o->zoom_range,
                 "MIN,MAX: range of the zoom factor (log-uniform; lowered where the object would leave the frame)")
      ->capture_default_str();
  frame_like_recon(s.reframe);  // the framing recon gives real inputs
  app.add_option("--aug-reframe", s.reframe.prob,
                 "probability of reframing a training image as recon frames a photo (the object's box to 0.67 of "
                 "the image, its centre at the renders' median place), after the zoom; the camera follows exactly, "
                 "its principal point leaving the image centre, so that the network meets reframed inputs; 0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  add_mask_error_options(app, s.mask_error);
  app.add_option("--occlusion", o->occlusion,
                 "occlusion augmentation (the occlusion paper's protocol): none; half (the left or right half of the "
                 "object's box removed); rect (a rectangle of 0.25-0.5 of the image side on the object); mixed (half "
                 "or rect). Removed pixels are white; with --mask-channel the network also reads their mask")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "half", "rect", "mixed"}));
  app.add_option("--occlusion-prob", s.occlusion.prob, "probability of occluding a training image")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_flag("--mask-channel", o->mask_channel,
               "the network reads a fourth input channel, the missing-data mask (1 = pixel unknown, e.g. occluded), "
               "so that missing pixels are not taken for background; --init may name an RGB model of the same "
               "architecture (its first convolution gets zero mask weights)");
  app.add_flag("--object-channel", o->object_channel,
               "the network reads unmasked images (the object among a photograph's pixels) with the object's mask as "
               "a fourth input channel (1 = object), as recon gives it a photo's crop and the mask it found "
               "(docs/train.md); every training image gets its object's mask; excludes --mask-channel, --occlusion "
               "and --aug-mask-error; --init may name a model with the missing-data channel (same weights)");
  app.add_option("--aug-context", s.context.prob,
                 "with --object-channel: probability that a training image's white background becomes a crop of a "
                 "photograph of --context-backgrounds or a procedural background (as the segmenter's composites)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--context-mask-error", s.context.mask_error,
                 "with --object-channel: probability that a training image's mask channel gets a segmentation error "
                 "(thin parts dropped, the outline moved, a blob added; the pixels stay the true ones)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--context-backgrounds", s.context_backgrounds,
                 "with --aug-context: photographs of the drawn backgrounds (a folder, or a .lst/.txt list of image paths; "
                 "none = procedural backgrounds only)");
  app.add_option("--context-band", s.net.context_band,
                 "with --object-channel: the network reads the photograph only within this many pixels of the mask's "
                 "object, white beyond (recon shows it the photo so; 0 = the whole image)")
      ->capture_default_str()
      ->check(in_range(0, 137));
  app.add_option("--context-procedural", s.context.background.procedural,
                 "share of procedural backgrounds among the drawn ones when there are photographs")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--context-clutter", s.context.background.clutter,
                 "probability of dead-leaves clutter over a drawn background (busy photographs)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_flag("--mirror-features", s.net.mirror_features,
               "the local stream also reads the image features at the projection of each point's mirror image "
               "across the object's x = 0 plane (its symmetry plane in ShapeNet-style data), with weights of its own, "
               "so that hidden parts can read their visible twin; --init may name a model without them (their "
               "weights start at 0)");
  app.add_option("--adversarial", s.adversarial.weight,
                 "weight of the occlusion paper's conditional patch critic (0 = off): each item's predicted field is "
                 "rendered as a soft silhouette through its camera and judged, stacked on the input image, against the "
                 "unoccluded object's silhouette; fine-tune a trained model with it (--init or --resume)")
      ->capture_default_str()
      ->check(in_range(0.0, 1e3));
  app.add_option("--critic-size", o->critic_size,
                 "side of the critic's input and of the silhouette render: 14 * 2^k (14, 28, 56, 112, 224); the "
                 "critic's patch map is 14 x 14")
      ->capture_default_str();
  app.add_option("--critic-lr", s.adversarial.critic.lr, "Adam learning rate of the critic (beta1 0.5)")
      ->capture_default_str();
  app.add_option("--silhouette-samples", s.adversarial.render.samples,
                 "samples per pixel ray searched for the smallest predicted value (then 4 refinement samples)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--silhouette-temperature", s.adversarial.temperature,
                 "alpha = sigmoid(-prediction / T) at each ray's point of smallest prediction (prediction = 10 x sdf)")
      ->capture_default_str();
  app.add_option("--weight-decay", s.weight_decay, "L2 weight decay (coupled, as DISN's regulariser)")
      ->capture_default_str();
  app.add_option("--grad-clip", s.grad_clip, "clip the gradient norm to this value (0 = off)")->capture_default_str();
  app.add_option("--val-every", s.val_every, "validate and write a checkpoint every N steps")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--val-shapes", s.val_shapes, "validation shapes (view 0 of each)")->capture_default_str();
  app.add_option("--max-shapes", s.max_shapes, "use only the first N training shapes (0 = all)")->capture_default_str();
  add_ema_option(app, s.ema);
  app.add_option("--seed", s.seed, "seed of the initialisation and of every batch")->capture_default_str();
  app.add_flag("--resume", s.resume, "continue from MODEL when it exists (same settings and seed; bit-exact continuation)");
  app.add_option("--minutes", o->minutes, "stop after this many minutes of training, saving the model (0 = no limit)")
      ->capture_default_str();
  app.add_option("--encoder", o->encoder, "encoder stage channels (one stride-2 stage each; see --first-stride)")
      ->capture_default_str();
  app.add_option("--first-stride", s.net.first_stride,
                 "stride of the first encoder stage: 2, or 1 for a first map at the image's resolution (DISN samples "
                 "local features from its full-resolution conv1 stage)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 2}));
  app.add_option("--extra-convs", s.net.extra_convs, "stride-1 convolutions added to every stage after the first")
      ->capture_default_str();
  app.add_option("--global", s.net.global_features, "global feature size")->capture_default_str();
  app.add_option("--point-mlp", o->point_mlp, "point MLP widths (per stream)")->capture_default_str();
  app.add_option("--decoder", o->decoder, "decoder hidden widths (per stream)")->capture_default_str();
  app.add_flag("--json", o->json, "print the result as JSON on stdout");
  return [o] {
    SdfTrainSettings& s = o->s;
    s.net.variant = sdf_variant_from_string(o->variant);
    s.net.encoder_channels = parse_widths(o->encoder, "--encoder");
    s.net.point_mlp = parse_widths(o->point_mlp, "--point-mlp");
    s.net.decoder = parse_widths(o->decoder, "--decoder");
    s.time_limit_seconds = o->minutes * 60.0;
    s.occlusion.kind = parse_occlusion_kind(o->occlusion);
    if (o->mask_channel && o->object_channel)
      throw InvalidInput("train sdf: --mask-channel and --object-channel are two meanings of the fourth channel; "
                         "choose one");
    s.net.input_channels = o->mask_channel || o->object_channel ? 4 : 3;
    if (o->object_channel) s.net.mask_channel = SdfNetConfig::MaskChannel::kObject;
    if (s.net.context_band > 0 && !o->object_channel)
      throw InvalidInput("train sdf: --context-band applies with --object-channel");
    s.context.band = s.net.context_band;
    s.adversarial.critic.size = s.adversarial.render.size = o->critic_size;
    std::tie(s.zoom.min, s.zoom.max) = parse_positive_range(o->zoom_range, "train sdf: --zoom-range");
    // In an MPI job (mpirun/srun, nets/comm.h) every rank trains; rank 0 alone reports and writes files.
    const bool root = Comm::world().is_root();
    if (root && Comm::world().size() > 1)
      std::fprintf(stderr, "train sdf: data-parallel over %s\n", Comm::world().describe().c_str());
    ProgressBar bar("train sdf", root ? s.steps : 0);
    const SdfTrainResult r = train_sdf(s, [&](const SdfTrainEvent& e) {
      if (!root) return;
      bar.update(e.step);
      if (e.validated) {
        char line[320], raw[96] = "";
        if (e.averaged)
          std::snprintf(raw, sizeof raw, " (raw weights: loss %.4f sample-IoU %.4f)", e.val_raw.loss,
                        e.val_raw.sample_iou);
        std::snprintf(line, sizeof line,
                      "step %ld/%ld  loss %.4f  lr %.2e  val: loss %.4f sign-acc %.4f sample-IoU %.4f%s  (%.0f s)", e.step,
                      e.total, e.loss, e.lr, e.val.loss, e.val.sign_accuracy, e.val.sample_iou, raw, e.seconds);
        bar.print_line(stderr, line);
      }
    });
    bar.finish();
    if (!root) return int(kOk);
    if (o->json) {
      Json j = {{"model", r.model},
                {"csv", r.csv},
                {"plot", r.plot},
                {"steps", r.steps},
                {"start_step", r.start_step},
                {"seconds", r.seconds},
                {"train_loss", r.final_loss},
                {"val", {{"loss", r.val.loss}, {"sign_accuracy", r.val.sign_accuracy},
                         {"sample_iou", r.val.sample_iou}, {"shapes", r.val.shapes}}}};
      if (s.ema > 0)
        j["val_raw"] = {{"loss", r.val_raw.loss}, {"sign_accuracy", r.val_raw.sign_accuracy},
                        {"sample_iou", r.val_raw.sample_iou}, {"shapes", r.val_raw.shapes}};
      std::cout << j.dump(2) << '\n';
    } else {
      std::cout << "trained " << r.steps - r.start_step << " steps (to step " << r.steps << ") in " << r.seconds
                << " s; validation sign accuracy " << r.val.sign_accuracy << ", sample IoU " << r.val.sample_iou
                << "\nmodel: " << r.model << "\nloss curve: " << r.csv << ", " << r.plot << '\n';
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("train sdf", "train the SDF network (DISN two-stream and its ablations) on a prepared dataset",
                        setup_train_sdf);

}  // namespace
}  // namespace sdfkit::app
