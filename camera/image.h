// A float image (H x W x C, row-major, channels interleaved) and its file I/O through OpenImageIO.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace sdfkit {

/// Pixel (x = column, y = row) channel c is data[(y * width + x) * channels + c]. Row 0 is the top row.
/// Values of 8/16-bit files are mapped to [0, 1]; float files (EXR) keep their values.
struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> data;

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), data(static_cast<size_t>(w) * h * c, fill) {}

  [[nodiscard]] bool empty() const { return data.empty(); }
  [[nodiscard]] size_t index(int x, int y, int c = 0) const {
    return (static_cast<size_t>(y) * width + x) * channels + c;
  }
  float& at(int x, int y, int c = 0) { return data[index(x, y, c)]; }
  [[nodiscard]] float at(int x, int y, int c = 0) const { return data[index(x, y, c)]; }
};

/// The largest image read_image reads: 250 megapixels (a 200 MP phone photo fits; 3 GB as RGB floats). A file
/// declaring more is refused before any pixel is allocated: its header alone can claim gigapixels.
inline constexpr long long kMaxImagePixels = 250'000'000;

/// How read_image treats a file's EXIF/TIFF orientation metadata.
enum class ImageOrientation {
  kUpright,   ///< turned and/or mirrored as the metadata says, i.e. as the image is displayed (photos, masks)
  kAsStored,  ///< the pixels as stored (texture maps, whose UV coordinates address the stored grid)
};

/// Read any format OpenImageIO reads (PNG, JPEG, EXR, TIFF, ...), all channels, first sub-image.
/// 8/16-bit integer data -> [0, 1] floats. By default the image is returned as it is meant to be displayed: a file
/// whose metadata holds an orientation other than 1 (a phone photo stored sideways with "turn 90 degrees to
/// display") is turned and/or mirrored upright, so that width, height, pixel positions and anything derived from
/// them (masks, boxes, cameras) refer to the upright image. Throws IoError naming the file when it is missing,
/// unreadable, corrupt or empty (zero pixels), larger than kMaxImagePixels, or when it holds non-finite values.
Image read_image(const std::string& path, ImageOrientation orientation = ImageOrientation::kUpright);

/// Write by extension: .png (8-bit, values clamped to [0, 1] and rounded), .exr (32-bit float, values as
/// they are), .jpg/.jpeg (8-bit), .tif/.tiff (16-bit). Written to a temporary file in the same folder and
/// renamed, so `path` is never half-written; parent folders are created. Throws InvalidInput for an empty or
/// inconsistent image or NaN/Inf values, IoError naming the file when writing fails.
void write_image(const std::string& path, const Image& image);

/// Channel subset / conversion helpers.
/// RGB from an image with 1 (grey), 2 (grey+alpha), 3 or 4 channels; with `background` (0..1) composited
/// under the alpha when the image has alpha.
Image to_rgb(const Image& image, float background = 1.0f);
/// Alpha channel (channels 2 or 4) as a 1-channel image; an opaque (all ones) image otherwise.
Image alpha_of(const Image& image);

}  // namespace sdfkit
