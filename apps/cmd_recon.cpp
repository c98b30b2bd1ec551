// `sdfkit recon IMAGE|DIR|LIST -o OUT`: single-view reconstruction with the shipped (or a given) model.
#include "apps/command.h"
#include "camera/camera.h"
#include "camera/image.h"
#include "camera/occlusion.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/random.h"
#include "core/mesh_io.h"
#include "recon/recon.h"
#include "recon/recon_json.h"


#include <algorithm>
#include <cstdio>
#include <tuple>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit::app {
namespace {

/// Flags that do not apply to the chosen mode are errors, not silently ignored.
void check_flags_apply(const CLI::App& app, bool estimate, bool refine, bool local, bool dense, bool mask) {
  const auto given = [&](const std::string& name) { return app.get_option(name)->count() > 0; };
  for (const char* f : {"--refine-res", "--refine-mode", "--refine-sweep", "--refine-sweep-step", "--refine-local"})
    if (!refine && given(f)) throw InvalidInput(std::string(f) + " applies with --refine-camera");
  for (const char* f : {"--refine-distance", "--refine-evals", "--refine-max-deg", "--refine-max-distance"})
    if (!local && given(f)) throw InvalidInput(std::string(f) + " applies with --refine-local");
  for (const char* f : {"--pose-model", "--photo-pose-model", "--flip-check", "--pose-distances", "--pose-tta",
                        "--pose-zoom-tta", "--framing-fit-centre"})
    if (!estimate && given(f)) throw InvalidInput(std::string(f) + " applies with --cam est (the camera is given)");
  if (dense && given("--safety")) throw InvalidInput("--safety applies to the adaptive extraction, not to --dense");
  if (dense && given("--no-follow")) throw InvalidInput("--no-follow applies to the adaptive extraction, not to --dense");
  for (const char* f : {"--segment", "--box", "--seg-model", "--seg-zoom", "--seg-scan", "--seg-agreement", "--seg-sure"})
    if (mask && given(f)) throw InvalidInput(std::string(f) + " does not apply with --mask (the mask gives the object)");
}

/// An image's own camera file (--cam sidecar): <folder>/<stem>.json beside it.
std::string sidecar_camera_path(const std::string& image) {
  const fs::path p(image);
  return (p.parent_path() / (p.stem().string() + ".json")).string();
}

/// The files of one reconstruction: the mesh, and with the preview <mesh stem>.preview.png and <mesh stem>.mask.png.
ReconOutputPaths recon_output_paths(const std::string& input, const std::string& mesh_path) {
  const fs::path base = fs::path(mesh_path).parent_path() / fs::path(mesh_path).stem();
  return {input, mesh_path, base.string() + ".preview.png", base.string() + ".mask.png", {}};
}

void write_recon_outputs(const ReconResult& r, const ReconOutputPaths& paths, bool preview) {
  write_mesh(paths.mesh, r.mesh);
  if (preview) {
    write_image(paths.preview, r.preview);
    write_image(paths.mask, r.framing.mask);
  }
}

/// --fuse: one mesh from several views; the flags that do not apply are errors.
void check_fuse_flags(const CLI::App& app, size_t images, bool mesh_out, const std::string& out, const std::string& cam) {
  if (images < 2) throw InvalidInput("--fuse needs two or more views of the object (a folder or a list of images)");
  if (!mesh_out)
    throw InvalidInput("-o " + out + ": --fuse writes one mesh; give a path ending in .obj, .ply, .off, .stl or .glb");
  if (cam != "est" && cam != "sidecar")
    throw InvalidInput("--fuse: every view needs its own camera: --cam sidecar (each image's <name>.json) or est");
  for (const char* f : {"--mask", "--missing", "--occlude", "--box", "--jobs", "--refine-camera", "--refine-rounds"})
    if (app.get_option(f)->count() > 0) throw InvalidInput(std::string(f) + " does not apply with --fuse");
}

/// --fuse: Reconstructor::run_views over every input, one mesh, its preview and mask (the first view's).
int fuse_views(const Reconstructor& rec, const std::vector<std::string>& inputs, bool sidecar,
               const ReconSettings& settings, const std::string& mesh_path, bool json) {
  std::vector<Image> images;
  std::vector<Camera> cams(inputs.size());
  std::vector<const Camera*> cam_ptrs(inputs.size(), nullptr);
  for (size_t i = 0; i < inputs.size(); ++i) {
    images.push_back(read_image(inputs[i]));
    if (sidecar) {
      cams[i] = read_camera(sidecar_camera_path(inputs[i]));
      cam_ptrs[i] = &cams[i];
    }
  }
  const ReconResult r = rec.run_views(images, cam_ptrs, settings, inputs);
  for (const std::string& w : r.framing.warnings) std::fprintf(stderr, "sdfkit: warning: %s: %s\n", inputs[0].c_str(), w.c_str());
  ReconOutputPaths paths = recon_output_paths(inputs[0], mesh_path);
  paths.views = inputs;
  write_recon_outputs(r, paths, settings.preview);
  if (json) {
    std::cout << recon_result_json(r, settings, paths, images[0].width, images[0].height).dump(2) << '\n';
  } else {
    std::printf("%zu views -> %s (%ld faces, %ld evaluations, %g s%s)\n", inputs.size(), mesh_path.c_str(),
                static_cast<long>(r.mesh.num_faces()), r.evaluations, r.timings.total,
                settings.preview ? (", preview " + paths.preview).c_str() : "");
  }
  return int(kOk);
}

std::function<int()> setup_recon(CLI::App& app) {
  struct Opts {
    std::string input, out, model, photo_model, pose_model, photo_pose_model, seg_model,
        cam = "est", mask, format = "obj", segment = "auto", seg_scan = "on", seg_sure, framing = "auto", box,
        fit_centre = "auto";
    std::string pose_distances = "off", pose_tta = "mirror", pose_zoom_tta = zoom_list(kDefaultPoseZoomTta);
    ReconSettings s;
    bool json = false, no_preview = false;
    int jobs = 1;
    std::string refine_mode = "joint";
    bool refine = false;
    std::string missing, occlude = "none";
    uint64_t occlude_seed = 1;
    bool fuse = false;
  };
  auto o = std::make_shared<Opts>();
  o->model = default_model_path("sdf.ckpt");
  o->pose_model = default_model_path("pose.ckpt");
  o->photo_pose_model = default_model_path("pose_photo.ckpt");
  o->photo_model = default_model_path("sdf_photo.ckpt");
  o->seg_model = default_model_path("seg.ckpt");
  app.add_option("input", o->input,
                 "an image (any format OpenImageIO reads: PNG, JPEG, EXR, TIFF, BMP, WebP, HEIC, ...; any size and aspect "
                 "ratio, grey, RGB or RGBA), a folder of images, "
                 "or a .txt/.lst list of image paths. The object is found (alpha, --mask, a plain background, or "
                 "GrabCut: --segment), composited on white and cropped like the training renders (--framing)")
      ->required();
  app.add_option("-o,--out", o->out,
                 "output: a mesh path (.obj, .ply, .off, .stl, .glb) for one image; for a folder or list, a folder "
                 "receiving <name>.<--format> per image. Beside each mesh: <name>.preview.png and the object mask "
                 "used, <name>.mask.png")
      ->required();
  app.add_option("--model", o->model,
                 "SDF network model (default: sdf.ckpt of the model folder: $SDFKIT_MODEL_DIR, else "
                 "<sdfkit's folder>/../share/sdfkit/models)")
      ->capture_default_str();
  app.add_option("--photo-model", o->photo_model,
                 "SDF network for images recon reframes (photos, any image not framed like a render): fine-tuned on "
                 "such crops (docs/recon.md). Default: sdf_photo.ckpt of the model folder when it exists and --model "
                 "is not given; none = --model for every image")
      ->capture_default_str();
  app.add_option("--pose-model", o->pose_model, "camera pose network model (used with --cam est; default: pose.ckpt there)")
      ->capture_default_str();
  app.add_option("--photo-pose-model", o->photo_pose_model,
                 "pose network for images recon reframes (photos, any image not framed like a render; --cam est): "
                 "trained on such crops, with a centre head (docs/recon.md). Default: pose_photo.ckpt of the model "
                 "folder when it exists and --pose-model is not given; none = --pose-model for every image")
      ->capture_default_str();
  app.add_option("--segment", o->segment,
                 "without alpha or --mask: auto = a plain background detected from the image border, else the "
                 "segmenter network when its model (--seg-model) exists, else GrabCut; net = always the segmenter "
                 "network; grabcut = always GrabCut (seeded from the border or --box); none = use the image as it is "
                 "(non-white pixels are the object)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "grabcut", "net", "none"}));
  app.add_option("--seg-model", o->seg_model,
                 "segmenter model (sdfkit train seg) of --segment net and auto (default: seg.ckpt of the model "
                 "folder; auto falls back to GrabCut when it does not exist)")
      ->capture_default_str();
  app.add_option("--seg-zoom", o->s.framing.segmenter_zoom_rounds,
                 "rounds of the segmenter reading the image again closer up, cut around its last answer's object "
                 "(0 = one reading of the whole image; docs/recon.md)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4));
  app.add_option("--seg-scan", o->seg_scan, kSegScanHelp)->capture_default_str()->check(CLI::IsMember({"on", "off"}));
  app.add_option("--seg-agreement", o->s.framing.grabcut_min_agreement, kSegAgreementHelp)
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  o->seg_sure = seg_sure_default(o->s.framing);
  app.add_option("--seg-sure", o->seg_sure, kSegSureHelp)->capture_default_str();
  app.add_option("--box", o->box, "X,Y,W,H: the object lies inside this pixel box (GrabCut's seed; outside is background)");
  app.add_option("--framing", o->framing,
                 "auto = keep an image framed like the training renders (square, object centred at their scale), "
                 "else crop a square around the object and scale it to their framing; always = always crop; "
                 "none = never (the whole image, padded to a square)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "always", "none"}));
  app.add_option("--framing-fit", o->s.framing_fit_rounds,
                 "rounds of fitting the crop of a reframed image to where a training render would show the object "
                 "(origin at the centre, size of its distance; docs/recon.md): with a given camera one exact round, "
                 "with an estimated one each round cuts the crop where the estimate shows the object "
                 "(--framing-fit-centre) and reads the new crop (0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 8));
  app.add_option("--framing-fit-centre", o->fit_centre,
                 "with an estimated camera, where a fitting round cuts the crop: camera = where the estimate shows "
                 "the object-frame origin, at its distance's size; shape = at the centre and size of a coarse mesh "
                 "reconstructed through it; auto = camera when the pose model reading reframed images has a centre "
                 "head (the shipped photo pose model has), else shape")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "camera", "shape"}));
  app.add_option("--cam", o->cam,
                 "est = estimate the camera with the pose network; a camera JSON file (views/NN.json format) for "
                 "every image; sidecar = IMAGE's own <name>.json")
      ->capture_default_str();
  app.add_option("--mask", o->mask, "mask image (white = object) replacing the alpha of a single input image");
  app.add_option("--missing", o->missing,
                 "mask image of the pixels whose content is unknown, e.g. hidden by an occluder (white = missing; the "
                 "image's size; single input image). They become white in the network image and, for a model trained "
                 "with --mask-channel, 1 in its mask channel");
  app.add_option("--occlude", o->occlude,
                 "remove part of every input image, as `train sdf --occlusion` does, and treat it as missing data "
                 "(--missing): none, left, right, half (left or right by a coin seeded by --occlude-seed and the "
                 "image's file name), rect (a rectangle of 0.25-0.5 of the image side on the object). Needs images "
                 "with an alpha channel (renders); the split is at the centre column of the alpha's box")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "left", "right", "half", "rect"}));
  app.add_option("--occlude-seed", o->occlude_seed, "seed of --occlude half and rect")->capture_default_str();
  app.add_option("--res", o->s.resolution, "effective grid resolution (points per axis: 65, 129, 257, ...)")
      ->capture_default_str();
  app.add_option("--threshold", o->s.threshold,
                 "binary-variant models (the shipped one): the occupancy probability whose level set is the "
                 "surface (Occupancy Networks' tau; lower keeps more inside). An error with an SDF model")
      ->capture_default_str();
  app.add_flag("--mirror-tta", o->s.mirror_tta,
               "test-time augmentation: average the field with the one read from the input flipped left to right "
               "through the mirrored camera (an exact symmetry of the task; twice the network work)");
  app.add_option("--safety", o->s.safety,
                 "Lipschitz allowance of the network field for the adaptive extraction (1 = exact SDF; default: the "
                 "model's, 2 for an SDF model, 10 for a binary one)");
  app.add_flag("--dense", o->s.dense, "evaluate the full grid instead of the adaptive extraction (slower baseline)");
  app.add_flag("--no-follow{false}", o->s.follow_surface,
               "adaptive extraction without surface following: cells the safety bound misjudges leave holes (for "
               "comparison)");
  app.add_option("--keep-fraction", o->s.min_component_fraction,
                 "drop mesh components with fewer faces than this fraction of the largest (DISN: 0.3)")
      ->capture_default_str();
  CLI::Option* format_opt = app.add_option("--format", o->format, "mesh format in folder mode: obj, ply, off, stl or glb")
      ->capture_default_str()
      ->check(CLI::IsMember(kMeshOutExtensions));
  app.add_option("--pose-distances", o->pose_distances,
                 "MIN,MAX: the training renders' camera distances (2.45,3.0 for sdfkit's view sets); an estimated "
                 "distance outside them is read as a longer or shorter focal length at the nearest of them, the "
                 "camera that makes a magnified or shrunk image (reframed photos); off = the pose network's camera "
                 "as it is")
      ->capture_default_str();
  app.add_option("--flip-check", o->s.flip_check,
                 "pose models with an azimuth head: turn the estimated camera to the azimuth the head prefers when it "
                 "gives that azimuth more than this many times the probability of the regressed one (0 = off)")
      ->capture_default_str()
      ->check(non_negative());
  app.add_option("--pose-tta", o->pose_tta,
                 "mirror: the pose network also reads the input flipped left to right and the two estimates are "
                 "combined (docs/recon.md); none: one reading")
      ->capture_default_str()
      ->check(CLI::IsMember({"mirror", "none"}));
  app.add_option("--pose-zoom-tta", o->pose_zoom_tta,
                 "the pose network also reads the input magnified by each of these factors (comma-separated, in "
                 "[0.5, 2]) and the readings that agree are averaged (docs/recon.md); none: off")
      ->capture_default_str();
  app.add_flag("--refine-camera", o->refine,
               "test-time camera refinement (opt-in, docs/recon.md): reconstruct coarsely (--refine-res) for camera "
               "candidates turned in azimuth within +-(--refine-sweep) degrees, keep the one whose mesh's "
               "silhouette best overlaps the object mask framing found (alpha, --mask, plain background or "
               "--segment), then "
               "reconstruct with it");
  app.add_option("--refine-rounds", o->s.refine_rounds, "refinement rounds (implies --refine-camera when > 0)")
      ->check(in_range(0, 5));
  app.add_option("--refine-res", o->s.refine_resolution, "grid resolution of the meshes refinement scores")
      ->capture_default_str();
  app.add_option("--refine-mode", o->refine_mode,
                 "joint: reconstruct again for every candidate camera and score that mesh through that camera; "
                 "mesh: align the one mesh reconstructed with the estimate (cheaper, but that mesh already fits the "
                 "estimate's view)")
      ->capture_default_str()
      ->check(CLI::IsMember({"joint", "mesh"}));
  app.add_option("--refine-sweep", o->s.refine.sweep_azimuth_deg,
                 "azimuth turns tried: -this..+this degrees (0 = none)")
      ->capture_default_str()
      ->check(in_range(0.0, 180.0));
  app.add_option("--refine-sweep-step", o->s.refine.sweep_step_deg, "step of the azimuth sweep in degrees")
      ->capture_default_str()
      ->check(in_range(1.0, 90.0));
  app.add_flag("--refine-local", o->s.refine.local_search,
               "after the sweep, a bounded Nelder-Mead search over the rotation (and with --refine-distance the "
               "distance) around the best candidate");
  app.add_flag("--refine-distance", o->s.refine.refine_distance, "the local search also changes the camera distance");
  app.add_option("--refine-evals", o->s.refine.max_evaluations, "objective evaluations of the local search")
      ->capture_default_str()
      ->check(in_range(1, 100000));
  app.add_option("--refine-max-deg", o->s.refine.max_rotation_deg, "local search bound of each rotation component")
      ->capture_default_str()
      ->check(in_range(0.1, 90.0));
  app.add_option("--refine-max-distance", o->s.refine.max_distance_change,
                 "local search bound of the camera distance: ratio within [1/(1+c), 1+c]")
      ->capture_default_str()
      ->check(in_range(0.01, 1.0));
  app.add_flag("--fuse", o->fuse,
               "multi-view: the images (a folder or list) are views of one object; one mesh (-o MESH) from the mean "
               "of their fields, each view through its own camera (--cam sidecar, or est: each view's estimate)");
  app.add_flag("--no-preview", o->no_preview, "do not write the preview PNG nor <name>.mask.png");
  app.add_option("-j,--jobs", o->jobs, "images reconstructed in parallel (each also uses the worker threads)")
      ->capture_default_str()
      ->check(positive());
  app.add_flag("--json", o->json, "print per-image results (camera, timings per stage, evaluations) as JSON");
  return [o, format_opt, &app] {
    const std::vector<std::string> inputs = collect_inputs(o->input);
    const bool many = fs::is_directory(o->input) || inputs.size() > 1 || is_list_path(o->input);
    const bool mesh_out = is_mesh_out_path(o->out);
    if (o->fuse) check_fuse_flags(app, inputs.size(), mesh_out, o->out, o->cam);
    if (!many && !mesh_out)
      throw InvalidInput("-o " + o->out + ": give a mesh path ending in .obj, .ply, .off, .stl or .glb for one image");
    if (many && mesh_out && !o->fuse)
      throw InvalidInput("-o " + o->out + ": " + o->input + " holds " + image_count(inputs.size()) +
                         "; give a folder for their meshes");
    if (many && !o->fuse && fs::exists(o->out) && !fs::is_directory(o->out))
      throw InvalidInput("-o " + o->out + ": exists and is not a folder");
    if (!many && fs::is_directory(o->out)) throw InvalidInput("-o " + o->out + ": is a folder, not a mesh path");
    if ((!many || o->fuse) && format_opt->count() > 0)
      throw InvalidInput("--format applies to a folder or list of images; for one image the extension of -o chooses");
    if (!o->box.empty() && many) throw InvalidInput("--box applies to a single input image");
    if (!o->mask.empty() && many) throw InvalidInput("--mask applies to a single input image");
    if (!o->missing.empty() && many) throw InvalidInput("--missing applies to a single input image");
    if (!o->missing.empty() && o->occlude != "none") throw InvalidInput("give --missing or --occlude, not both");
    o->s.preview = !o->no_preview;
    o->s.refine_joint = o->refine_mode == "joint";
    o->s.framing.segment = parse_segmentation(o->segment);
    configure_segmenter(app, o->s.framing, o->seg_model, o->seg_scan, o->seg_sure, o->mask.empty());
    o->s.framing.reframe = parse_reframing(o->framing);
    o->s.framing_fit_centre = o->fit_centre == "camera"  ? ReconSettings::FitCentre::kCamera
                              : o->fit_centre == "shape" ? ReconSettings::FitCentre::kShape
                                                         : ReconSettings::FitCentre::kAuto;
    o->s.pose_mirror_tta = o->pose_tta == "mirror";
    o->s.pose_zoom_tta = parse_zoom_list(o->pose_zoom_tta, "recon: --pose-zoom-tta");
    if (o->pose_distances != "off")
      std::tie(o->s.pose_distance_min, o->s.pose_distance_max) =
          parse_positive_range(o->pose_distances, "recon: --pose-distances");
    if (!o->box.empty()) o->s.framing.box = parse_pixel_box(o->box);
    if (o->refine && o->s.refine_rounds == 0) o->s.refine_rounds = 1;
    const bool estimate = o->cam == "est";
    check_flags_apply(app, estimate, o->s.refine_rounds > 0, o->s.refine.local_search, o->s.dense, !o->mask.empty());
    for (const char* f : {"--framing-fit", "--framing-fit-centre"})
      if (o->s.framing.reframe == Reframing::kNone && app.get_option(f)->count() > 0)
        throw InvalidInput(std::string(f) + " fits the crop of a reframed image; it does not apply with --framing none");
    if (o->s.framing.reframe == Reframing::kNone && app.get_option("--photo-model")->count() > 0)
      throw InvalidInput("--photo-model reconstructs reframed images; it does not apply with --framing none");
    const bool sidecar = o->cam == "sidecar";
    Camera fixed_camera;
    if (!estimate && !sidecar) fixed_camera = read_camera(o->cam);
    // The photo pose and SDF models: given (or "none"), else the default one when it exists and the main model is
    // the default too (a model of one's own comes without its photo companion unless one is named).
    const auto companion = [&](const char* flag, const std::string& path, const char* main_flag) -> std::string {
      if (app.get_option(flag)->count() > 0) return path == "none" ? std::string() : require_model_path(path, flag);
      if (app.get_option(main_flag)->count() == 0 && !path.empty() && fs::exists(path)) return path;
      return {};
    };
    const std::string photo_pose =
        estimate ? companion("--photo-pose-model", o->photo_pose_model, "--pose-model") : std::string();
    const std::string photo_model = companion("--photo-model", o->photo_model, "--model");
    const auto rec = Reconstructor::load(require_model_path(o->model, "--model"),
                                         estimate ? require_model_path(o->pose_model, "--pose-model") : std::string(),
                                         photo_pose, photo_model);
    if (app.get_option("--threshold")->count() > 0 && rec->sdf().config().variant != SdfVariant::kBinary)
      throw InvalidInput("--threshold applies to a binary-variant model; " + o->model + " is " +
                         to_string(rec->sdf().config().variant) + " (its surface is the field's 0 level)");
    (void)rec->surface_level(o->s);  // a threshold outside (0, 1) fails before any work
    Image mask, missing;
    if (!o->mask.empty()) mask = read_image(o->mask);
    if (!o->missing.empty()) missing = read_image(o->missing);

    if (o->fuse) return fuse_views(*rec, inputs, o->cam == "sidecar", o->s, o->out, o->json);

    const BatchOutputs outs = batch_outputs(inputs, many, o->out, "." + o->format, "reconstructed");
    long nfail = 0;
    const std::vector<Json> results = run_batch(
        "recon", inputs, outs.clash, o->jobs,
        [&](size_t i, Json& j, ProgressBar& bar) {
          const std::string& in = inputs[i];
          const std::string stem = fs::path(in).stem().string();
          const std::string& mesh_path = outs.paths[i];
          const ReconOutputPaths paths = recon_output_paths(in, mesh_path);
          Image img = read_image(in);
          // --occlude: the removed pixels (transparent in img) are the missing data.
          Image occluded;
          if (o->occlude != "none") {
            if (img.channels != 2 && img.channels != 4)
              throw InvalidInput(in +
                                 ": --occlude needs an image with an alpha channel (a render); give --missing for "
                                 "other images");
            const uint64_t h = fnv1a(stem.data(), stem.size()) ^ Rng::mix(o->occlude_seed);
            OcclusionSettings os;
            os.mode = o->occlude == "half" ? (Rng(h).uniform() < 0.5 ? OcclusionMode::kLeft : OcclusionMode::kRight)
                                           : parse_occlusion_mode(o->occlude);
            occluded = apply_occlusion(img, os, h);
          }
          const Image* missing_ptr = !occluded.empty() ? &occluded : (!o->missing.empty() ? &missing : nullptr);
          Camera cam;
          const Camera* cam_ptr = nullptr;
          if (sidecar) {
            cam = read_camera(sidecar_camera_path(in));
            cam_ptr = &cam;
          } else if (!estimate) {
            cam_ptr = &fixed_camera;
          }
          const ReconResult r = rec->run(img, o->mask.empty() ? nullptr : &mask, cam_ptr, o->s, in, missing_ptr);
          for (const std::string& w : r.framing.warnings) bar.print_line(stderr, "sdfkit: warning: " + in + ": " + w);
          write_recon_outputs(r, paths, o->s.preview);
          j = recon_result_json(r, o->s, paths, img.width, img.height);
          if (!o->json) {
            std::ostringstream line;
            line << in << " -> " << mesh_path << " (" << r.mesh.num_faces() << " faces, " << r.evaluations
                 << " evaluations, " << r.timings.total << " s" << (o->s.preview ? ", preview " + paths.preview : "")
                 << ")";
            bar.print_line(stdout, line.str());
          }
        },
        &nfail);
    if (o->json) std::cout << (inputs.size() == 1 ? results[0].dump(2) : Json(results).dump(2)) << '\n';
    return batch_exit_code(nfail, inputs.size());
  };
}

SDFKIT_REGISTER_COMMAND("recon", "reconstruct a closed mesh from one image (camera estimate, SDF network, adaptive extraction)",
                        setup_recon);

}  // namespace
}  // namespace sdfkit::app
