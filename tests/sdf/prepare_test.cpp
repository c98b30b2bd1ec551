#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "scratch.h"
#include "sdf/prepare.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

#include <filesystem>

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
