#include "core/error.h"
#include "core/files.h"
#include "core/random.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

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

namespace {
/// A version 1.0 .npy file with the given header dictionary text and `data` after it.
std::string write_raw_npy(const fs::path& path, const std::string& dict, const std::string& data) {
  std::string header = dict;
  header.append((64 - (10 + header.size() + 1) % 64) % 64, ' ');
  header.push_back('\n');
  std::string bytes("\x93NUMPY\x01\x00", 8);
  bytes.push_back(static_cast<char>(header.size() & 0xff));
  bytes.push_back(static_cast<char>(header.size() >> 8));
  write_text_atomic(path.string(), bytes + header + data);
  return path.string();
}

std::string npy_error(const std::string& path) {
  try {
    (void)read_npy(path);
  } catch (const IoError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not an IoError: ") + e.what();
  }
  return "no error";
}
}  // namespace

TEST_CASE("npy: malformed or hostile shapes are IoErrors naming the file, empty arrays read as empty") {
  const fs::path dir = test::scratch_dir("core_npy_hostile");
  const std::string data(48, '\0');  // 12 float32 zeros
  const auto dict = [](const std::string& shape) {
    return "{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }";
  };
  for (const std::string shape : {"(abc,)", "(3, x)", "(-3, 4)", "(99999999999999999999999,)", "(1e3,)",
                                  "(4611686018427387904, 4)",  // 2^62 x 4: the product wraps to 0 in 64 bits
                                  "(3037000500, 3037000500)",  // the product overflows a signed 64-bit integer
                                  "(100000000000,)",           // fits in memory arithmetic, not in the file
                                  "(13,)", "()"}) {
    CAPTURE(shape);
    const std::string path = write_raw_npy(dir / "bad.npy", dict(shape), data);
    const std::string err = npy_error(path);
    CHECK(err.rfind(path + ": ", 0) == 0);  // an IoError whose message starts with the file name
  }
  // Empty arrays are valid: no copy from or to a null pointer, the right (empty) shape.
  const MatrixXfR empty = read_npy(write_raw_npy(dir / "empty.npy", dict("(0,)"), ""));
  CHECK(empty.rows() == 0);
  CHECK(empty.size() == 0);
  const MatrixXfR empty2 = read_npy(write_raw_npy(dir / "empty2.npy", dict("(0, 3)"), ""));
  CHECK(empty2.rows() == 0);
  CHECK(empty2.cols() == 3);
  // Exactly the 12 values present: read.
  const MatrixXfR full = read_npy(write_raw_npy(dir / "full.npy", dict("(3, 4)"), data));
  CHECK(full.rows() == 3);
  CHECK(full.cols() == 4);
  CHECK((full.array() == 0.f).all());
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

TEST_CASE("stale temporaries of killed writers are removed, live writers' and other files are kept") {
  const fs::path dir = test::scratch_dir("core_stale_tmp");
  fs::remove_all(dir);
  fs::create_directories(dir);
  // A pid that surely ran and ended: a child that exits at once, reaped.
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  const std::string dead = std::to_string(child), live = std::to_string(::getppid());
  const std::string model = (dir / "m.ckpt").string();
  for (const std::string& name : std::vector<std::string>{"m.ckpt", "m.ckpt.tmp." + dead, "m.ckpt.tmp." + live, "m.ckpt.tmp.x1",
                                 "m.ckpt.tmp.", "other.ckpt.tmp." + dead, "m.ckpt.tmp." + dead + ".bak"})
    write_text_atomic((dir / name).string(), "x");
  CHECK(remove_stale_temporaries(model) == 1);
  CHECK_FALSE(fs::exists(dir / ("m.ckpt.tmp." + dead)));
  for (const std::string& name : std::vector<std::string>{"m.ckpt", "m.ckpt.tmp." + live, "m.ckpt.tmp.x1", "m.ckpt.tmp.",
                                 "other.ckpt.tmp." + dead, "m.ckpt.tmp." + dead + ".bak"})
    CHECK(fs::exists(dir / name));
  CHECK(remove_stale_temporaries(model) == 0);
  CHECK(remove_stale_temporaries((dir / "missing" / "m.ckpt").string()) == 0);  // no folder: nothing to do
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

TEST_CASE("FolderLock: one holder at a time, in this process or another, released with its holder") {
  const std::filesystem::path dir = test::scratch_dir("folder_lock") / "shape";
  {
    const FolderLock a(dir.string());
    CHECK(a.locked());
    CHECK(std::filesystem::is_directory(dir));
    const FolderLock b(dir.string());
    CHECK_FALSE(b.locked());
    // Another process cannot take it either (flock: per open file description, inherited by nobody here).
    const pid_t pid = fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      const FolderLock c(dir.string());
      _exit(c.locked() ? 1 : 0);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
  }
  const FolderLock again(dir.string());
  CHECK(again.locked());
  // A path under a regular file cannot be a folder: an IoError naming it.
  write_text_atomic((dir / "file").string(), "x");
  CHECK_THROWS_AS(FolderLock((dir / "file" / "sub").string()), IoError);
}

TEST_CASE("find_referenced_file: texture names as exporters write them are found beside the mesh") {
  const fs::path dir = test::scratch_dir("files_referenced");
  fs::remove_all(dir);
  fs::create_directories(dir / "Textures");
  fs::create_directories(dir / "wood.png");  // a folder named like a texture is never the answer
  write_text_atomic((dir / "Plain001.jpg").string(), "x");
  write_text_atomic((dir / "Textures" / "Wood.JPG").string(), "x");
  const auto found = [&](const std::string& name) {
    const std::string f = find_referenced_file(dir.string(), name);
    return f.empty() ? std::string() : fs::path(f).lexically_relative(dir).string();
  };
  CHECK(found("Plain001.jpg") == "Plain001.jpg");
  CHECK(found("Plain001.jpg\t\t") == "Plain001.jpg");        // an MTL line with trailing tabs
  CHECK(found("  \"plain001.JPG\"\r") == "Plain001.jpg");    // quotes, blanks, another case
  CHECK(found("textures\\wood.jpg") == "Textures/Wood.JPG"); // backslashes, case of every component
  CHECK(found("f:\\models\\chair\\Textures\\wood.jpg") == "Textures/Wood.JPG");  // a drive letter and its folders
  CHECK(found("K:/maps/PLAIN001.jpg") == "Plain001.jpg");
  CHECK(found("/nowhere/on/this/machine/Plain001.jpg") == "Plain001.jpg");
  CHECK(fs::path(find_referenced_file(dir.string(), (dir / "Plain001.jpg").string())) == dir / "Plain001.jpg");
  CHECK(found("wood.png").empty());
  CHECK(found("missing.jpg").empty());
  CHECK(found("").empty());
  CHECK(found(" \t").empty());
  fs::remove_all(dir);
}
