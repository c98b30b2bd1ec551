// Helpers of the commands that read images (recon, segment): which files are inputs, and the segmenter network.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "models/seg_net.h"

#include <unistd.h>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit::app {

const std::vector<std::string> kImageExtensions = {"png",  "jpg", "jpeg", "exr", "tif", "tiff", "bmp", "webp",
                                                   "heic", "heif", "avif", "gif", "pnm", "ppm", "pgm",  "pbm",
                                                   "tga",  "hdr",  "jp2",  "j2k"};

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
}  // namespace

const char* const kSegScanHelp =
    "on: the segmenter also reads windows of 0.6 of the image's longer side (3 x 2 on a 320 x 224 photo), zooms in on "
    "each window's answer as on the whole image's, and keeps the answer most readings agree on (small or thin "
    "objects the whole-image reading misses for a salient part of a photo; docs/recon.md); off: the whole image's "
    "reading alone";

const char* const kSegAgreementHelp =
    "with --segment auto: GrabCut's refinement of the segmenter's mask is kept only when the two masks agree at least "
    "this much (IoU), else the segmenter's mask as it is (GrabCut strays on busy photos: background of the object's "
    "colours taken in, thin parts dropped); 0 = GrabCut's whenever it keeps an object";

bool seg_scan_setting(const CLI::App& app, const std::string& value, int zoom_rounds) {
  if (value == "on" && zoom_rounds == 0) {
    if (app.get_option("--seg-scan")->count() > 0)
      throw InvalidInput("--seg-scan on zooms in on each window's answer; it does not apply with --seg-zoom 0");
    return false;  // the default gives way to --seg-zoom 0: one reading of the whole image
  }
  return value == "on";
}

const char* const kSegSureHelp =
    "P,F with --segment auto: labels GrabCut may not change when it refines the segmenter's mask: the pixels where "
    "the network's probability is at least P stay object, the pixels farther from its object than F times the "
    "object's size stay background; 'none' = GrabCut may relabel every pixel";

std::string seg_sure_default(const FramingSettings& framing) {
  std::ostringstream o;
  o << framing.grabcut_sure_object << ',' << framing.grabcut_sure_background;
  return o.str();
}

void seg_sure_setting(const CLI::App& app, const std::string& value, FramingSettings& framing) {
  if (app.get_option("--seg-sure")->count() == 0) return;
  if (value == "none") {
    framing.grabcut_sure_object = 2.0;
    framing.grabcut_sure_background = 0.0;
    return;
  }
  double p = 0, f = 0;
  char comma = 0;
  std::istringstream in(value);
  std::string rest;
  if (!(in >> p >> comma >> f) || comma != ',' || (in >> rest) || !(p > 0.5 && p <= 1.0) || !(f > 0 && f <= 10))
    throw InvalidInput("--seg-sure '" + value + "': give P,F with 0.5 < P <= 1 and 0 < F <= 10 (e.g. 0.97,0.15), or none");
  framing.grabcut_sure_object = p;
  framing.grabcut_sure_background = f;
}

bool is_image_path(const std::string& path) {
  const std::string e = extension_of(path);
  return std::find(kImageExtensions.begin(), kImageExtensions.end(), e) != kImageExtensions.end();
}

bool is_list_path(const std::string& path) {
  const std::string e = extension_of(path);
  return e == "txt" || e == "lst";
}

std::vector<std::string> collect_inputs(const std::string& input) {
  std::vector<std::string> out;
  if (fs::is_directory(input)) {
    for (const auto& e : fs::directory_iterator(input)) {
      const std::string p = e.path().string(), stem = e.path().stem().string();
      if (!e.is_regular_file() || !is_image_path(p)) continue;
      if (ends_with(stem, "_mask") || ends_with(stem, ".mask") || ends_with(stem, ".preview")) continue;
      out.push_back(p);
    }
    std::sort(out.begin(), out.end());
    if (out.empty()) {
      std::string known;
      for (const std::string& e : kImageExtensions) known += (known.empty() ? "" : ", ") + e;
      throw InvalidInput(input + ": folder holds no images (" + known + ")");
    }
    return out;
  }
  if (!fs::exists(input)) throw IoError(input + ": no such file or folder");
  if (is_list_path(input)) {
    std::istringstream in(read_file(input));
    std::string line;
    while (std::getline(in, line)) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (line.empty() || line[0] == '#') continue;
      fs::path p(line);
      if (p.is_relative()) p = fs::path(input).parent_path() / p;
      out.push_back(p.string());
    }
    if (out.empty()) throw InvalidInput(input + ": list holds no image paths");
    return out;
  }
  return {input};
}

std::string image_count(size_t n) { return std::to_string(n) + (n == 1 ? " image" : " images"); }

void use_shared_segmenter(FramingSettings& framing, const std::string& model_path) {
  auto net = std::shared_ptr<SegNet>(load_seg_model(model_path));
  auto lock = std::make_shared<std::mutex>();
  framing.segmenter = [net, lock](const Image& rgb) {
    const std::lock_guard<std::mutex> guard(*lock);
    return predict_foreground(*net, rgb);
  };
  framing.segmenter_batch = [net, lock](const std::vector<Image>& rgbs) {
    const std::lock_guard<std::mutex> guard(*lock);
    return predict_foreground(*net, rgbs);
  };
}

