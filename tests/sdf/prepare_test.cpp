#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "scratch.h"
#include "sdf/normalize.h"
#include "sdf/prepare.h"
#include "sdf/symmetry.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

#include <chrono>
#include <filesystem>
#include <functional>

using namespace sdfkit;
namespace fs = std::filesystem;

TEST_CASE("prepare: writes the four files, norm.json last, complete shapes are skipped, output is reproducible") {
  const fs::path dir = test::scratch_dir("prepare_test");
  fs::remove_all(dir);
  const std::string src = (dir / "src" / "box.obj").string();
  write_mesh(src, make_box(Vec3(1, 2, 3), Vec3(3, 3, 4)));
  PrepareSettings s;
  s.samples.count = 2000;
  s.grid.voxel_size = 0.02;
  s.grid.band = 0.14;
  const PrepareStatus a = prepare_shape(src, (dir / "a").string(), s);
  CHECK_FALSE(a.skipped);
  CHECK(a.gt_source == "input");  // closed, one part
  CHECK(shape_is_complete((dir / "a").string()));
  const ShapeFiles fa((dir / "a").string());
  const Json j = read_json(fa.norm);
  CHECK(j["norm"][0].get<double>() == doctest::Approx(2.0));
  CHECK(j["norm"][3].get<double>() == doctest::Approx(0.5 * Vec3(2, 1, 1).norm()));
  CHECK(j["source_hash"].get<std::string>().size() == 16);
  const MatrixXfR S = read_npy(fa.samples);
  CHECK(S.rows() == 2000);
  CHECK(S.cols() == 4);
  const Mesh gt = read_mesh(fa.gt);
  CHECK(gt.V.rowwise().norm().maxCoeff() == doctest::Approx(1.0).epsilon(1e-6));

  CHECK(prepare_shape(src, (dir / "a").string(), s).skipped);
  const PrepareStatus b = prepare_shape(src, (dir / "b").string(), s);
  const ShapeFiles fb((dir / "b").string());
  for (auto [x, y] : {std::pair{fa.norm, fb.norm}, {fa.sdf, fb.sdf}, {fa.samples, fb.samples}, {fa.gt, fb.gt}})
    CHECK(read_file(x) == read_file(y));
  fs::remove_all(dir);
}

TEST_CASE("prepare --up z: a z-up file is turned to +y before normalising, and norm.json says so") {
  const fs::path dir = test::scratch_dir("prepare_up");
  fs::remove_all(dir);
  const std::string src = (dir / "src" / "tall.obj").string();
  write_mesh(src, make_box(Vec3(0, 0, 0), Vec3(1, 1, 4)));  // tall along the file's z
  PrepareSettings s;
  s.samples.count = 500;
  s.grid.voxel_size = 0.04;
  s.up = UpAxis::kZ;
  prepare_shape(src, (dir / "z").string(), s);
  const ShapeFiles f((dir / "z").string());
  CHECK(read_json(f.norm)["up"] == "z");
  const Mesh gt = read_mesh(f.gt);
  const Eigen::RowVector3d extent = gt.V.colwise().maxCoeff() - gt.V.colwise().minCoeff();
  CHECK(extent.y() == doctest::Approx(4 * extent.x()).epsilon(1e-6));  // the long side is now the height
  CHECK(extent.z() == doctest::Approx(extent.x()).epsilon(1e-6));
  fs::remove_all(dir);
}

