#include "camera/image.h"
#include "core/error.h"
#include "core/files.h"
#include "scratch.h"

#include <doctest/doctest.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <unistd.h>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {
std::string tmpdir() {
  return test::scratch_dir("image_test").string();
}

Image gradient(int w, int h, int c) {
  Image img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = static_cast<float>((x + 3 * y + 50 * k) % 256) / 255.0f;
  return img;
}
}  // namespace

TEST_CASE("image: PNG round trip is exact on 8-bit values, alpha kept straight") {
  const std::string dir = tmpdir();
  Image img = gradient(37, 21, 4);
  img.at(3, 4, 3) = 0.0f;  // fully transparent pixel keeps its colour (no premultiplication)
  img.at(3, 4, 0) = 200.0f / 255.0f;
  write_image(dir + "/a.png", img);
  const Image back = read_image(dir + "/a.png");
  REQUIRE(back.width == 37);
  REQUIRE(back.height == 21);
  REQUIRE(back.channels == 4);
  // Same 8-bit codes (the float for code k is k/255 up to one ulp, depending on how the reader divides).
  for (size_t i = 0; i < img.data.size(); ++i) CHECK(std::lround(back.data[i] * 255) == std::lround(img.data[i] * 255));
  for (size_t i = 0; i < img.data.size(); ++i) CHECK(std::abs(back.data[i] - img.data[i]) < 1e-6f);
  // No temporary file is left behind.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  CHECK(files == 1);
  fs::remove_all(dir);
}

TEST_CASE("image: PNG quantisation clamps and rounds, EXR keeps floats") {
  const std::string dir = tmpdir();
  Image img(4, 1, 1);
  img.data = {-0.5f, 0.5f, 1.7f, 0.2f};
  write_image(dir + "/q.png", img);
  const Image q = read_image(dir + "/q.png");
  CHECK(q.data[0] == 0.0f);
  CHECK(std::lround(q.data[1] * 255) == 128);  // 127.5 rounds up
  CHECK(q.data[2] == 1.0f);
  CHECK(std::lround(q.data[3] * 255) == 51);

  Image depth(5, 3, 1);
  for (size_t i = 0; i < depth.data.size(); ++i) depth.data[i] = 1.2345f * static_cast<float>(i) - 3.0f;
  write_image(dir + "/d.exr", depth);
  const Image e = read_image(dir + "/d.exr");
  REQUIRE(e.data.size() == depth.data.size());
  for (size_t i = 0; i < depth.data.size(); ++i) CHECK(e.data[i] == depth.data[i]);
  fs::remove_all(dir);
}