void configure_segmenter(const CLI::App& app, FramingSettings& framing, const std::string& seg_model,
                         const std::string& seg_scan, const std::string& seg_sure, bool load) {
  for (const char* f : {"--seg-model", "--seg-zoom", "--seg-scan"})
    if (app.get_option(f)->count() > 0 &&
        (framing.segment == Segmentation::kGrabCut || framing.segment == Segmentation::kNone))
      throw InvalidInput(std::string(f) + " applies with --segment net or auto");
  for (const char* f : {"--seg-agreement", "--seg-sure"})
    if (app.get_option(f)->count() > 0 && framing.segment != Segmentation::kAuto)
      throw InvalidInput(std::string(f) + " applies with --segment auto (GrabCut refining the segmenter's mask)");
  framing.segmenter_scan = seg_scan_setting(app, seg_scan, framing.segmenter_zoom_rounds);
  seg_sure_setting(app, seg_sure, framing);
  if (load && (framing.segment == Segmentation::kNet ||
               (framing.segment == Segmentation::kAuto && !seg_model.empty() &&
                (app.get_option("--seg-model")->count() > 0 || fs::exists(seg_model)))))
    use_shared_segmenter(framing, require_model_path(seg_model, "--seg-model"));
}

BatchOutputs batch_outputs(const std::vector<std::string>& inputs, bool many, const std::string& out,
                           const std::string& suffix, const std::string& verb) {
  // The folder the outputs go to must exist and take files before any item runs: otherwise every item would do its
  // work and then fail to write it.
  const fs::path folder = many ? fs::path(out) : fs::path(out).parent_path();
  if (!folder.empty()) {
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec) throw IoError("-o " + out + ": cannot create the folder " + folder.string() + " (" + ec.message() + ")");
    if (::access(folder.c_str(), W_OK) != 0)
      throw IoError("-o " + out + ": cannot write in the folder " + folder.string() + " (" + std::strerror(errno) + ")");
  }
  BatchOutputs b;
  b.paths.resize(inputs.size());
  b.clash.resize(inputs.size());
  std::map<std::string, size_t> owner;
  for (size_t i = 0; i < inputs.size(); ++i) {
    b.paths[i] = !many ? out : (fs::path(out) / (fs::path(inputs[i]).stem().string() + suffix)).string();
    const auto [it, fresh] = owner.emplace(fs::path(b.paths[i]).lexically_normal().string(), i);
    if (!fresh)
      b.clash[i] = inputs[i] + ": its output " + b.paths[i] + " is also the output of " + inputs[it->second] +
                   " (same file name stem); not " + verb;
  }
  return b;
}

std::vector<Json> run_batch(const std::string& label, const std::vector<std::string>& inputs,
                            const std::vector<std::string>& clash, int jobs,
                            const std::function<void(size_t i, Json& record, ProgressBar& bar)>& item, long* failed) {
  std::vector<Json> results(inputs.size());
  std::vector<int> bad(inputs.size(), 0);
  ProgressBar bar(label, static_cast<long>(inputs.size()));
  auto one = [&](size_t i) {
    Json j = {{"input", inputs[i]}};
    try {
      if (!clash[i].empty()) throw InvalidInput(clash[i]);
      item(i, j, bar);
    } catch (const std::exception& e) {
      bad[i] = 1;
      std::string msg = e.what();  // one line: library messages may carry several (e.g. image decoders)
      for (char& c : msg)
        if (c == '\n' || c == '\r') c = ' ';
      j["error"] = msg;
      bar.print_line(stderr, "sdfkit: error: " + msg);
    }
    results[i] = std::move(j);
    bar.tick();
  };
  if (jobs <= 1) {
    for (size_t i = 0; i < inputs.size(); ++i) one(i);
  } else {
    tbb::task_arena arena(jobs);
    arena.execute([&] { tbb::parallel_for(size_t(0), inputs.size(), one); });
  }
  bar.finish();
  *failed = std::count(bad.begin(), bad.end(), 1);
  return results;
}

int batch_exit_code(long failed, size_t items) {
  if (failed == 0) return int(kOk);
  return failed == static_cast<long>(items) && items == 1 ? int(kUserError) : int(kPartialFailure);
}

void add_mask_error_options(CLI::App& app, MaskErrorAugmentSettings& settings) {
  app.add_option("--aug-mask-error", settings.prob,
                 "probability of showing a training image as recon's composite of a photo with an imperfect mask: its "
                 "thin parts (what an opening by a disc of 1-3 px removes) each dropped to the background with "
                 "probability 0.7; with probability --mask-error-edge its outline moved by 1-2 px (a textured halo "
                 "outward, or eroded); with probability 0.3 a textured blob beside the object; applied before the zoom "
                 "and the reframing, whose crop follows the erroneous mask; the camera and shape stay the true ones; "
                 "0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--mask-error-edge", settings.error.edge_prob,
                 "with --aug-mask-error: probability of moving an image's outline by 1-2 px (0 = thin parts and "
                 "blobs only)")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
  app.add_option("--mask-error-cut", settings.error.cut_prob,
                 "with --aug-mask-error: probability of also cutting off one end of the object (left, top, right or "
                 "bottom, the line tilted by up to 15 degrees, 5-30% of the object's extent deep), as a mask that "
                 "misses a chair's legs or a lamp's base; 0 = off")
      ->capture_default_str()
      ->check(in_range(0.0, 1.0));
}

void add_ema_option(CLI::App& app, double& decay) {
  app.add_option("--ema", decay,
                 "keep an exponential moving average of the weights with this decay per step (e.g. 0.999; 0 = off): "
                 "validation scores it and the model holds it; the raw weights' scores go to the loss curve's *_raw "
                 "columns")
      ->capture_default_str()
      ->check(in_range(0, 1));
}

}  // namespace sdfkit::app
