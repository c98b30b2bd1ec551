#include "extract/marching_cubes_vdb.h"

#include "core/error.h"
#include "core/primitives.h"
#include "extract/band_grid.h"
#include "mesh_checks.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <cmath>
#include <cstdio>
#include <unistd.h>
#include <functional>
#include <string>

using namespace sdfkit;
using sdfkit::test::bad_edges;
using sdfkit::test::euler_characteristic;

namespace {

/// Narrow band (|d| <= 3 voxels active) of an analytic SDF, index (i, j, k) at voxel * (i, j, k).
openvdb::FloatGrid::Ptr band_of(const std::function<double(const Vec3&)>& f, double voxel, int lo, int hi) {
  const float bg = static_cast<float>(3 * voxel);
  auto g = openvdb::FloatGrid::create(bg);
  g->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
  g->setGridClass(openvdb::GRID_LEVEL_SET);
  auto acc = g->getAccessor();
  for (int k = lo; k <= hi; ++k)
    for (int j = lo; j <= hi; ++j)
      for (int i = lo; i <= hi; ++i) {
        const double d = f(voxel * Vec3(i, j, k));
        if (std::abs(d) <= 3 * voxel) acc.setValue(openvdb::Coord(i, j, k), static_cast<float>(d));
      }
  openvdb::tools::signedFloodFill(g->tree());
  return g;
}

/// The dense grid over the band's active bounding box (+1 voxel), inactive voxels at their (signed) background.
DenseGrid dense_of(const openvdb::FloatGrid& g, openvdb::Coord& min) {
  const openvdb::CoordBBox box = g.evalActiveVoxelBoundingBox();
  min = box.min() - openvdb::Coord(1);
  const openvdb::Coord dim = box.dim() + openvdb::Coord(2);
  const openvdb::Vec3d o = g.transform().indexToWorld(min);
  DenseGrid d(Vec3(o.x(), o.y(), o.z()), g.voxelSize()[0], dim.x(), dim.y(), dim.z());
  auto acc = g.getConstAccessor();
  for (int k = 0; k < d.nz; ++k)
    for (int j = 0; j < d.ny; ++j)
      for (int i = 0; i < d.nx; ++i) d.at(i, j, k) = acc.getValue(min.offsetBy(i, j, k));
  return d;
}

void check_same_as_dense(const openvdb::FloatGrid& g, double iso) {
  openvdb::Coord min;
  const DenseGrid d = dense_of(g, min);
  const Mesh dense = marching_cubes(d, {iso, false});
  const Mesh sparse = marching_cubes(g, {iso, false});
  REQUIRE(dense.F.rows() > 100);
  CHECK(sparse.F == dense.F);  // same triangles, same order, same vertex numbering
  REQUIRE(sparse.V.rows() == dense.V.rows());
  CHECK((sparse.V - dense.V).cwiseAbs().maxCoeff() < 1e-12);
}

}  // namespace

TEST_CASE("sparse band MC of a VDB level-set sphere: closed, Euler 2, on the sphere, same as dense") {
  openvdb::initialize();
  const float r = 0.5f;
  const openvdb::Vec3f c(0.02f, -0.01f, 0.03f);
  auto g = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(r, c, 0.01f, 3.0f);
  MarchingCubesStats st;
  const Mesh m = marching_cubes(*g, {}, &st);
  CHECK(bad_edges(m) == 0);
  CHECK(euler_characteristic(m) == 2);
  CHECK(sdfkit::test::degenerate_faces(m) == 0);
  double worst = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    worst = std::max(worst, std::abs((m.V.row(v).transpose() - Vec3(c.x(), c.y(), c.z())).norm() - r));
  CHECK(worst < 1e-3);
  CHECK(signed_volume(m) == doctest::Approx(4.0 / 3.0 * M_PI * r * r * r).epsilon(3e-3));
  check_same_as_dense(*g, 0.0);
  check_same_as_dense(*g, 0.003);  // DISN's iso value
}

TEST_CASE("sparse band MC of a torus band: Euler 0, same as dense") {
  openvdb::initialize();
  auto g = band_of([](const Vec3& p) { return torus_sdf(p, Vec3::Zero(), 0.5, 0.15); }, 0.02, -40, 40);
  const Mesh m = marching_cubes(*g);
  CHECK(bad_edges(m) == 0);
  CHECK(euler_characteristic(m) == 0);
  check_same_as_dense(*g, 0.0);
}

TEST_CASE("band grids without OpenVDB in the caller: from a dense grid, through a .vdb file") {
  openvdb::initialize();
  DenseGrid d(Vec3(-1, -1, -1), 2.0 / 63, 64, 64, 64);
  for (int k = 0; k < 64; ++k)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) d.at(i, j, k) = static_cast<float>(sphere_sdf(d.point(i, j, k), Vec3::Zero(), 0.6));
  const BandGrid band = BandGrid::from_dense(d, 3.0);
  CHECK(band.active_voxels() > 0);
  CHECK(band.active_voxels() < long(d.size()) / 5);
  const Mesh sparse = band.extract();
  const Mesh dense = marching_cubes(d, {0.0, false});
  CHECK(sparse.F == dense.F);
  CHECK((sparse.V - dense.V).cwiseAbs().maxCoeff() < 1e-12);

  const std::string path = (test::scratch_dir("extract_band") / "band.vdb").string();
  {
    openvdb::io::File file(path);
    file.write({std::const_pointer_cast<openvdb::FloatGrid>(
        std::static_pointer_cast<const openvdb::FloatGrid>(band.grid()))});
    file.close();
  }
  const BandGrid back = BandGrid::read(path, "sdf");
  CHECK(back.active_voxels() == band.active_voxels());
  CHECK(back.extract().F == sparse.F);
  CHECK_THROWS_AS(BandGrid::read(path, "nope"), IoError);
  std::remove(path.c_str());
  CHECK_THROWS_AS(BandGrid::read("/nonexistent/x.vdb"), IoError);
}
