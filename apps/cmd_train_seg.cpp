// `sdfkit train seg --data DIR --backgrounds B -o MODEL`: train the foreground segmenter (models/seg_net.h) on renders
// of a prepared dataset composited onto background photos and procedural backgrounds.
#include "apps/command.h"
#include "core/error.h"
#include "core/json.h"
#include "train/seg_train.h"

#include <cstdio>
#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_train_seg(CLI::App& app) {
  struct Opts {
    SegTrainSettings s;
    double minutes = 0;
    bool json = false;
    std::string encoder, decoder, object_range = "0.2,0.95";
  };
  auto o = std::make_shared<Opts>();
  SegTrainSettings& s = o->s;
  o->encoder = join_widths(s.net.encoder);
  o->decoder = join_widths(s.net.decoder);
  app.add_option("--data", s.data, "prepared dataset folder (views/NN.png RGBA renders; sdfkit prep or synth)")
      ->required();
  app.add_option("--backgrounds", s.backgrounds,
                 "background photos: a folder (searched recursively: png, jpg, tif, bmp, exr, webp) or a list file "
                 "of image paths; without it every background is procedural");
  app.add_option("-o,--out", s.out,
                 "model file to write; MODEL_STEM.loss.csv (loss curve), MODEL_STEM.loss.svg (plot) and "
                 "MODEL.train.ckpt (resumable training state) are written beside it")
      ->required();
  app.add_option("--split", s.train_split,
                 "training split: a name (DATA/NAME.lst or DATA/../NAME.lst) or a list file of <category>/<shape>")
      ->capture_default_str();
  app.add_option("--val-split", s.val_split, "validation split (\"\" = composites of the training shapes)")
      ->capture_default_str();
  app.add_option("--val-backgrounds", s.val_backgrounds,
                 "background photos of the validation composites, kept out of training (a folder or list file, as "
                 "--backgrounds); default: the training backgrounds, whose composites flatter a segmenter that has "
                 "learnt them. Validation only: the training bytes do not change");
  app.add_option("--steps", s.steps, "optimisation steps")->capture_default_str()->check(positive());
  app.add_option("--batch", s.batch, "composites per step")->capture_default_str()->check(positive());
  app.add_option("--lr", s.lr, "Adam learning rate (cosine decay to --lr-min)")->capture_default_str()->check(positive());
  app.add_option("--lr-min", s.lr_min, "learning rate at the last step")->capture_default_str()->check(non_negative());
  app.add_option("--iou-weight", s.iou_weight,
                 "weight of the soft-IoU term added to the per-pixel cross-entropy (0 = cross-entropy alone)")
      ->capture_default_str()
      ->check(non_negative());
  auto* thin_radius =
      app.add_option("--thin-radius", s.thin_radius,
                     "with --thin-weight: the thin parts are what an opening by a disc of this radius (px of the "
                     "--size input) removes from the object")
          ->capture_default_str()
          ->check(in_range(1, 8));
  app.add_option("--thin-weight", s.thin_weight,
                 "the cross-entropy of the object's thin parts (legs, arms, barrels, wing tips: --thin-radius) weighs "
                 "this many times a pixel's (1 = off)")
      ->capture_default_str()
      ->check(in_range(1.0, 100.0));
  app.add_option("--grad-clip", s.grad_clip, "clip the gradient norm (0 = off)")->capture_default_str()->check(non_negative());
  app.add_option("--size", s.net.size, "side of the letterboxed network input (a multiple of 2^stages)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--encoder", o->encoder, "channels of the stride-2 encoder stages")->capture_default_str();
  app.add_option("--extra-convs", s.net.extra_convs, "stride-1 3x3 convolutions after each stage's first")
      ->capture_default_str()
      ->check(in_range(0, 4));
  app.add_option("--decoder", o->decoder, "widths of the 1x1 decoder layers on the hypercolumn")->capture_default_str();
  app.add_option("--fine", s.net.fine,
                 "channels of a full-resolution branch (two 3x3 convolutions of the input) joining the decoder, which "
                 "then predicts at the input's resolution instead of half of it (0 = off)")
      ->capture_default_str()
      ->check(in_range(0, 256));
  app.add_option("--procedural", s.composite.procedural,
                 "probability of a procedural background (flat, gradient, noise, stripes, checker) instead of a photo")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--clutter", s.composite.clutter,
                 "probability of dead-leaves clutter (shaded or photo-textured ellipses, rectangles, triangles) drawn "
                 "over a composite's background: busy photos hold many object-like things to leave out")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--clutter-shapes", s.composite.clutter_shapes, "most clutter shapes in one composite")
      ->capture_default_str()
      ->check(in_range(1, 1000));
  app.add_option("--cutouts", s.cutouts,
                 "cut-out objects (RGBA images with transparent surroundings: animals, tools, vehicles, people): a "
                 "folder or list file as --backgrounds; pasted over the backgrounds of training composites with "
                 "--cutout-prob (the salient things of a busy photo that are not the object)");
  app.add_option("--cutout-prob", s.composite.cutouts,
                 "probability of pasting 1-3 cut-outs of --cutouts (longer side 0.15-0.7 of the canvas's) over a "
                 "training composite's background, behind the object; 0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--object-range", o->object_range,
                 "MIN,MAX: the object's box longer side as a share of the canvas's longer side")
      ->capture_default_str();
  app.add_option("--background-side", s.background_side,
                 "background photos are shrunk to this longer side when loaded (memory; composites are made at "
                 "--size)")
      ->capture_default_str()
      ->check(in_range(8, 4096));
  app.add_option("--max-shapes", s.max_shapes, "use only the first N training shapes (0 = all)")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--val-every", s.val_every, "validate, checkpoint and rewrite the curve every N steps")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--val-items", s.val_items, "validation composites (seeded views, backgrounds and places)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--seed", s.seed, "seed of the initialisation, of every composite and of the validation set")
      ->capture_default_str();
  app.add_option("--init", s.init,
                 "start from the parameters of this segmenter model (same architecture; or the same without --fine: "
                 "the fine branch is added to it, disconnected at first)");
  app.add_flag("--resume", s.resume,
               "continue from MODEL.train.ckpt when it exists (same settings required; bit-exact continuation)");
  app.add_option("--minutes", o->minutes, "stop after this many minutes, saving the model (0 = no limit)")
      ->capture_default_str()
      ->check(non_negative());
  app.add_flag("--json", o->json, "print the result as JSON on stdout");
  return [o, thin_radius] {
    SegTrainSettings& s = o->s;
    if (thin_radius->count() > 0 && s.thin_weight == 1.0)
      throw InvalidInput("train seg: --thin-radius applies with --thin-weight above 1");
    s.time_limit_seconds = o->minutes * 60.0;
    s.net.encoder = parse_widths(o->encoder, "train seg: --encoder");
    s.net.decoder = parse_widths(o->decoder, "train seg: --decoder");
    const auto [lo, hi] = parse_positive_range(o->object_range, "train seg: --object-range");
    s.composite.object_min = lo;
    s.composite.object_max = hi;
    if (s.backgrounds.empty())
      std::fprintf(stderr, "train seg: warning: no --backgrounds: every background is procedural\n");
    ProgressBar bar("train seg", s.steps);
    const SegTrainResult r = train_seg(s, [&](const SegTrainEvent& e) {
      bar.update(e.step);
      if (e.validated) {
        char line[256];
        std::snprintf(line, sizeof line, "step %ld/%ld  loss %.5f  lr %.2e  val: loss %.5f mask IoU %.4f  (%.0f s)",
                      e.step, e.total, e.loss, e.lr, e.val.loss, e.val.iou, e.seconds);
        bar.print_line(stderr, line);
      }
    });
    bar.finish();
    const Json j = {{"model", r.model},
                    {"csv", r.csv},
                    {"plot", r.plot},
                    {"steps", r.steps},
                    {"start_step", r.start_step},
                    {"seconds", r.seconds},
                    {"total_seconds", r.total_seconds},
                    {"seconds_per_step", r.steps > r.start_step ? r.seconds / static_cast<double>(r.steps - r.start_step) : 0.0},
                    {"train_items", r.train_items},
                    {"backgrounds", r.backgrounds},
                    {"val_backgrounds", r.val_backgrounds},
                    {"cutouts", r.cutouts},
                    {"val", {{"loss", r.val.loss}, {"iou", r.val.iou}, {"items", r.val.items}}}};
    if (o->json)
      std::cout << j.dump(2) << '\n';
    else
      std::cout << "trained " << r.steps - r.start_step << " steps (to step " << r.steps << ") in " << r.seconds
                << " s; validation mask IoU " << r.val.iou << "\nmodel: " << r.model << "\nloss curve: " << r.csv
                << ", " << r.plot << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("train seg",
                        "train the foreground segmenter (figure/ground for recon --segment net) on renders composited "
                        "onto backgrounds",
                        setup_train_seg);

}  // namespace
}  // namespace sdfkit::app
