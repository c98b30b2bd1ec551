// `sdfkit train pose --data DIR -o MODEL`: train the camera pose estimator on a prepared dataset.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "nets/comm.h"
#include "recon/framing.h"
#include "sdf/prepare.h"
#include "sdf/symmetry.h"
#include "train/pose_train.h"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <mutex>

namespace sdfkit::app {
namespace {

std::function<int()> setup_train_pose(CLI::App& app) {
  struct Opts {
    PoseTrainSettings s;
    double minutes = 0;
    double symmetry_tol = 0.01;
    bool json = false;
    std::string zoom_range = "0.7,1.6";
  };
  auto o = std::make_shared<Opts>();
  PoseTrainSettings& s = o->s;
  s = shipped_pose_recipe();  // the defaults are the shipped model's recipe (docs/results/pose.md)
  app.add_option("--data", s.data, "prepared dataset folder (sdfkit prep ... --views V)")->required();
  app.add_option("-o,--out", s.out,
                 "model file to write; MODEL_STEM.loss.csv (loss curve), MODEL_STEM.loss.svg (plot) and "
                 "MODEL.train.ckpt (resumable training state) are written beside it")
      ->required();
  app.add_option("--split", s.train_split,
                 "training split: a name (DATA/NAME.lst or DATA/../NAME.lst) or a list file of <category>/<shape>")
      ->capture_default_str();
  app.add_option("--val-split", s.val_split, "validation split (\"\" = validate on training shapes)")
      ->capture_default_str();
  app.add_option("--steps", s.steps, "optimisation steps")->capture_default_str()->check(positive());
  app.add_option("--batch", s.batch, "(shape, view) images per step")->capture_default_str()->check(positive());
  app.add_option("--points", s.points, "sample points per image in the loss (DISN: 2048)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--lr", s.lr, "Adam learning rate (cosine decay to --lr-min)")->capture_default_str();
  app.add_option("--lr-min", s.lr_min, "learning rate at the last step")->capture_default_str();
  app.add_option("--beta1", s.beta1, "Adam beta1 (DISN: 0.5)")->capture_default_str();
  app.add_option("--weight-decay", s.weight_decay, "L2 weight decay (coupled)")->capture_default_str();
  app.add_option("--grad-clip", s.grad_clip, "clip the gradient norm (0 = off)")->capture_default_str();
  app.add_option("--val-every", s.val_every, "validate, checkpoint and rewrite the curve every N steps")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--val-items", s.val_items, "validation images (seeded choice of views)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--max-shapes", s.max_shapes, "use only the first N training shapes (0 = all)")->capture_default_str();
  app.add_option("--width", s.net.width, "channels of the first convolution (later: 2x, 4x, 8x)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--extra-convs", s.net.extra_convs,
                 "conv 3x3/1 layers added after the second and after the third convolution each (0 = the "
                 "6-convolution encoder; 1 costs about 1.7 times the compute at width 32)")
      ->capture_default_str()
      ->check(in_range(0, 2));
  app.add_option("--feature", s.net.feature, "size of the shared feature the heads read")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--azimuth-bins", s.net.azimuth_bins,
                 "bins of the azimuth classifier head (0 = no head, DISN's network); at inference it checks the "
                 "regressed rotation for flips")
      ->capture_default_str()
      ->check(in_range(0, 360));
  app.add_option("--azimuth-weight", s.azimuth_weight, "weight of the azimuth head's cross-entropy in the loss")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--symmetry-tol", o->symmetry_tol,
                 "take L_cam modulo each training shape's quarter and half turns about the vertical axis that map its "
                 "gt.obj onto itself within this distance (object units); 0 = plain L_cam")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--distance-min", o->s.net.distance_min, "smallest predictable camera distance")
      ->capture_default_str();
  app.add_option("--distance-max", o->s.net.distance_max, "largest predictable camera distance")->capture_default_str();
  app.add_option("--aug-colour", s.augment.colour,
                 "photometric augmentation: random brightness and tint of the object, strength in [0, 1) (0 = off); "
                 "the white background and the object's outline stay as rendered, so the camera stays exact")
      ->capture_default_str()
      ->check(in_range(0.0, 0.999));
  app.add_option("--aug-swap", s.augment.channel_swap,
                 "probability of a random permutation of the image's RGB channels (0 = off)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--aug-noise", s.augment.noise,
                 "standard deviation of Gaussian pixel noise added to training images in [0, 1] (0 = off)")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--aug-zoom", s.zoom.prob,
                 "probability of magnifying a training image about its centre by a factor from --zoom-range, the "
                 "camera distance divided by it, so that the model reads the distance from the object's size "
                 "(0 = off); the distance range must cover the zoomed distances")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--zoom-range", o->zoom_range,
                 "MIN,MAX: range of the zoom factor (log-uniform; lowered where the object would leave the frame)")
      ->capture_default_str();
  app.add_flag("--centre-head", s.net.centre_head,
               "add a head that regresses where the object-frame origin appears (the principal point of a cropped "
               "image; --init may name a model without it: the head then starts at the image centre)");
  app.add_option("--centre-weight", s.centre_weight, "weight of the centre head's loss")
      ->capture_default_str()
      ->check(non_negative());
  frame_like_recon(s.reframe);  // the framing recon gives real inputs
  app.add_option("--aug-reframe", s.reframe.prob,
                 "probability of reframing a training image as recon frames a photo (the object's box to 0.67 of "
                 "the image, its centre at the renders' median place), after the zoom: the distance is divided by "
                 "the magnification and the principal point moves with the crop (needs --centre-head); 0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  add_mask_error_options(app, s.mask_error);
  add_ema_option(app, s.ema);
  app.add_option("--seed", s.seed, "seed of the initialisation, of every batch and of the augmentation")
      ->capture_default_str();
  app.add_option("--init", s.init,
                 "start from the parameters of this pose model (fine-tuning; same --width and distance range) "
                 "instead of a seeded random initialisation");
  app.add_flag("--resume", s.resume,
               "continue from MODEL.train.ckpt when it exists (same settings required; bit-exact continuation)");
  app.add_option("--minutes", o->minutes, "stop after this many minutes, saving the model (0 = no limit)")
      ->capture_default_str();
  app.add_flag("--json", o->json, "print the result as JSON on stdout");
  return [o] {
    PoseTrainSettings& s = o->s;
    s.time_limit_seconds = o->minutes * 60.0;
    {
      const auto [lo, hi] = parse_positive_range(o->zoom_range, "train pose: --zoom-range");
      s.zoom.min = lo;
      s.zoom.max = hi;
      if (s.zoom.enabled() && (s.net.distance_min > 2.45 / hi || s.net.distance_max < 3.0 / lo))
        std::fprintf(stderr,
                     "train pose: warning: zoomed distances reach [%.3g, %.3g] for views rendered at [2.45, 3], "
                     "outside --distance-min/--distance-max [%.3g, %.3g]\n",
                     2.45 / hi, 3.0 / lo, s.net.distance_min, s.net.distance_max);
    }
    if (o->symmetry_tol > 0) {
      const double tol = o->symmetry_tol;
      // Finding a shape's symmetries reads its gt.obj (a fraction of a second a shape, minutes for a large
      // benchmark); the result is cached beside it. Say so once, before the first shape whose cache does not
      // answer (missing, stale, unreadable or without this tolerance).
      auto told = std::make_shared<std::once_flag>();
      const bool is_root = Comm::world().is_root();
      s.symmetries = [tol, told, is_root](const ShapeEntry& shape) {
        const auto notice = [&] {
          if (!is_root) return;
          std::call_once(*told, [] {
            std::fprintf(stderr,
                         "train pose: finding the training shapes' vertical-turn symmetries from their gt.obj "
                         "(minutes for thousands of shapes; cached in each shape's symmetries.json)\n");
          });
        };
        try {
          return symmetric_rotations(prepared_shape_symmetries(shape.dir, tol, notice));
        } catch (const std::exception& e) {  // the message names gt.obj (or its cache) already
          throw IoError(std::string(e.what()) + " (finding the shape's symmetries; --symmetry-tol 0 trains without)");
        }
      };
      char tag[64];
      std::snprintf(tag, sizeof tag, "vertical turns of gt.obj, tol %g", tol);
      s.symmetry_tag = tag;
    }
    // In an MPI job (mpirun/srun, nets/comm.h) every rank trains; rank 0 alone reports and writes files.
    const bool root = Comm::world().is_root();
    if (root && Comm::world().size() > 1)
      std::fprintf(stderr, "train pose: data-parallel over %s\n", Comm::world().describe().c_str());
    ProgressBar bar("train pose", root ? s.steps : 0);
    const PoseTrainResult r = train_pose(s, [&](const PoseTrainEvent& e) {
      if (!root) return;
      bar.update(e.step);
      if (e.validated) {
        char line[256];
        char raw[64] = "";
        if (e.averaged) std::snprintf(raw, sizeof raw, " (raw weights: d3D %.4f d2D %.3f px)", e.val_raw.d3d, e.val_raw.d2d);
        std::snprintf(line, sizeof line, "step %ld/%ld  L_cam %.5f  lr %.2e  val: L_cam %.5f d3D %.4f d2D %.3f px%s  (%.0f s)",
                      e.step, e.total, e.loss, e.lr, e.val.loss, e.val.d3d, e.val.d2d, raw, e.seconds);
        bar.print_line(stderr, line);
      }
    });
    bar.finish();
    if (!root) return int(kOk);
    Json j = {{"model", r.model},       {"csv", r.csv},
                    {"plot", r.plot},         {"steps", r.steps},
                    {"start_step", r.start_step}, {"seconds", r.seconds},
                    {"total_seconds", r.total_seconds},
                    {"symmetric_shapes", r.symmetric_shapes},
                    {"train_azimuth_ce", r.train_azimuth_ce},
                    {"train_centre_loss", r.train_centre_loss},
                    {"val", {{"loss", r.val.loss}, {"d3d", r.val.d3d}, {"d2d", r.val.d2d}, {"items", r.val.items}}}};
    if (s.ema > 0)
      j["val_raw"] = {{"loss", r.val_raw.loss}, {"d3d", r.val_raw.d3d}, {"d2d", r.val_raw.d2d}, {"items", r.val_raw.items}};
    if (o->json)
      std::cout << j.dump(2) << '\n';
    else
      std::cout << "trained " << r.steps - r.start_step << " steps (to step " << r.steps << ") in " << r.seconds
                << " s; validation d3D " << r.val.d3d << ", d2D " << r.val.d2d << " px\nmodel: " << r.model
                << "\nloss curve: " << r.csv << ", " << r.plot << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("train pose", "train the camera pose estimator (6D rotation + distance) on a prepared dataset",
                        setup_train_pose);

}  // namespace
}  // namespace sdfkit::app