TEST_CASE("image: errors name the file") {
  const std::string dir = tmpdir();
  try {
    read_image(dir + "/missing.png");
    FAIL("no exception");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("missing.png") != std::string::npos);
  }
  write_text_atomic(dir + "/corrupt.png", std::string("\x89PNG\r\n\x1a\n garbage", 17));
  CHECK_THROWS_AS(read_image(dir + "/corrupt.png"), IoError);
  write_text_atomic(dir + "/empty.png", "");
  CHECK_THROWS_AS(read_image(dir + "/empty.png"), IoError);
  // Truncated real PNG.
  write_image(dir + "/ok.png", gradient(64, 64, 3));
  const std::string bytes = read_file(dir + "/ok.png");
  write_text_atomic(dir + "/trunc.png", bytes.substr(0, bytes.size() / 2));
  CHECK_THROWS_AS(read_image(dir + "/trunc.png"), IoError);
  // A chunk that declares more bytes than the file holds (libpng would allocate them first): refused up front,
  // naming the chunk. IHDR is 8 + 4 + 4 + 13 + 4 bytes long; the lying chunk goes right after it.
  std::string lying = bytes.substr(0, 33) + std::string("\x6a\x00\x00\x8a", 4) + "tEXt" + "Software" +
                      bytes.substr(33);
  write_text_atomic(dir + "/lying.png", lying);
  try {
    read_image(dir + "/lying.png");
    FAIL("no exception");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("lying.png: corrupt PNG (chunk 'tEXt' at byte 33 declares 1778385034 bytes") !=
          std::string::npos);
  }
  // A header claiming 20000 x 20000 pixels (a few bytes can claim gigapixels): refused before any allocation.
  // IHDR's width and height are bytes 16-23, its CRC (PNG's CRC-32 over type and data) bytes 29-32.
  std::string huge = bytes;
  for (int i = 0; i < 2; ++i) {
    const uint32_t side = 20000;
    for (int b = 0; b < 4; ++b) huge[16 + 4 * i + b] = static_cast<char>((side >> (24 - 8 * b)) & 0xff);
  }
  uint32_t crc = 0xffffffffu;
  for (int i = 12; i < 29; ++i) {
    crc ^= static_cast<unsigned char>(huge[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  for (int b = 0; b < 4; ++b) huge[29 + b] = static_cast<char>((crc >> (24 - 8 * b)) & 0xff);
  write_text_atomic(dir + "/huge.png", huge);
  try {
    read_image(dir + "/huge.png");
    FAIL("no exception");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("huge.png: 20000x20000 pixels (400 megapixels) is more than sdfkit reads (250)") !=
          std::string::npos);
  }

  Image nan(2, 2, 1);
  nan.data[1] = NAN;
  CHECK_THROWS_AS(write_image(dir + "/nan.exr", nan), InvalidInput);
  CHECK_FALSE(fs::exists(dir + "/nan.exr"));
  CHECK_THROWS_AS(write_image(dir + "/x.bmpx", gradient(2, 2, 1)), InvalidInput);
  CHECK_THROWS_AS(write_image(dir + "/e.png", Image()), InvalidInput);
  fs::remove_all(dir);
}

TEST_CASE("image: to_rgb and alpha_of") {
  Image rgba(1, 1, 4);
  rgba.data = {1.0f, 0.0f, 0.5f, 0.25f};
  const Image rgb = to_rgb(rgba, 1.0f);
  CHECK(rgb.data[0] == doctest::Approx(1.0f));
  CHECK(rgb.data[1] == doctest::Approx(0.75f));
  CHECK(rgb.data[2] == doctest::Approx(0.875f));
  CHECK(alpha_of(rgba).data[0] == 0.25f);
  CHECK(alpha_of(rgb).data[0] == 1.0f);
}

TEST_CASE("image: the same pixels written a second apart give the same bytes (no time stamp in any format)") {
  // OIIO stamps EXR and TIFF headers with the current time (1 s resolution) unless told a date: the view-set
  // determinism test failed whenever its two renders fell on either side of a second boundary.
  const std::string dir = tmpdir();
  const Image img = gradient(16, 8, 4);
  for (const char* ext : {"png", "exr", "tif"}) {
    CAPTURE(ext);
    const std::string a = dir + "/stamp_a." + ext, b = dir + "/stamp_b." + ext;
    write_image(a, img);
    usleep(1'100'000);
    write_image(b, img);
    CHECK(read_file(a) == read_file(b));
    if (std::string(ext) != "png")  // EXR capDate and TIFF DateTime hold EXIF's "unknown date"
      CHECK(read_file(a).find("    :  :     :  :  ") != std::string::npos);
  }
}

namespace {
/// Write `img` (values in [0, 1]) as `path` through OpenImageIO with the metadata Orientation = `orientation`:
/// the stored pixels are `img`, the file says how to turn them for display.
void write_with_orientation(const std::string& path, const Image& img, int orientation, OIIO::TypeDesc type) {
  auto out = OIIO::ImageOutput::create(path);
  REQUIRE(out);
  OIIO::ImageSpec spec(img.width, img.height, img.channels, type);
  spec.attribute("Orientation", orientation);
  REQUIRE(out->open(path, spec));
  REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()));
  REQUIRE(out->close());
}

/// The values of channel 0 along one side of `img` ('t'op, 'b'ottom, 'l'eft, 'r'ight), read from its end at the
/// perpendicular side `from`.
std::vector<float> side_values(const Image& img, char side, char from) {
  std::vector<float> v;
  const bool row = side == 't' || side == 'b';
  const int n = row ? img.width : img.height;
  for (int i = 0; i < n; ++i) {
    const int along = (from == 'l' || from == 't') ? i : n - 1 - i;
    const int x = row ? along : (side == 'l' ? 0 : img.width - 1);
    const int y = row ? (side == 't' ? 0 : img.height - 1) : along;
    v.push_back(img.at(x, y, 0));
  }
  return v;
}
}  // namespace