TEST_CASE("prepared_source: a relative source is found from the folders above the shape, whatever the current one") {
  const fs::path dir = fs::absolute(test::scratch_dir("prepare_relative"));
  fs::remove_all(dir);
  // A benchmark's layout: ROOT/meshes/box.ply prepared as "meshes/box.ply" from ROOT into ROOT/prepared/box/box_0.
  write_mesh((dir / "meshes" / "box.ply").string(), make_box(Vec3(0, 0, 0), Vec3(1, 2, 1)));
  PrepareSettings s;
  s.samples.count = 200;
  s.grid.voxel_size = 0.05;
  const std::string shape = (dir / "prepared" / "box" / "box_0").string();
  struct Restore {  // the current folder back, whatever happens
    fs::path cwd = fs::current_path();
    ~Restore() { fs::current_path(cwd); }
  } restore;
  fs::current_path(dir);
  prepare_shape("meshes/box.ply", shape, s);
  CHECK(prepared_source(shape).path == "meshes/box.ply");  // from the folder it was prepared in: as recorded
  fs::current_path(dir / "prepared");  // elsewhere: found from the shape's ancestors
  const PreparedSource ps = prepared_source(shape);
  fs::current_path(restore.cwd);
  CHECK(fs::equivalent(ps.path, dir / "meshes" / "box.ply"));
  CHECK(read_prepared_source(ps).V.rows() == read_mesh((dir / "meshes" / "box.ply").string()).V.rows());
  // A relative source found nowhere is still named.
  Json j = read_json(ShapeFiles(shape).norm);
  j["source"] = "meshes/gone.ply";
  write_json(ShapeFiles(shape).norm, j);
  try {
    (void)prepared_source(shape);
    FAIL("missing relative source: expected an error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("meshes/gone.ply") != std::string::npos);
  }
}

TEST_CASE("read_prepared_source: the source mesh in the views' frame with its colours, errors name the file") {
  const fs::path dir = test::scratch_dir("prepare_source");
  fs::remove_all(dir);
  const std::string src = (dir / "src" / "tall.ply").string();
  Mesh tall = make_box(Vec3(0, 0, 0), Vec3(1, 1, 4));
  tall.colors = Colors::Constant(tall.V.rows(), 3, 0.25f);
  tall.colors.col(0).setConstant(0.75f);
  write_mesh(src, tall);
  PrepareSettings s;
  s.samples.count = 500;
  s.grid.voxel_size = 0.04;
  s.up = UpAxis::kZ;
  const std::string shape = (dir / "z").string();
  prepare_shape(src, shape, s);
  const Mesh m = read_prepared_source(shape);
  const Normalization norm = normalization_from_json(read_json(ShapeFiles(shape).norm));
  const PreparedSource ps = prepared_source(shape);  // what norm.json records, without reading the mesh
  CHECK(ps.path == src);
  CHECK(ps.up == UpAxis::kZ);
  CHECK(ps.norm.center == norm.center);
  CHECK(ps.norm.radius == norm.radius);
  const Mesh expect = apply_normalization(to_y_up(read_mesh(src), UpAxis::kZ), norm);
  REQUIRE(m.V.rows() == expect.V.rows());
  CHECK((m.V - expect.V).cwiseAbs().maxCoeff() < 1e-12);
  CHECK(m.V.rowwise().norm().maxCoeff() == doctest::Approx(1.0).epsilon(1e-9));  // the unit sphere
  CHECK(read_prepared_source(ps).V == m.V);  // from the checked source: the same mesh
  const Eigen::RowVector3d extent = m.V.colwise().maxCoeff() - m.V.colwise().minCoeff();
  CHECK(extent.y() == doctest::Approx(4 * extent.x()).epsilon(1e-9));  // turned to +y up
  REQUIRE(m.has_colors());
  CHECK(m.colors(0, 0) == doctest::Approx(0.75f).epsilon(0.01));
  CHECK(m.colors(0, 1) == doctest::Approx(0.25f).epsilon(0.01));
  // No source recorded / a source that is gone: the message names norm.json / the source.
  Json j = read_json(ShapeFiles(shape).norm);
  j.erase("source");
  write_json(ShapeFiles(shape).norm, j);
  try {
    (void)read_prepared_source(shape);
    FAIL("no source: expected an error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find(ShapeFiles(shape).norm) != std::string::npos);
  }
  j["source"] = (dir / "src" / "gone.ply").string();
  write_json(ShapeFiles(shape).norm, j);
  try {
    (void)read_prepared_source(shape);
    FAIL("missing source: expected an error");
  } catch (const Error& e) {
    CHECK(std::string(e.what()).find("gone.ply") != std::string::npos);
  }
  try {  // found before any mesh is read
    (void)prepared_source(shape);
    FAIL("missing source: expected an error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("gone.ply") != std::string::npos);
    CHECK(std::string(e.what()).find(ShapeFiles(shape).norm) != std::string::npos);
  }
  j["source"] = src;
  j["up"] = 3;
  write_json(ShapeFiles(shape).norm, j);
  CHECK_THROWS_AS((void)prepared_source(shape), IoError);
  fs::remove_all(dir);
}

TEST_CASE("prepare: an open box gets the iso-surface as ground truth, closed by the winding-number sign") {
  const fs::path dir = test::scratch_dir("prepare_open");
  fs::remove_all(dir);
  PrepareSettings s;
  s.samples.count = 1000;
  s.grid.voxel_size = 0.02;
  s.grid.band = 0.14;
  const PrepareStatus st = prepare_mesh(test::open_box(), "open box", dir.string(), s);
  CHECK(st.gt_source == "iso");
  const Mesh gt = read_mesh(ShapeFiles(dir.string()).gt);
  // The iso-surface at 0.003 closes the box: its signed volume is about the box's (0.5 / r)^3 in object units.
  CHECK(signed_volume(gt) > 0.3);
  fs::remove_all(dir);
}

TEST_CASE("prepare: bad input names the file and leaves no complete shape") {
  const fs::path dir = test::scratch_dir("prepare_bad");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string empty = (dir / "empty.obj").string();
  write_text_atomic(empty, "");
  CHECK_THROWS_WITH(prepare_shape(empty, (dir / "out").string()), doctest::Contains("empty.obj"));
  CHECK_FALSE(shape_is_complete((dir / "out").string()));
  fs::remove_all(dir);
}

TEST_CASE("prepared_shape_symmetries: found once, read back from symmetries.json, found again when gt.obj changes") {
  const fs::path dir = test::scratch_dir("prepare_symmetries");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const ShapeFiles files(dir.string());
  const auto symmetric = [](const std::vector<RotationSymmetry>& r) {
    std::vector<int> out;
    for (const RotationSymmetry& s : r)
      if (s.symmetric) out.push_back(s.degrees);
    return out;
  };
  // The hook runs exactly when the mesh is searched, i.e. when no cache entry answers.
  int searches = 0;
  const std::function<void()> count = [&searches] { ++searches; };
  CHECK_THROWS_WITH_AS(prepared_shape_symmetries(dir.string(), 0.01), doctest::Contains("gt.obj"), IoError);
  const Mesh oblong = make_box(Vec3(-0.5, -0.3, -0.2), Vec3(0.5, 0.3, 0.2));
  write_mesh(files.gt, oblong);
  const auto first = prepared_shape_symmetries(dir.string(), 0.01, count);
  CHECK(searches == 1);
  REQUIRE(first.size() == 3);
  CHECK(symmetric(first) == std::vector<int>{180});
  CHECK(symmetric(first) == symmetric(vertical_symmetries(oblong, 0.01)));
  CHECK(first[1].R == vertical_turn(180));
  Json cache = read_json(files.symmetries);
  CHECK(cache.at("turns").at("0.01").get<std::vector<int>>() == std::vector<int>{180});
  // The cache is what a second call reads: an edited entry comes back as it is.
  cache["turns"]["0.01"] = std::vector<int>{90, 270};
  write_json(files.symmetries, cache);
  CHECK(symmetric(prepared_shape_symmetries(dir.string(), 0.01, count)) == std::vector<int>{90, 270});
  CHECK(searches == 1);
  // Another tolerance is found and added beside it.
  CHECK(symmetric(prepared_shape_symmetries(dir.string(), 0.05, count)) == std::vector<int>{180});
  CHECK(searches == 2);
  cache = read_json(files.symmetries);
  CHECK(cache.at("turns").size() == 2);
  // A new gt.obj (other size and time): every entry is stale, found again.
  const Mesh square = make_box(Vec3(-0.4, -0.3, -0.4), Vec3(0.4, 0.3, 0.4));
  write_mesh(files.gt, square);
  fs::last_write_time(files.gt, fs::last_write_time(files.gt) + std::chrono::seconds(5));
  CHECK(symmetric(prepared_shape_symmetries(dir.string(), 0.01, count)) == std::vector<int>{90, 180, 270});
  CHECK(searches == 3);
  cache = read_json(files.symmetries);
  CHECK(cache.at("turns").size() == 1);
  // A corrupt cache is rebuilt; a cache that cannot be written (a folder in its place) is skipped.
  write_text_atomic(files.symmetries, "{");
  CHECK(symmetric(prepared_shape_symmetries(dir.string(), 0.01, count)) == std::vector<int>{90, 180, 270});
  CHECK(searches == 4);
  CHECK(read_json(files.symmetries).at("turns").at("0.01").size() == 3);
  fs::remove(files.symmetries);
  fs::create_directories(files.symmetries);
  CHECK(symmetric(prepared_shape_symmetries(dir.string(), 0.01)) == std::vector<int>{90, 180, 270});
  CHECK_THROWS_AS(prepared_shape_symmetries(dir.string(), 0.0), InvalidInput);
  fs::remove_all(dir);
}
