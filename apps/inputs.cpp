// Helpers of the commands that read images (recon, segment): which files are inputs, and the segmenter network.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "nets/seg_net.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <mutex>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit::app {

namespace {
const std::vector<std::string> kImageExtensions = {"png", "jpg", "jpeg", "exr", "tif", "tiff", "bmp"};

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
}  // namespace

const char* const kSegScanHelp =
    "on: the segmenter also reads windows of 0.6 of the image's longer side (3 x 2 on a 320 x 224 photo), zooms in on "
    "each window's answer as on the whole image's, and keeps the answer most readings agree on (small or thin "
    "objects the whole-image reading misses for a salient part of a photo; docs/recon.md); off: the whole image's "
    "reading alone";

bool seg_scan_setting(const CLI::App& app, const std::string& value, int zoom_rounds) {
  if (value == "on" && zoom_rounds == 0) {
    if (app.get_option("--seg-scan")->count() > 0)
      throw InvalidInput("--seg-scan on zooms in on each window's answer; it does not apply with --seg-zoom 0");
    return false;  // the default gives way to --seg-zoom 0: one reading of the whole image
  }
  return value == "on";
}

bool is_image_path(const std::string& path) {
  const std::string e = extension_of(path);
  return std::find(kImageExtensions.begin(), kImageExtensions.end(), e) != kImageExtensions.end();
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
    if (out.empty()) throw InvalidInput(input + ": folder holds no images (png, jpg, exr, tif, bmp)");
    return out;
  }
  if (!fs::exists(input)) throw IoError(input + ": no such file or folder");
  const std::string ext = extension_of(input);
  if (ext == "txt" || ext == "lst") {
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

std::function<Image(const Image& rgb)> shared_segmenter(const std::string& model_path) {
  auto net = std::shared_ptr<SegNet>(load_seg_model(model_path));
  auto lock = std::make_shared<std::mutex>();
  return [net, lock](const Image& rgb) {
    const std::lock_guard<std::mutex> guard(*lock);
    return predict_foreground(*net, rgb);
  };
}

}  // namespace sdfkit::app
