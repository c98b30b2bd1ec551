// `sdfkit eval-pose --model M --data DIR [--split test] [--symmetry] [--twins]`: d3D and d2D (DISN Table 3) of a
// pose model on a split, optionally also modulo each shape's rotational symmetries about its vertical axis and
// modulo the turned views that look like the image (renders of the shape's source mesh).
#include "apps/command.h"
#include "camera/pose_metrics.h"
#include "camera/render.h"
#include "camera/texture.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "sdf/prepare.h"
#include "sdf/symmetry.h"
#include "train/pose_train.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <cstdio>
#include <iomanip>
#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_eval_pose(CLI::App& app) {
  struct Opts {
    std::string model, data, split = "test";
    PoseEvalSettings e;
    bool json = false, symmetry = false, twins = false;
    double twin_tol = 0.01;
    std::string pose_tta = "mirror", per_image;
    double symmetry_tol = 0.01;
    double flip_check = kDefaultFlipCheck;
    double mirror_agree = kMirrorAgreeDeg;
    std::string zoom_tta = "none";
  };
  auto o = std::make_shared<Opts>();
  app.add_option("--model", o->model, "pose model written by `sdfkit train pose`")->required();
  app.add_option("--data", o->data, "prepared dataset folder")->required();
  app.add_option("--split", o->split,
                 "split: a name (DATA/NAME.lst or DATA/../NAME.lst) or a list file; \"\" = every shape")
      ->capture_default_str();
  app.add_option("--points", o->e.points, "seeded sample points per shape (DISN: 2048)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--views", o->e.views, "first N views of each shape (-1 = all)")->capture_default_str();
  app.add_option("--seed", o->e.seed, "seed of the point draw")->capture_default_str();
  app.add_flag("--symmetry", o->symmetry,
               "also score modulo each shape's symmetries: the quarter and half turns about the vertical axis that "
               "map its gt.obj onto itself (an image cannot tell those poses apart); adds d3D-sym and d2D-sym");
  app.add_option("--symmetry-tol", o->symmetry_tol,
                 "a turn is a symmetry when every vertex and face centre of gt.obj lands within this distance "
                 "(object units) of gt.obj")
      ->capture_default_str()
      ->check(positive());
  app.add_flag("--twins", o->twins,
               "also score modulo what each image shows: an estimate turned by 20 degrees or more about the vertical "
               "axis is compared with the truth turned by the multiples of 5 degrees within 15 of its turn, by "
               "rendering the shape's source mesh (norm.json's \"source\", colours kept) at both cameras; the turns "
               "whose render differs from the true view in at most --twin-tol of the silhouettes' pixels count as "
               "right; adds d3D-twin and d2D-twin (and twin_diff to --per-image)");
  app.add_option("--twin-tol", o->twin_tol,
                 "--twins: the share of the two renders' silhouette pixels that may differ (inside one silhouette "
                 "only, or a colour channel apart by more than 0.1)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--flip-check", o->flip_check,
                 "models with an azimuth head: turn the regressed camera to another azimuth when the head gives it "
                 "more than this many times the probability mass of the regressed one (0 = off: the 6D head alone)")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--pose-tta", o->pose_tta,
                 "mirror: also read every view flipped left to right and combine the two estimates (docs/nets.md, "
                 "pose mirror TTA), as recon does by default; none: one reading")
      ->capture_default_str()
      ->check(CLI::IsMember({"mirror", "none"}));
  app.add_option("--mirror-agree", o->mirror_agree,
                 "--pose-tta mirror: the two readings are averaged when their rotations are at most this many degrees "
                 "apart, else the one the azimuth head supports is kept")
      ->capture_default_str()
      ->check(in_range(0.0, 180.0));
  app.add_option("--zoom-tta", o->zoom_tta,
                 "also read every view magnified by each of these factors (comma-separated, in [0.5, 2]) and average "
                 "the readings that agree (docs/nets.md, pose zoom TTA), as recon's --pose-zoom-tta; none: off")
      ->capture_default_str();
  app.add_option("--zoom", o->e.zoom,
                 "magnify every view by this factor about its centre and divide the true camera distance by it "
                 "(less where the object would leave the frame): how well the model reads the distance from the "
                 "object's size, as recon needs for reframed photos (1 = the views as rendered)")
      ->capture_default_str()
      ->check(in_range(0.25, 4.0));
  app.add_flag("--reframe", o->e.reframe,
               "then frame every view as recon frames a photo (the object's box to 0.67 of the image at the renders' "
               "median place; the true distance divided by the magnification, its principal point moved with the "
               "crop): how well the model reads recon's reframed inputs (a model without --centre-head answers with "
               "the image centre)");
  app.add_option("--per-image", o->per_image,
                 "also write every image's scores to this CSV file: id, view, d3D, d2D (and their -sym forms), the "
                 "rotation error's angle and its nearest turn about the vertical axis (about +-180 for a whole-view "
                 "flip), the true and estimated distances, the principal points' distance (px)");
  app.add_flag("--json", o->json, "print JSON (overall + per category) instead of text");
  return [o, &app] {
    const std::vector<double> zoom_tta = parse_zoom_list(o->zoom_tta, "eval-pose: --zoom-tta");
    if (o->pose_tta != "mirror" && zoom_tta.empty() && app.get_option("--mirror-agree")->count() > 0)
      throw InvalidInput("--mirror-agree applies with --pose-tta mirror or --zoom-tta");
    const auto t0 = std::chrono::steady_clock::now();
    auto net = load_pose_model(o->model);
    net->set_flip_check(o->flip_check);
    net->set_mirror_tta(o->pose_tta == "mirror");
    net->set_mirror_agree(o->mirror_agree);
    net->set_zoom_tta(zoom_tta);
    DatasetSettings ds;
    ds.root = o->data;
    ds.split = o->split;
    const Dataset data(ds);
    Json symmetries = Json::object();  // shape id -> the turns (degrees) found to be symmetries
    std::mutex symmetries_mutex;       // evaluate_pose asks for several shapes at once
    if (o->symmetry)
      o->e.symmetries = [&](const ShapeEntry& shape) {
        std::vector<Mat3> group;
        Json degrees = Json::array();
        for (const RotationSymmetry& r : prepared_shape_symmetries(shape.dir, o->symmetry_tol))
          if (r.symmetric) {
            group.push_back(r.R);
            degrees.push_back(r.degrees);
          }
        const std::lock_guard<std::mutex> lock(symmetries_mutex);
        symmetries[shape.id] = degrees;
        return group;
      };
    if (!o->twins && app.get_option("--twin-tol")->count() > 0) throw InvalidInput("--twin-tol applies with --twins");
    // --twins: the renders of the shape being scored (items come in shape order), and each image's smallest
    // difference from a turned render (NaN when the estimate is within kTwinMinTurn of the truth).
    std::vector<double> twin_diff;
    long turned = 0, twinned = 0;  // images looked at, images with a twin
    TwinSearch search;
    search.tol = o->twin_tol;
    size_t twin_shape = std::numeric_limits<size_t>::max();
    std::unique_ptr<MeshRenderer> twin_renderer;
    std::vector<PreparedSource> sources;
    if (o->twins) {
      // Every shape's source mesh must be there: say so now, not after the network has read every image.
      for (const ShapeEntry& shape : data.shapes()) sources.push_back(prepared_source(shape.dir));
      o->e.twins = [&](size_t s, int, const Camera& truth, const Camera& predicted) {
        std::vector<Mat3> out;
        const double turn = rotation_error_degrees(predicted.R, truth.R).second;
        if (std::abs(turn) < search.min_turn) {  // read about right: nothing to look for
          twin_diff.push_back(std::numeric_limits<double>::quiet_NaN());
          return out;
        }
        if (s != twin_shape) {
          twin_renderer =
              std::make_unique<MeshRenderer>(read_prepared_source(sources.at(s), image_texture_sampler()));
          twin_shape = s;
        }
        double best = 0;
        // R_y(a) = [[cos, 0, sin], [0, 1, 0], [-sin, 0, cos]], the turn rotation_error_degrees measures.
        for (const double a : view_twin_turns(*twin_renderer, truth, turn, search, &best))
          out.push_back(Eigen::AngleAxisd(a * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix());
        twin_diff.push_back(best);
        ++turned;
        twinned += out.empty() ? 0 : 1;
        return out;
      };
    }
    std::map<std::string, PoseScores> per;
    std::vector<PoseItemScore> items;
    ProgressBar bar("eval-pose", 1);
    const PoseScores all = evaluate_pose(
        *net, data, o->e, &per,
        [&](long done, long total) {
          (void)total;
          bar.update(done);
        },
        o->per_image.empty() ? nullptr : &items);
    bar.finish();
    if (!o->per_image.empty())
      write_file_atomic(o->per_image, [&](std::ostream& f) {
        f << "id,view,d3d,d2d,d3d_sym,d2d_sym,rotation_deg,azimuth_deg,distance,distance_est,centre_px";
        if (o->twins) f << ",d3d_twin,d2d_twin,twin_diff";
        f << '\n' << std::setprecision(6);
        for (size_t i = 0; i < items.size(); ++i) {
          const PoseItemScore& it = items[i];
          f << it.id << ',' << it.view << ',' << it.plain.d3d << ',' << it.plain.d2d << ',' << it.sym.d3d << ','
            << it.sym.d2d << ',' << it.rotation_deg << ',' << it.azimuth_deg << ',' << it.distance << ','
            << it.distance_est << ',' << it.centre_px;
          if (o->twins) {
            f << ',' << it.twin.d3d << ',' << it.twin.d2d << ',';
            if (!std::isnan(twin_diff[i])) f << twin_diff[i];
          }
          f << '\n';
        }
      });
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o->json) {
      auto scores = [&](const PoseScores& v) {
        Json j = {{"d3d", v.d3d},
                  {"d2d", v.d2d},
                  {"loss", v.loss},
                  {"items", v.items},
                  {"large_error_share", v.large},
                  {"centre_px", v.centre_px},
                  {"distance_error", v.distance_error}};
        if (o->symmetry) {
          j["d3d_sym"] = v.d3d_sym;
          j["d2d_sym"] = v.d2d_sym;
        }
        if (o->twins) {
          j["d3d_twin"] = v.d3d_twin;
          j["d2d_twin"] = v.d2d_twin;
        }
        return j;
      };
      Json cats = Json::object();
      for (const auto& [k, v] : per) cats[k] = scores(v);
      Json j = scores(all);
      j.update({{"model", o->model}, {"data", o->data}, {"split", o->split}, {"shapes", data.size()},
                {"azimuth_bins", net->settings().azimuth_bins}, {"flip_check", o->flip_check}, {"pose_tta", o->pose_tta},
                {"mirror_agree_deg", o->mirror_agree}, {"zoom_tta", zoom_tta},
                {"points", o->e.points}, {"zoom", o->e.zoom}, {"reframe", o->e.reframe}, {"seconds", seconds}, {"per_category", cats}});
      if (o->twins) {
        j["twin_tol"] = o->twin_tol;
        j["turned_images"] = turned;
        j["twinned_images"] = twinned;
      }
      if (o->symmetry) {
        j["symmetry_tol"] = o->symmetry_tol;
        j["symmetries"] = symmetries;
      }
      std::cout << j.dump(2) << '\n';
    } else {
      auto row = [&](const std::string& name, const PoseScores& v) {
        std::printf("%-14s %8ld %10.4f %10.3f %9.1f%% %10.3f %9.1f%%", name.c_str(), v.items, v.d3d, v.d2d,
                    100.0 * v.large, v.centre_px, 100.0 * v.distance_error);
        if (o->symmetry) std::printf(" %10.4f %10.3f", v.d3d_sym, v.d2d_sym);
        if (o->twins) std::printf(" %10.4f %10.3f", v.d3d_twin, v.d2d_twin);
        std::printf("\n");
      };
      std::printf("%-14s %8s %10s %10s %10s %10s %10s", "category", "items", "d3D", "d2D(px)", ">10px", "centre(px)",
                  "dist err");
      if (o->symmetry) std::printf(" %10s %10s", "d3D-sym", "d2D-sym");
      if (o->twins) std::printf(" %10s %10s", "d3D-twin", "d2D-twin");
      std::printf("\n");
      for (const auto& [k, v] : per) row(k, v);
      row("mean", all);
      if (o->symmetry) {
        long symmetric = 0;
        for (const auto& [id, d] : symmetries.items()) symmetric += d.empty() ? 0 : 1;
        std::printf("%ld of %zu shapes have a quarter or half turn symmetry (tolerance %g)\n", symmetric,
                    data.size(), o->symmetry_tol);
      }
      if (o->twins)
        std::printf("%ld of the %ld estimates turned by %g degrees or more look like a turned view (tolerance %g)\n",
                    twinned, turned, search.min_turn, o->twin_tol);
    }
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("eval-pose", "score a pose model on a split: d3D and d2D (DISN Table 3)", setup_eval_pose);

}  // namespace
}  // namespace sdfkit::app
