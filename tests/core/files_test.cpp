#include "core/error.h"
#include "core/files.h"
#include "core/random.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

TEST_CASE("npy round trip is exact and readable as NumPy's header layout") {
  const fs::path dir = test::scratch_dir("core_npy");
  fs::create_directories(dir);
  MatrixXfR m(5, 4);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = 0.25f * static_cast<float>(i) - 1.f;
  const std::string path = (dir / "a.npy").string();
  write_npy(path, m);
  const std::string bytes = read_file(path);
  CHECK((bytes.size() - 5 * 4 * 4) % 64 == 0);  // header padded to 64 bytes
  const MatrixXfR back = read_npy(path);
  REQUIRE(back.rows() == 5);
  REQUIRE(back.cols() == 4);
  CHECK((back.array() == m.array()).all());
  // A truncated file is an error naming the file.
  write_text_atomic(path, bytes.substr(0, bytes.size() - 3));
  CHECK_THROWS_AS(read_npy(path), IoError);
  fs::remove_all(dir);
}

TEST_CASE("atomic write leaves no file behind when the writer throws") {
  const fs::path dir = test::scratch_dir("core_atomic");
  fs::remove_all(dir);
  const std::string path = (dir / "x.txt").string();
  CHECK_THROWS(write_file_atomic(path, [](std::ostream& o) {
    o << "partial";
    throw IoError("boom");
  }));
  CHECK_FALSE(fs::exists(path));
  CHECK(fs::is_empty(dir));
  fs::remove_all(dir);
}

TEST_CASE("Rng: seeded, uniform in range, unbiased below()") {
  Rng a(42), b(42), c(43);
  for (int i = 0; i < 100; ++i) CHECK(a.next() == b.next());
  CHECK(a.next() != c.next());
  Rng r(7);
  double sum = 0;
  long counts[3] = {0, 0, 0};
  const int n = 30000;
  for (int i = 0; i < n; ++i) {
    const double u = r.uniform();
    REQUIRE(u >= 0.0);
    REQUIRE(u < 1.0);
    sum += u;
    counts[r.below(3)]++;
  }
  CHECK(sum / n == doctest::Approx(0.5).epsilon(0.02));
  for (long k : counts) CHECK(std::abs(k - n / 3) < 600);  // > 5 sigma
}
