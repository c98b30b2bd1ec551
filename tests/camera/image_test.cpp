#include "camera/image.h"
#include "core/error.h"
#include "core/files.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>

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
