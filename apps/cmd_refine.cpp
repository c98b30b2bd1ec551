// `sdfkit refine VIEWS_DIR -o MESH`: deform a mesh (a sphere, or a `recon` result) until its soft renders match a
// view set's images (refine/refine.h); writes the mesh, its loss curve (CSV + SVG) and a preview sheet.
#include "apps/command.h"
#include "bench/timing.h"
#include "camera/image.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "extract/cleanup.h"
#include "nets/plot.h"
#include "refine/carve.h"
#include "refine/refine.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>

namespace fs = std::filesystem;

namespace sdfkit::app {
namespace {

/// OUT_STEM.SUFFIX beside the output mesh (out/cow.obj -> out/cow.loss.csv).
std::string beside(const std::string& mesh, const std::string& suffix) {
  const fs::path p(mesh);
  return (p.parent_path() / p.stem()).string() + "." + suffix;
}

std::function<int()> setup_refine(CLI::App& app) {
  struct Opts {
    std::string views, out, init = "sphere", names, subdivide, albedo = "uniform";
    double init_keep_fraction = kRefineKeepFraction;
    RefineSettings s;
    int sphere_level = 4;
    double sphere_radius = 1.0;
    int preview = 4;
    double minutes = 0;
    bool json = false, adversarial = false, carve = false;
    CarveSettings carve_settings;
    double w_adversarial = 1.0;
  };
  auto o = std::make_shared<Opts>();
  RefineSettings& s = o->s;
  app.add_option("views", o->views, "view set folder: NN.png (RGBA) + NN.json (camera), as `render` and `prep --views` write")
      ->required();
  app.add_option("-o,--out", o->out,
                 "refined mesh (.obj .ply .off .stl; OBJ and PLY keep the vertex colours); OUT_STEM.loss.csv, "
                 ".loss.svg and .preview.png are written beside it")
      ->required();
  app.add_option("--view-names", o->names,
                 "use only these views, comma-separated (e.g. 00,01,02: a recon input and two more); default all");
  app.add_option("--init", o->init,
                 "starting mesh: 'sphere' (an icosphere, see --sphere-level) or a mesh file in the views' object "
                 "frame, e.g. a `recon` result of one of the views")
      ->capture_default_str();
  app.add_option("--init-keep-fraction", o->init_keep_fraction,
                 "a mesh file's components with fewer faces than this fraction of its largest are dropped before "
                 "the optimisation: a few-pixel piece gets a silhouette gradient it cannot follow and flies off "
                 "(0 keeps all)")
      ->capture_default_str()
      ->check(in_range(0, 1));
  app.add_option("--sphere-level", o->sphere_level, "subdivisions of the starting icosphere (4: 2562 vertices)")
      ->check(in_range(0, 7))
      ->capture_default_str();
  app.add_option("--sphere-radius", o->sphere_radius, "radius of the starting icosphere (views' object frame)")
      ->check(positive())
      ->capture_default_str();
  CLI::Option* carve_flag = app.add_flag("--carve", o->carve,
               "before optimising, cut the starting mesh down to the views' visual hull (space carving: keep what "
               "projects inside every silhouette); opens what a view sees through, e.g. the gap between a recon "
               "table's legs, which deforming the mesh cannot");
  app.add_option("--carve-res", o->carve_settings.resolution, "grid points per axis of the carving (box [-1.05, 1.05]^3)")
      ->check(in_range(3, 1025))
      ->capture_default_str()
      ->needs(carve_flag);
  app.add_flag("--carve-complete", o->carve_settings.complete,
               "with --carve: also add what the starting mesh misses: the hull points that a majority of the views "
               "(--carve-complete-views) see on silhouette pixels the carved mesh leaves uncovered (more than a pixel in "
               "from their edge), e.g. the base a recon chair lacks; the optimisation then refines it")
      ->needs(carve_flag);
  app.add_option("--carve-complete-views", o->carve_settings.complete_views,
                 "with --carve-complete: a hull point is added when at least this many views see it on unexplained "
                 "pixels (0: a majority, n / 2 + 1 of n)")
      ->check(in_range(0, 64))
      ->capture_default_str()
      ->needs(carve_flag);
  app.add_option("--iters", s.iters,
                 "optimisation steps (0: write the starting mesh as it is, e.g. the visual hull with --carve)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--views-per-step", s.views_per_step, "views drawn at random for each step")
      ->check(positive())
      ->capture_default_str();
  app.add_option("--lr", s.lr, "SGD learning rate on positions and colours")->check(positive())->capture_default_str();
  app.add_option("--momentum", s.momentum, "SGD momentum")->check(in_range(0.0, 0.999999))->capture_default_str();
  app.add_option("--w-silhouette", s.w_silhouette, "weight of the silhouette squared error")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--w-rgb", s.w_rgb, "weight of the RGB squared error (0: silhouettes only, faster)")
      ->check(non_negative())
      ->capture_default_str();
  CLI::Option* rgb_vertices = app.add_flag(
      "--rgb-moves-vertices,!--no-rgb-moves-vertices", s.rgb_moves_vertices,
      "let the RGB error's gradient move the vertices, not only fit their colours (default: off from a sphere, on, the "
      "paper's, from a mesh file; always on with --lit or --adversarial)");
  CLI::Option* w_edge = app.add_option("--w-edge", s.w_edge,
                                       "weight of the edge-length regulariser (default 0.1 from a sphere, 1, the "
                                       "paper's, from a mesh file)")
                            ->check(non_negative());
  app.add_option("--w-normal", s.w_normal, "weight of the normal-consistency regulariser")
      ->check(non_negative())
      ->capture_default_str();
  CLI::Option* w_laplacian = app.add_option("--w-laplacian", s.w_laplacian,
                                            "weight of the Laplacian smoothing regulariser (default 0.1 from a "
                                            "sphere, 1, the paper's, from a mesh file)")
                                 ->check(non_negative());
  app.add_flag("--adversarial", o->adversarial,
               "train the paper's critic (dense blocks + self-attention, models/critic.h) against the renders and add "
               "its verdict to the loss");
  app.add_option("--w-adversarial", o->w_adversarial, "weight of the adversarial term with --adversarial")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--critic-size", s.critic.size, "side in pixels the critic sees the images at (they are resized)")
      ->check(in_range(16, 1024))
      ->capture_default_str();
  app.add_option("--sigma", s.raster.sigma, "edge softness of the silhouettes, in pixels^2")
      ->check(positive())
      ->capture_default_str();
  CLI::Option* exact = app.add_option(
                             "--exact-silhouette", s.exact_silhouette,
                             "samples per pixel side of the sharp silhouette whose difference with the target drives "
                             "the silhouette term after --exact-after steps, the soft one only carrying it to the "
                             "vertices (the soft silhouette alone is dilated and shrinks the mesh); 3 = `render`'s "
                             "sampling; 0 = the soft silhouette's own error, the paper's loss (default 3 from a "
                             "sphere, 0 from a mesh file)")
                         ->check(CLI::Range(0, 8));
  CLI::Option* exact_after =
      app.add_option("--exact-after", s.exact_after,
                     "steps with the soft silhouette's own error before the exact one takes over (the soft error pulls "
                     "a distant mesh in); default: three quarters of --iters, half with --carve")
          ->check(CLI::NonNegativeNumber);
  app.add_option("--gamma", s.raster.gamma, "depth softness of the colour blending")
      ->check(positive())
      ->capture_default_str();
  CLI::Option* lit = app.add_flag(
      "--lit", s.lit,
      "shape from shading, for views made by `render` or `prep --views`: from the exact silhouette's first step "
      "on, shade the colours as `render` lights its views (flat Lambert + Blinn-Phong, the camera-fixed light rig) "
      "and let the colour error move the vertices where both silhouettes cover the pixel; recovers what no contour "
      "shows, such as the concavities --carve fills");
  app.add_option("--albedo", o->albedo,
                 "with --lit: one albedo for the whole mesh (uniform: the shading cannot hide in the colours) or one "
                 "per vertex")
      ->check(CLI::IsMember({"uniform", "vertex"}))
      ->capture_default_str()
      ->needs(lit);
  app.add_option("--subdivide-at", o->subdivide,
                 "coarse to fine: after these steps (comma-separated) split every face into four and restart the "
                 "momentum (see --subdivide-lr)");
  app.add_option("--subdivide-lr", s.subdivide_lr_factor, "learning-rate factor at each --subdivide-at step")
      ->check(positive())
      ->capture_default_str();
  app.add_option("--seed", s.seed, "seed of the views drawn at every step (same seed, same mesh)")->capture_default_str();
  app.add_option("--log-every", s.log_every, "a loss-curve row every N steps")->check(positive())->capture_default_str();
  app.add_option("--preview", o->preview, "views in the preview sheet (target above render; 0 = no sheet)")
      ->check(in_range(0, 64))
      ->capture_default_str();
  app.add_option("--minutes", o->minutes, "stop after this many minutes, writing what was reached (0 = no limit)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_flag("--json", o->json, "print a JSON summary on stdout");
  return [o, exact, exact_after, w_edge, w_laplacian, rgb_vertices] {
    RefineSettings& s = o->s;
    s.time_limit_seconds = o->minutes * 60.0;
    s.w_adversarial = o->adversarial ? o->w_adversarial : 0.0;
    s.uniform_albedo = o->albedo == "uniform";
    if (!is_mesh_out_path(o->out))
      throw InvalidInput("-o " + o->out + ": give a mesh path ending in .obj, .ply, .off, .stl or .glb");
    validate_refine_settings(s);
    std::vector<std::string> only;
    for (size_t a = 0; !o->names.empty() && a <= o->names.size();) {
      const size_t b = std::min(o->names.find(',', a), o->names.size());
      if (b > a) only.push_back(o->names.substr(a, b - a));
      a = b + 1;
    }
    s.subdivide_at.clear();
    for (size_t a = 0; !o->subdivide.empty() && a <= o->subdivide.size();) {
      const size_t b = std::min(o->subdivide.find(',', a), o->subdivide.size());
      const std::string item = o->subdivide.substr(a, b - a);
      char* end = nullptr;
      const long v = std::strtol(item.c_str(), &end, 10);
      if (item.empty() || *end != '\0' || v < 1 || v >= s.iters)
        throw InvalidInput("--subdivide-at '" + o->subdivide + "': steps between 1 and --iters - 1, comma-separated");
      s.subdivide_at.push_back(v);
      a = b + 1;
    }
    const std::vector<TargetView> views = read_target_views(o->views, s.raster.background, only);
    Mesh init = o->init == "sphere" ? refine_sphere(o->sphere_level, o->sphere_radius) : read_mesh(o->init);
    long init_dropped = 0;
    if (o->init != "sphere") {
      CleanupReport cleaned;
      init = cleanup(init, {o->init_keep_fraction, ComponentMeasure::kFaces}, &cleaned);
      init_dropped = cleaned.components - cleaned.kept_components;
      if (init_dropped > 0)
        std::fprintf(stderr, "refine: %s: %ld small components dropped (--init-keep-fraction %g)\n", o->init.c_str(),
                     init_dropped, o->init_keep_fraction);
    }
    Json carve_json = nullptr;
    if (o->carve) {
      CarveReport cr;
      init = carve_mesh(views, &init, o->carve_settings, &cr);
      std::fprintf(stderr, "refine: carved to the visual hull of %zu views at %d^3: volume %.4f -> %.4f, %ld faces (%.1f s)\n",
                   views.size(), o->carve_settings.resolution, cr.init_volume, cr.volume, cr.faces, cr.seconds);
      if (o->carve_settings.complete)
        std::fprintf(stderr, "refine: completed from %ld unexplained silhouette pixels: volume %.4f -> %.4f\n",
                     cr.unexplained_pixels, cr.carved_volume, cr.volume);
      carve_json = {{"resolution", o->carve_settings.resolution}, {"init_volume", cr.init_volume},
                    {"volume", cr.volume}, {"vertices", cr.vertices}, {"faces", cr.faces}, {"seconds", cr.seconds},
                    {"complete", o->carve_settings.complete}};
      if (o->carve_settings.complete) {
        carve_json["unexplained_pixels"] = cr.unexplained_pixels;
        carve_json["carved_volume"] = cr.carved_volume;
      }
    }
    // From a mesh file the paper's loss measured best (docs/results/refine.md, recon rows): those defaults differ.
    if (o->init != "sphere") {
      const RefineSettings paper = paper_loss(s);
      if (!exact->count()) s.exact_silhouette = paper.exact_silhouette;
      if (!w_edge->count()) s.w_edge = paper.w_edge;
      if (!w_laplacian->count()) s.w_laplacian = paper.w_laplacian;
      if (!rgb_vertices->count()) s.rgb_moves_vertices = paper.rgb_moves_vertices;
    }
    // From the visual hull the exact error takes over at half the steps, not three quarters: the soft error's
    // shrinkage costs more there than its pull (docs/refine.md).
    if (o->carve && o->init == "sphere" && !exact_after->count()) s.exact_after = s.iters / 2;
    s.exact_after = exact_silhouette_from(s);
    std::fprintf(stderr, "refine: %zu views of %d x %d px, %ld vertices, %ld steps of %d views\n", views.size(),
                 views[0].camera.width, views[0].camera.height, static_cast<long>(init.V.rows()), s.iters,
                 std::min<int>(s.views_per_step, static_cast<int>(views.size())));
    ProgressBar bar("refine", s.iters);
    const RefineResult r = refine_mesh(views, init, s, [&](const RefineRow& row) {
      bar.update(row.step);
      if (row.step % std::max<long>(1, s.iters / 10) < s.log_every || row.step == s.iters) {
        char line[200];
        std::snprintf(line, sizeof line, "step %ld/%ld  loss %.5f  silhouette %.5f  rgb %.5f  (%.1f s)", row.step,
                      s.iters, row.loss, row.silhouette, row.rgb, row.seconds);
        bar.print_line(stderr, line);
      }
    });
    bar.finish();

    write_mesh(o->out, r.mesh);
    const std::vector<std::string> header = {"step",   "loss",      "silhouette",  "rgb",    "edge",
                                             "normal", "laplacian", "adversarial", "critic", "seconds"};
    std::vector<std::vector<double>> rows;
    for (const RefineRow& row : r.curve)
      rows.push_back({double(row.step), row.loss, row.silhouette, row.rgb, row.edge, row.normal, row.laplacian,
                      row.adversarial, row.critic, row.seconds});
    const std::string csv = beside(o->out, "loss.csv"), svg = beside(o->out, "loss.svg");
    write_text_atomic(csv, format_csv(header, rows));
    std::vector<int> plotted = {1, 2, 3, 4, 5, 6};
    if (s.w_adversarial > 0) plotted.insert(plotted.end(), {7, 8});
    write_loss_plot_svg(svg, rows, header, plotted, "refine: loss terms");
    std::string preview;
    if (o->preview > 0) {
      std::vector<int> which;
      const int n = static_cast<int>(views.size()), k = std::min(o->preview, n);
      for (int i = 0; i < k; ++i) which.push_back(i * n / k);
      preview = beside(o->out, "preview.png");
      SoftRasterSettings shown = s.raster;
      shown.lit = s.lit && r.steps > lit_from(s);  // the colours as the last step saw them
      write_image(preview, refine_preview_sheet(views, which, r.mesh, shown));
    }
    const RefineRow last = r.curve.empty() ? RefineRow{} : r.curve.back();
    const Json summary = {{"views", o->views},
                          {"mesh", o->out},
                          {"init", o->init},
                          {"init_components_removed", init_dropped},
                          {"carve", carve_json},
                          {"vertices", r.mesh.V.rows()},
                          {"faces", r.mesh.F.rows()},
                          {"steps", r.steps},
                          {"seconds", r.seconds},
                          {"seconds_per_step", r.seconds_per_step},
                          {"peak_rss_mb", peak_rss_mb()},
                          {"loss", {{"total", last.loss},
                                    {"silhouette", last.silhouette},
                                    {"rgb", last.rgb},
                                    {"edge", last.edge},
                                    {"normal", last.normal},
                                    {"laplacian", last.laplacian},
                                    {"adversarial", last.adversarial},
                                    {"critic", last.critic}}},
                          {"adversarial", s.w_adversarial > 0},
                          {"lit", s.lit},
                          {"lit_from", s.lit ? Json(lit_from(s)) : Json(nullptr)},
                          {"albedo", s.lit ? Json(o->albedo) : Json(nullptr)},
                          {"rgb_moves_vertices", colour_moves_vertices(s)},
                          {"exact_silhouette", s.exact_silhouette},
                          {"exact_after", s.exact_silhouette > 0 ? Json(s.exact_after) : Json(nullptr)},
                          {"weights", {{"silhouette", s.w_silhouette}, {"rgb", s.w_rgb}, {"edge", s.w_edge},
                                       {"normal", s.w_normal}, {"laplacian", s.w_laplacian}}},
                          {"curve", {{"csv", csv}, {"svg", svg}}},
                          {"preview", preview}};
    if (o->json)
      std::cout << summary.dump(2) << '\n';
    else
      std::cout << "refined " << r.mesh.V.rows() << " vertices in " << r.steps << " steps (" << r.seconds
                << " s, " << r.seconds_per_step << " s/step); final loss " << last.loss << "\nmesh: " << o->out
                << "\nloss curve: " << csv << ", " << svg << (preview.empty() ? "" : "\npreview: " + preview) << '\n';
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("refine", "deform a mesh to match a view set by differentiable rendering", setup_refine);

}  // namespace
}  // namespace sdfkit::app
