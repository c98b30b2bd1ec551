#include "core/error.h"
#include "core/files.h"
#include "core/io/points.h"
#include "core/random.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

using namespace sdfkit;
namespace fs = std::filesystem;

TEST_CASE("xyz: first three numbers of each line, with comments, blank lines, extra columns and CRLF") {
  const std::string text =
      "# x y z nx ny nz\n"
      "1 2 3\n"
      "\n"
      "   \t\r\n"
      "-0.5\t0.25 1e-3 0 0 1 # a normal after the position\n"
      "+4 5. .5\r\n"
      "7 8 9";  // no final line break
  const Points p = parse_xyz(text, "pts.xyz");
  REQUIRE(p.rows() == 4);
  CHECK(p.row(0) == Eigen::RowVector3d(1, 2, 3));
  CHECK(p.row(1) == Eigen::RowVector3d(-0.5, 0.25, 1e-3));
  CHECK(p.row(2) == Eigen::RowVector3d(4, 5, 0.5));
  CHECK(p.row(3) == Eigen::RowVector3d(7, 8, 9));
}

TEST_CASE("xyz: numbers printed with 17 significant digits read back bit for bit") {
  Rng rng(7);
  Points ref(200, 3);
  std::string text;
  char buf[96];
  for (Eigen::Index i = 0; i < ref.rows(); ++i) {
    for (int k = 0; k < 3; ++k) ref(i, k) = rng.normal() * std::pow(10.0, rng.uniform(-8, 8));
    std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g\n", ref(i, 0), ref(i, 1), ref(i, 2));
    text += buf;
  }
  const Points p = parse_xyz(text, "random.xyz");
  REQUIRE(p.rows() == ref.rows());
  CHECK((p.array() == ref.array()).all());
}

TEST_CASE("xyz: a bad line is refused with one line naming the file and the line number") {
  const auto refused = [](const std::string& text, const std::string& expect) {
    CAPTURE(text);
    try {
      (void)parse_xyz(text, "cloud.xyz");
      FAIL("accepted");
    } catch (const Error& e) {
      const std::string what = e.what();
      CHECK(what.rfind("cloud.xyz: ", 0) == 0);
      CHECK(what.find(expect) != std::string::npos);
      CHECK(what.find('\n') == std::string::npos);
    }
  };
  refused("0 0 0\n1 2\n", "line 2: expected three numbers");
  refused("0 0 0\n\n1,2,3\n", "line 3: expected three numbers");
  refused("x y z\n0 0 0\n", "line 1: expected three numbers x y z separated by blanks, got 'x y z'");
  refused("1.5f 2 3\n", "line 1: expected three numbers");
  refused("0 0 0\n1 2 3abc\n", "line 2: expected three numbers");  // glued text is not an extra column
  refused("0 0 0\n1 2 3\n4 5 nan\n", "line 3: non-finite coordinates");
  refused("nan 0 0\n", "line 1: non-finite coordinates");
  refused("1 inf 0\n", "line 1: non-finite coordinates");
  refused("1 1e999 0\n", "line 1: non-finite coordinates");  // overflows to infinity
  refused(std::string("1 2\0 3\n", 7), "line 1: expected three numbers");
  refused("", "no points");
  refused("# only a comment\n\n", "no points");
  // The message quotes at most 40 characters of the line and nothing unprintable.
  refused(std::string(100, 'a') + "\n", "got '" + std::string(40, 'a') + "...'");
  refused("\x01\x02 1 2\n", "got '?? 1 2'");
  CHECK_THROWS_AS((void)parse_xyz("1 2\n", "c.xyz"), IoError);
  CHECK_THROWS_AS((void)parse_xyz("1 2 nan\n", "c.xyz"), InvalidInput);
  CHECK_THROWS_AS((void)parse_xyz("", "c.xyz"), InvalidInput);
}

TEST_CASE("read_point_cloud: .xyz, .txt and .npy (first three columns), other extensions and bad arrays refused") {
  const fs::path dir = test::scratch_dir("points_io");
  write_text_atomic((dir / "a.xyz").string(), "1 2 3\n4 5 6\n");
  write_text_atomic((dir / "a.TXT").string(), "1 2 3\n4 5 6\n");
  MatrixXfR wide(2, 4);
  wide << 1, 2, 3, 9, 4, 5, 6, 9;
  write_npy((dir / "a.npy").string(), wide);
  Points expect(2, 3);
  expect << 1, 2, 3, 4, 5, 6;
  for (const char* name : {"a.xyz", "a.TXT", "a.npy"}) {
    CAPTURE(name);
    CHECK(has_point_cloud_extension(name));
    const Points p = read_point_cloud((dir / name).string());
    CHECK(p.rows() == 2);
    CHECK((p.array() == expect.array()).all());
  }
  CHECK_FALSE(has_point_cloud_extension("a.obj"));

  const std::string narrow = (dir / "narrow.npy").string();
  write_npy(narrow, MatrixXfR::Ones(3, 2));
  CHECK_THROWS_WITH_AS(read_point_cloud(narrow), doctest::Contains((narrow + ": .npy point cloud needs N x 3").c_str()),
                       IoError);
  const std::string nan = (dir / "nan.npy").string();
  MatrixXfR bad = MatrixXfR::Zero(2, 3);
  bad(1, 2) = std::numeric_limits<float>::quiet_NaN();
  write_npy(nan, bad);
  CHECK_THROWS_WITH_AS(read_point_cloud(nan), doctest::Contains((nan + ": non-finite").c_str()), InvalidInput);
  const std::string obj = (dir / "a.obj").string();
  CHECK_THROWS_WITH_AS(read_point_cloud(obj), doctest::Contains((obj + ": unknown point cloud extension").c_str()),
                       IoError);
  const std::string absent = (dir / "absent.xyz").string();
  CHECK_THROWS_WITH_AS(read_xyz(absent), doctest::Contains("absent.xyz"), IoError);
}
