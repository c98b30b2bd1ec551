#include "camera/image.h"

#include "core/error.h"
#include "core/files.h"

#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>

namespace fs = std::filesystem;

namespace sdfkit {

namespace {

/// A PNG's chunk lengths checked against the file before libpng sees them: libpng allocates an ancillary chunk's
/// declared length (up to 2^31 - 1 bytes) before reading it, so a 270-byte file can cost gigabytes. Files that do
/// not start with the PNG signature are left to OpenImageIO.
void check_png_chunks(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  unsigned char head[8] = {};
  if (!in.read(reinterpret_cast<char*>(head), 8) || !std::equal(head, head + 8, kSignature)) return;
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  if (ec) return;
  uint64_t at = 8;
  while (at < size) {
    unsigned char h[8] = {};
    if (size - at < 12 || !in.read(reinterpret_cast<char*>(h), 8))
      throw IoError(path + ": corrupt PNG (truncated chunk header at byte " + std::to_string(at) + ")");
    const uint64_t len = (uint64_t(h[0]) << 24) | (uint64_t(h[1]) << 16) | (uint64_t(h[2]) << 8) | uint64_t(h[3]);
    const std::string type(reinterpret_cast<const char*>(h + 4), 4);
    if (len > size - at - 12)
      throw IoError(path + ": corrupt PNG (chunk '" + type + "' at byte " + std::to_string(at) + " declares " +
                    std::to_string(len) + " bytes, the file has " + std::to_string(size - at - 12) + " left)");
    if (type == "IEND") return;
    at += 12 + len;
    in.seekg(static_cast<std::streamoff>(at));
  }
}

/// `img` as displayed under TIFF/EXIF orientation `o` (2-8): each displayed pixel (x, y) takes the stored pixel
/// the orientation puts there (2: mirrored left to right, 3: turned 180 degrees, 4: mirrored top to bottom,
/// 5: transposed, 6: to be turned 90 degrees clockwise, 7: transversed, 8: to be turned 90 degrees
/// counter-clockwise; TIFF 6.0 "Orientation"). Written out rather than OpenImageIO's ImageBufAlgo::reorient,
/// which in Debian 12's version (2.4) swaps orientations 5 and 7 (OpenImageIO issue 4661).
Image upright(const Image& img, int o) {
  const int w = img.width, h = img.height, c = img.channels;
  const bool turned = o >= 5;
  Image out(turned ? h : w, turned ? w : h, c);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      int sx = x, sy = y;
      switch (o) {
        case 2: sx = w - 1 - x; break;
        case 3: sx = w - 1 - x; sy = h - 1 - y; break;
        case 4: sy = h - 1 - y; break;
        case 5: sx = y; sy = x; break;
        case 6: sx = y; sy = h - 1 - x; break;
        case 7: sx = w - 1 - y; sy = h - 1 - x; break;
        case 8: sx = w - 1 - y; sy = x; break;
        default: break;
      }
      std::copy_n(&img.data[img.index(sx, sy)], c, &out.data[out.index(x, y)]);
    }
  return out;
}

}  // namespace

Image read_image(const std::string& path, ImageOrientation how) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw IoError(path + ": no such file");
  if (fs::is_directory(path, ec)) throw IoError(path + ": is a folder, not an image");
  check_png_chunks(path);
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // keep colour values exactly as stored (no premultiplication)
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string msg = OIIO::geterror();
    throw IoError(path + ": cannot read image" + (msg.empty() ? std::string() : " (" + msg + ")"));
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth != 1)
    throw IoError(path + ": empty or unsupported image (" + std::to_string(spec.width) + "x" +
                  std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) + ")");
  const long long pixels = static_cast<long long>(spec.width) * spec.height;
  const std::string size = std::to_string(spec.width) + "x" + std::to_string(spec.height);
  if (pixels > kMaxImagePixels)
    throw IoError(path + ": " + size + " pixels (" + std::to_string(pixels / 1'000'000) +
                  " megapixels) is more than sdfkit reads (" + std::to_string(kMaxImagePixels / 1'000'000) +
                  "); shrink the image first");
  Image img;
  try {
    img = Image(spec.width, spec.height, spec.nchannels);
  } catch (const std::bad_alloc&) {
    throw IoError(path + ": not enough memory for a " + size + " image with " + std::to_string(spec.nchannels) +
                  " channels");
  }
  // OIIO converts 8/16-bit unsigned data to [0, 1] floats.
  const bool ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.data.data());
  if (!ok) {
    const std::string msg = in->geterror();
    throw IoError(path + ": corrupt or truncated image" + (msg.empty() ? std::string() : " (" + msg + ")"));
  }
  const int orientation = spec.get_int_attribute("Orientation", 1);
  in->close();
  for (float v : img.data)
    if (!std::isfinite(v)) throw IoError(path + ": image holds non-finite values");
  // Not a conditional expression: `turn ? upright(...) : img` would copy img whenever there is nothing to turn.
  if (how == ImageOrientation::kUpright && orientation >= 2 && orientation <= 8) return upright(img, orientation);
  return img;
}