// A phone photo is often stored sideways with "turn 90 degrees to display" in its EXIF data; everything recon
// derives from an image (mask, box, camera) must refer to the upright image the user sees.
TEST_CASE("image: files are read upright under each of the eight EXIF/TIFF orientations") {
  const std::string dir = tmpdir();
  const int w = 3, h = 2;
  Image stored(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) stored.at(x, y, c) = static_cast<float>(1 + x + w * y + 10 * c) / 64.0f;
  // TIFF 6.0's definition of each orientation: the visual side on which the stored row 0 lies, and the visual
  // side on which the stored column 0 lies (1: top, left; 6: right, top; ...).
  const char sides[9][2] = {{},         {'t', 'l'}, {'t', 'r'}, {'b', 'r'}, {'b', 'l'},
                            {'l', 't'}, {'r', 't'}, {'r', 'b'}, {'l', 'b'}};
  std::vector<float> row0, col0;
  for (int x = 0; x < w; ++x) row0.push_back(stored.at(x, 0, 0));
  for (int y = 0; y < h; ++y) col0.push_back(stored.at(0, y, 0));
  for (int o = 1; o <= 8; ++o) {
    CAPTURE(o);
    const std::string path = dir + "/o" + std::to_string(o) + ".tif";
    write_with_orientation(path, stored, o, OIIO::TypeDesc::UINT16);
    const Image shown = read_image(path);
    const bool swapped = o >= 5;
    REQUIRE(shown.width == (swapped ? h : w));
    REQUIRE(shown.height == (swapped ? w : h));
    REQUIRE(shown.channels == 3);
    // The stored row 0 along its side, starting where column 0 lies; column 0 along its side, starting at row 0's.
    const std::vector<float> r = side_values(shown, sides[o][0], sides[o][1]);
    const std::vector<float> c = side_values(shown, sides[o][1], sides[o][0]);
    REQUIRE(r.size() == row0.size());
    REQUIRE(c.size() == col0.size());
    for (size_t i = 0; i < r.size(); ++i) CHECK(r[i] == doctest::Approx(row0[i]).epsilon(1e-4));
    for (size_t i = 0; i < c.size(); ++i) CHECK(c[i] == doctest::Approx(col0[i]).epsilon(1e-4));
    // Every stored pixel is shown once, with its three channels together.
    std::vector<float> a(stored.data.begin(), stored.data.end()), b(shown.data.begin(), shown.data.end());
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    for (size_t i = 0; i < a.size(); ++i) CHECK(b[i] == doctest::Approx(a[i]).epsilon(1e-4));
    for (int y = 0; y < shown.height; ++y)
      for (int x = 0; x < shown.width; ++x) {
        CHECK(shown.at(x, y, 1) == doctest::Approx(shown.at(x, y, 0) + 10.0f / 64).epsilon(1e-4));
        CHECK(shown.at(x, y, 2) == doctest::Approx(shown.at(x, y, 0) + 20.0f / 64).epsilon(1e-4));
      }
  }
  // Texture maps are read as stored: their UV coordinates address the stored grid.
  const Image as_stored = read_image(dir + "/o6.tif", ImageOrientation::kAsStored);
  REQUIRE(as_stored.width == w);
  for (size_t i = 0; i < stored.data.size(); ++i)
    CHECK(as_stored.data[i] == doctest::Approx(stored.data[i]).epsilon(1e-4));
  // An orientation outside 1-8 is ignored (the pixels as stored), not an error.
  write_with_orientation(dir + "/o9.tif", stored, 9, OIIO::TypeDesc::UINT16);
  const Image odd = read_image(dir + "/o9.tif");
  CHECK(odd.width == w);
  CHECK(odd.at(2, 1, 0) == doctest::Approx(stored.at(2, 1, 0)).epsilon(1e-4));
  fs::remove_all(dir);
}

TEST_CASE("image: a JPEG stored sideways with EXIF orientation 6 is read upright") {
  const std::string dir = tmpdir();
  // Stored 32 x 16: a red left half and a blue right half, each a block large enough for JPEG to keep its colour.
  Image stored(32, 16, 3, 0.0f);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) stored.at(x, y, x < 16 ? 0 : 2) = 1.0f;
  const std::string path = dir + "/phone.jpg";
  write_with_orientation(path, stored, 6, OIIO::TypeDesc::UINT8);
  const Image shown = read_image(path);
  REQUIRE(shown.width == 16);
  REQUIRE(shown.height == 32);
  // Turned 90 degrees clockwise, the stored left half (red) is on top and the right half (blue) below.
  CHECK(shown.at(8, 6, 0) > 0.8f);
  CHECK(shown.at(8, 6, 2) < 0.2f);
  CHECK(shown.at(8, 25, 2) > 0.8f);
  CHECK(shown.at(8, 25, 0) < 0.2f);
  fs::remove_all(dir);
}
