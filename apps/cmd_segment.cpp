// `sdfkit segment IMAGE|DIR|LIST -o OUT`: the object mask recon would use (alpha, plain background, the segmenter
// network and GrabCut), without reconstructing; with --truth, scored against known masks.
#include "apps/command.h"
#include "camera/image.h"
#include "core/error.h"
#include "core/json.h"
#include "recon/framing.h"
#include "recon/recon_json.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit::app {
namespace {

/// The reference mask of `input` under --truth: the file itself for one image given a file, else
/// <truth>/<stem>.png, else <truth>/<stem>.mask.png.
std::string truth_path(const std::string& truth, const std::string& input) {
  if (!fs::is_directory(truth)) return truth;
  const std::string stem = fs::path(input).stem().string();
  for (const char* suffix : {".png", ".mask.png"}) {
    const fs::path p = fs::path(truth) / (stem + suffix);
    if (fs::exists(p)) return p.string();
  }
  throw IoError(truth + ": holds no reference mask for " + input + " (" + stem + ".png or " + stem + ".mask.png)");
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::function<int()> setup_segment(CLI::App& app) {
  struct Opts {
    std::string input, out, segment = "auto", seg_model, box, truth, seg_scan = "on", seg_sure;
    int jobs = 1;
    bool json = false;
    FramingSettings framing;
  };
  auto o = std::make_shared<Opts>();
  o->seg_model = default_model_path("seg.ckpt");
  app.add_option("input", o->input,
                 "an image (any format OpenImageIO reads, any size and aspect ratio, grey, RGB or RGBA), a folder of "
                 "images, or a .txt/.lst list of image paths")
      ->required();
  app.add_option("-o,--out", o->out,
                 "output: a .png path for one image; for a folder or list, a folder receiving <name>.mask.png per "
                 "image. The mask is the object's coverage in [0, 1] at the input's size, as recon writes it")
      ->required();
  app.add_option("--segment", o->segment,
                 "as recon's: without alpha, auto = a plain background detected from the image border, else the "
                 "segmenter network seeding GrabCut when its model (--seg-model) exists, else GrabCut; net = the "
                 "segmenter network alone; grabcut = GrabCut alone (seeded from the border or --box); none = the "
                 "non-white pixels")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "grabcut", "net", "none"}));
  app.add_option("--seg-model", o->seg_model,
                 "segmenter model (sdfkit train seg) of --segment net and auto (default: seg.ckpt of the model "
                 "folder; auto falls back to GrabCut when it does not exist)")
      ->capture_default_str();
  app.add_option("--seg-zoom", o->framing.segmenter_zoom_rounds,
                 "rounds of the segmenter reading the image again closer up, cut around its last answer's object "
                 "(0 = one reading of the whole image; docs/recon.md)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4));
  app.add_option("--seg-scan", o->seg_scan, kSegScanHelp)->capture_default_str()->check(CLI::IsMember({"on", "off"}));
  app.add_option("--seg-agreement", o->framing.grabcut_min_agreement, kSegAgreementHelp)
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  o->seg_sure = seg_sure_default(o->framing);
  app.add_option("--seg-sure", o->seg_sure, kSegSureHelp)->capture_default_str();
  app.add_option("--box", o->box, "X,Y,W,H: the object lies inside this pixel box (single input image)");
  app.add_option("--truth", o->truth,
                 "score the masks: a folder of reference masks <name>.png or <name>.mask.png (their alpha when they "
                 "have one, else their luminance; the input's size), or for one image a mask file. Prints each "
                 "image's mask IoU (pixels over 0.5), the share of the reference's object it misses and the area "
                 "it adds outside it (as a share of the object), and the mean IoU; an image with no object found "
                 "counts as 0");
  app.add_option("-j,--jobs", o->jobs, "images segmented in parallel")->capture_default_str()->check(positive());
  app.add_flag("--json", o->json,
               "print {\"images\": [per image: input, mask, mask_source, object_box, segmenter_zooms, segmenter_scan, "
               "warnings, iou, missed, extra "
               "or error], \"summary\": {...}} as JSON");
  return [o, &app] {
    const std::vector<std::string> inputs = collect_inputs(o->input);
    const bool many = fs::is_directory(o->input) || inputs.size() > 1 || is_list_path(o->input);
    if (!many && extension_of(o->out) != "png")
      throw InvalidInput("-o " + o->out + ": give a .png path for the mask of one image");
    if (many && fs::exists(o->out) && !fs::is_directory(o->out))
      throw InvalidInput("-o " + o->out + ": exists and is not a folder (" + o->input + " holds " +
                         image_count(inputs.size()) + ")");
    if (many && extension_of(o->out) == "png")
      throw InvalidInput("-o " + o->out + ": " + o->input + " holds " + image_count(inputs.size()) +
                         "; give a folder for their masks");
    if (!o->box.empty() && many) throw InvalidInput("--box applies to a single input image");
    if (!o->truth.empty() && !fs::exists(o->truth)) throw IoError(o->truth + ": no such file or folder");
    if (!o->truth.empty() && many && !fs::is_directory(o->truth))
      throw InvalidInput("--truth " + o->truth + ": give a folder of reference masks for several images");
    o->framing.segment = parse_segmentation(o->segment);
    if (!o->box.empty()) o->framing.box = parse_pixel_box(o->box);
    configure_segmenter(app, o->framing, o->seg_model, o->seg_scan, o->seg_sure, true);

    const BatchOutputs outs = batch_outputs(inputs, many, o->out, ".mask.png", "segmented");
    long nfail = 0;
    std::vector<Json> results = run_batch(
        "segment", inputs, outs.clash, o->jobs,
        [&](size_t i, Json& j, ProgressBar& bar) {
          const std::string& in = inputs[i];
          const Image img = read_image(in);
          Image truth;
          std::string truth_file;
          if (!o->truth.empty()) {
            truth_file = truth_path(o->truth, in);
            truth = read_image(truth_file);
            if (truth.width != img.width || truth.height != img.height)
              throw InvalidInput(truth_file + ": reference mask is " + std::to_string(truth.width) + "x" +
                                 std::to_string(truth.height) + " but " + in + " is " + std::to_string(img.width) +
                                 "x" + std::to_string(img.height));
            j["truth"] = truth_file;
          }
          FramedInput f;
          try {
            f = frame_input(img, nullptr, o->framing, in);
          } catch (const InvalidInput&) {
            if (!o->truth.empty()) j["iou"] = 0.0;  // scored as a miss, reported as a failure
            throw;
          }
          write_image(outs.paths[i], f.mask);
          const PixelBox& b = f.object_box;
          j["mask"] = outs.paths[i];
          j["mask_source"] = f.mask_source;
          j["object_box"] = {b.x, b.y, b.w, b.h};
          j["segmenter_zooms"] = f.segmenter_zooms;
          j["segmenter_scan"] = segmenter_scan_json(f.segmenter_scan);
          j["warnings"] = f.warnings;
          std::ostringstream line;
          line << in << " -> " << outs.paths[i] << " (" << f.mask_source << ", object " << b.w << "x" << b.h << " px";
          if (!o->truth.empty()) {
            const MaskAgreement a = mask_agreement(f.mask, truth);
            j["iou"] = a.iou;
            j["missed"] = a.missed;
            j["extra"] = a.extra;
            char text[96];
            std::snprintf(text, sizeof text, "%.3f (missed %.3f, extra %.3f of the object)", a.iou, a.missed, a.extra);
            line << ", mask IoU " << text;
          }
          line << ")";
          for (const std::string& w : f.warnings) bar.print_line(stderr, "sdfkit: warning: " + in + ": " + w);
          if (!o->json) bar.print_line(stdout, line.str());
        },
        &nfail);

    Json summary = {{"images", inputs.size()}, {"failed", nfail}};
    std::vector<double> scored;
    if (!o->truth.empty()) {
      // An image that found no object scores 0; one that failed otherwise (unreadable, no reference) is left out.
      for (size_t i = 0; i < inputs.size(); ++i)
        if (results[i].contains("iou")) scored.push_back(results[i]["iou"].get<double>());
      double sum = 0;
      for (double v : scored) sum += v;
      const long below = std::count_if(scored.begin(), scored.end(), [](double v) { return v < 0.5; });
      summary["scored"] = scored.size();
      summary["mean_iou"] = scored.empty() ? 0.0 : sum / static_cast<double>(scored.size());
      summary["median_iou"] = median_of(scored);
      summary["below_half"] = below;
    }
    if (o->json) {
      std::cout << Json{{"images", std::move(results)}, {"summary", summary}}.dump(2) << '\n';
    } else if (!o->truth.empty()) {
      std::printf("%zu images: mean mask IoU %.4f, median %.4f, %ld below 0.5 (%zu scored; %ld failed)\n",
                  inputs.size(), summary["mean_iou"].get<double>(), summary["median_iou"].get<double>(),
                  summary["below_half"].get<long>(), scored.size(), nfail);
    }
    return batch_exit_code(nfail, inputs.size());
  };
}

SDFKIT_REGISTER_COMMAND("segment",
                        "write the object mask recon would use (segmentation only), and score it with --truth",
                        setup_segment);

}  // namespace
}  // namespace sdfkit::app