void write_image(const std::string& path, const Image& image) {
  require(image.width > 0 && image.height > 0 && image.channels > 0, path + ": cannot write an empty image");
  require(image.data.size() == static_cast<size_t>(image.width) * image.height * image.channels,
          path + ": image data size does not match its width x height x channels");
  for (float v : image.data) require(std::isfinite(v), path + ": refusing to write NaN/Inf pixel values");
  const std::string ext = extension_of(path);
  OIIO::TypeDesc type;
  if (ext == "png" || ext == "jpg" || ext == "jpeg")
    type = OIIO::TypeDesc::UINT8;
  else if (ext == "exr")
    type = OIIO::TypeDesc::FLOAT;
  else if (ext == "tif" || ext == "tiff")
    type = OIIO::TypeDesc::UINT16;
  else
    throw InvalidInput(path + ": unsupported image extension '" + ext + "' (use .png, .exr, .jpg or .tif)");

  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  static std::atomic<unsigned> counter{0};
  const std::string tmp = (target.parent_path() / ("." + target.filename().string() + ".tmp" +
                                                   std::to_string(::getpid()) + "_" + std::to_string(counter++) +
                                                   "." + ext))
                              .string();
  auto out = OIIO::ImageOutput::create(ext);
  if (!out) throw IoError(path + ": no image writer for '" + ext + "' (" + OIIO::geterror() + ")");
  OIIO::ImageSpec spec(image.width, image.height, image.channels, type);
  if (image.channels == 4 || image.channels == 2) {
    spec.alpha_channel = image.channels - 1;
    spec.attribute("oiio:UnassociatedAlpha", 1);  // values are stored as given (straight alpha)
  }
  if (ext == "exr") spec.attribute("compression", "zip");
  // OIIO stamps EXR (capDate) and TIFF (DateTime) files with the current time unless the spec holds a DateTime:
  // the same pixels would give different bytes across a second boundary. EXIF's value for an unknown date
  // (blanks but the colons) keeps every file a pure function of its pixels.
  if (ext == "exr" || ext == "tif" || ext == "tiff") spec.attribute("DateTime", "    :  :     :  :  ");
  auto fail = [&](const std::string& what) {
    fs::remove(tmp, ec);
    throw IoError(path + ": " + what);
  };
  if (!out->open(tmp, spec)) fail("cannot open for writing (" + out->geterror() + ")");
  bool ok;
  if (type == OIIO::TypeDesc::FLOAT) {
    ok = out->write_image(OIIO::TypeDesc::FLOAT, image.data.data());
  } else if (type == OIIO::TypeDesc::UINT8) {
    // Own quantisation (clamp, round half up) so bytes do not depend on the library's conversion.
    std::vector<uint8_t> q(image.data.size());
    for (size_t i = 0; i < q.size(); ++i)
      q[i] = static_cast<uint8_t>(std::floor(std::clamp(image.data[i], 0.0f, 1.0f) * 255.0f + 0.5f));
    ok = out->write_image(OIIO::TypeDesc::UINT8, q.data());
  } else {
    std::vector<uint16_t> q(image.data.size());
    for (size_t i = 0; i < q.size(); ++i)
      q[i] = static_cast<uint16_t>(std::floor(std::clamp(image.data[i], 0.0f, 1.0f) * 65535.0f + 0.5f));
    ok = out->write_image(OIIO::TypeDesc::UINT16, q.data());
  }
  if (!ok) {
    const std::string msg = out->geterror();
    out->close();
    fail("write failed (" + msg + ")");
  }
  if (!out->close()) fail("write failed on close (" + out->geterror() + ")");
  out.reset();
  fs::rename(tmp, target, ec);
  if (ec) fail("cannot rename temporary file into place (" + ec.message() + ")");
}

Image to_rgb(const Image& image, float background) {
  Image out(image.width, image.height, 3);
  const int c = image.channels;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      float rgb[3];
      float a = 1.0f;
      if (c == 1 || c == 2) {
        rgb[0] = rgb[1] = rgb[2] = image.at(x, y, 0);
        if (c == 2) a = image.at(x, y, 1);
      } else {
        for (int k = 0; k < 3; ++k) rgb[k] = image.at(x, y, k);
        if (c >= 4) a = image.at(x, y, 3);
      }
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = (c == 2 || c >= 4) ? rgb[k] * a + background * (1 - a) : rgb[k];
    }
  return out;
}

Image alpha_of(const Image& image) {
  Image out(image.width, image.height, 1, 1.0f);
  if (image.channels == 2 || image.channels == 4)
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) out.at(x, y) = image.at(x, y, image.channels - 1);
  return out;
}

}  // namespace sdfkit
