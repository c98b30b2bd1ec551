#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "scratch.h"
#include "sdf/distance.h"
#include "sdf/normalize.h"
#include "sdf/prepare.h"
#include "sdf/sheets.h"
#include "sdf/winding.h"
#include "test_meshes.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// An open n x n grid of squares (two triangles each) over the map (u, v) in [0, 1]^2 -> point.
Mesh patch(int n, const std::function<Vec3(double, double)>& at) {
  Mesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) m.V.row(i * (n + 1) + j) = at(double(i) / n, double(j) / n);
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + n + 1;
      m.F.row(f++) << a, b, b + 1;
      m.F.row(f++) << a, b + 1, a + 1;
    }
  return m;
}

/// A flat square sheet of side 1.2, tilted about two axes so that it follows no lattice plane.
Mesh tilted_sheet() {
  const Mat3 r = (Eigen::AngleAxisd(0.37, Vec3::UnitX()) * Eigen::AngleAxisd(0.61, Vec3::UnitZ())).toRotationMatrix();
  return patch(12, [&](double u, double v) { return Vec3(r * Vec3(1.2 * (u - 0.5), 0.0, 1.2 * (v - 0.5))); });
}

/// A stool-like chair: four closed legs, two closed side rails and a sling seat hanging between the rails (an open,
/// curved single-sided sheet). Returns the mesh and the number of sling faces (the last faces).
std::pair<Mesh, long> sling_chair() {
  Mesh m = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(-0.42, 0.1, -0.42));
  for (const Vec3& lo : {Vec3(0.42, -0.5, -0.5), Vec3(-0.5, -0.5, 0.42), Vec3(0.42, -0.5, 0.42)})
    m = concatenate(m, make_box(lo, lo + Vec3(0.08, 0.6, 0.08)));
  m = concatenate(m, make_box(Vec3(-0.5, 0.1, -0.5), Vec3(-0.42, 0.18, 0.5)));
  m = concatenate(m, make_box(Vec3(0.42, 0.1, -0.5), Vec3(0.5, 0.18, 0.5)));
  const Mesh sling = patch(16, [](double u, double v) {
    const double x = -0.42 + 0.84 * u;
    return Vec3(x, 0.16 - 0.12 * (1.0 - (x / 0.42) * (x / 0.42)), -0.45 + 0.9 * v);
  });
  return {concatenate(m, sling), static_cast<long>(sling.F.rows())};
}

/// Share of `count` seeded random points on `sheet`'s faces (area-weighted) lying within `reach` of `gt`.
double covered_share(const Mesh& sheet, const Mesh& gt, double reach, int count = 600) {
  const MeshDistance dist(gt);
  std::vector<double> cum;
  double total = 0;
  for (Eigen::Index f = 0; f < sheet.F.rows(); ++f) {
    const Vec3 a = sheet.V.row(sheet.F(f, 0)), b = sheet.V.row(sheet.F(f, 1)), c = sheet.V.row(sheet.F(f, 2));
    cum.push_back(total += 0.5 * (b - a).cross(c - a).norm());
  }
  Rng rng(7);
  int hit = 0;
  for (int k = 0; k < count; ++k) {
    const auto f = static_cast<Eigen::Index>(std::upper_bound(cum.begin(), cum.end(), rng.uniform() * total) -
                                             cum.begin());
    double s = rng.uniform(), t = rng.uniform();
    if (s + t > 1) s = 1 - s, t = 1 - t;
    const Vec3 a = sheet.V.row(sheet.F(f, 0)), b = sheet.V.row(sheet.F(f, 1)), c = sheet.V.row(sheet.F(f, 2));
    if (dist(a + s * (b - a) + t * (c - a)) <= reach) ++hit;
  }
  return double(hit) / count;
}

long count_flags(const std::vector<char>& flags, size_t from, size_t to) {
  long n = 0;
  for (size_t i = from; i < to; ++i) n += flags[i];
  return n;
}

}  // namespace

TEST_CASE("open_sheet_faces: a lone sheet is all sheet, closed parts and an open box's floor are not") {
  const double probe = 0.02;
  const Mesh sheet = tilted_sheet();
  const std::vector<char> s = open_sheet_faces(sheet, probe);
  CHECK(count_flags(s, 0, s.size()) == sheet.F.rows());

  const Mesh box = make_box(Vec3(-0.3, -0.3, -0.3), Vec3(0.3, 0.3, 0.3));
  const std::vector<char> b = open_sheet_faces(box, probe);
  CHECK(count_flags(b, 0, b.size()) == 0);

  // A closed box beside a sheet: exactly the sheet's faces.
  Mesh moved = sheet;
  moved.V.col(0).array() += 2.0;
  const Mesh both = concatenate(box, moved);
  const std::vector<char> bs = open_sheet_faces(both, probe);
  CHECK(count_flags(bs, 0, size_t(box.F.rows())) == 0);
  CHECK(count_flags(bs, size_t(box.F.rows()), bs.size()) == sheet.F.rows());

  // An open box (no top): the winding-number sign calls its hollow inside, so its floor is no sheet.
  const Mesh open = test::open_box();
  const std::vector<char> o = open_sheet_faces(open, probe);
  for (Eigen::Index f = 0; f < open.F.rows(); ++f) {
    const double z = (open.V(open.F(f, 0), 2) + open.V(open.F(f, 1), 2) + open.V(open.F(f, 2), 2)) / 3;
    if (z < -0.49) CHECK(o[size_t(f)] == 0);
  }
}

TEST_CASE("thicken_open_sheets: every sheet face gets a closed outward prism, other meshes are returned as they are") {
  // One triangle: 3 + 6 vertices, 1 + 2 x 8 faces; the prism alone is closed and outward (winding number 1 inside
  // it, 0 beyond it), listed twice; the original face stays.
  Mesh tri;
  tri.V.resize(3, 3);
  tri.V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  tri.F.resize(1, 3);
  tri.F << 0, 1, 2;
  tri.colors.resize(3, 3);
  tri.colors << 1, 0, 0, 0, 1, 0, 0, 0, 1;
  SheetReport rep;
  const double t = 0.05;
  const Mesh out = thicken_open_sheets(tri, t, 0.01, &rep);
  CHECK(rep.sheet_faces == 1);
  REQUIRE(out.V.rows() == 9);
  REQUIRE(out.F.rows() == 17);
  CHECK(out.F.row(0) == tri.F.row(0));
  CHECK(out.colors.rows() == 9);
  for (int v = 3; v < 9; ++v) CHECK(out.colors.row(v) == tri.colors.row((v - 3) / 2));
  Mesh prism = out;
  prism.F = out.F.middleRows(1, 8);
  CHECK(out.F.middleRows(1, 8) == out.F.bottomRows(8));  // wound twice
  const Vec3 c(1.0 / 3, 1.0 / 3, 0);
  CHECK(WindingNumber::brute_force(prism, c) == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(WindingNumber::brute_force(prism, c + Vec3(0, 0, 0.5 * t)) == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(WindingNumber::brute_force(prism, c + Vec3(0, 0, 2 * t)) == doctest::Approx(0.0).epsilon(1e-9));
  CHECK(WindingNumber::brute_force(prism, c - Vec3(0, 0, 2 * t)) == doctest::Approx(0.0).epsilon(1e-9));
  CHECK(signed_volume(prism) == doctest::Approx(0.5 * 2 * t));
  // Inside the slab the whole mesh is inside, outside it the sheet's own +-0.5 remains.
  CHECK(WindingNumber::brute_force(out, c + Vec3(0, 0, 0.5 * t)) > 1.4);
  CHECK(WindingNumber::brute_force(out, c - Vec3(0, 0, 0.5 * t)) > 1.4);
  CHECK(WindingNumber::brute_force(out, c + Vec3(0, 0, 2 * t)) < 0.5);

  // A flat 12 x 12 sheet is one slab: a top and a bottom layer, walls along the 48 rim edges only, twice; the slab
  // is closed (every directed edge has its opposite as often) and the sheet's centre inside it.
  const Mesh sheet = tilted_sheet();
  const Mesh slab = thicken_open_sheets(sheet, t, 0.01, &rep);
  CHECK(rep.sheet_faces == 288);
  REQUIRE(slab.F.rows() == 288 + 2 * (2 * 288 + 2 * 48));
  CHECK(slab.V.rows() == 3 * 169);
  std::map<std::pair<int, int>, int> edges;
  for (Eigen::Index f = 288; f < slab.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++edges[{slab.F(f, k), slab.F(f, (k + 1) % 3)}];
  for (const auto& [e, n] : edges) CHECK(edges[{e.second, e.first}] == n);
  const Vec3 mid = sheet.V.colwise().mean().transpose();
  const Vec3 up = Vec3(slab.V.row(sheet.V.rows() + 2 * 84)) - Vec3(sheet.V.row(84));  // centre vertex's top offset
  CHECK(up.norm() == doctest::Approx(t));
  CHECK(WindingNumber::brute_force(slab, mid + 0.5 * up) > 1.4);
  CHECK(WindingNumber::brute_force(slab, mid - 0.5 * up) > 1.4);
  CHECK(std::abs(WindingNumber::brute_force(slab, mid + 2 * up)) < 0.5);

  // A closed mesh comes back as it is.
  const Mesh box = make_box(Vec3(-1, -1, -1), Vec3(1, 1, 1));
  const Mesh same = thicken_open_sheets(box, t, 0.01, &rep);
  CHECK(rep.sheet_faces == 0);
  CHECK(same.V == box.V);
  CHECK(same.F == box.F);
  CHECK_THROWS_AS(thicken_open_sheets(tri, 0.0, 0.01), sdfkit::InvalidInput);
}

TEST_CASE("prepare: an open sheet's ground truth is a slab around it, not a shell the lattice misses") {
  const fs::path dir = test::scratch_dir("sheets_prepare");
  fs::remove_all(dir);
  PrepareSettings s;
  s.samples.count = 4000;
  s.grid.voxel_size = 0.02;
  s.grid.seal = true;  // prep --sign flood, as the real-mesh data set is prepared
  const Mesh sheet = tilted_sheet();
  const Mesh object = apply_normalization(sheet, unit_sphere_normalization(sheet));
  const double h = s.grid.voxel_size;

  PrepareSettings none = s;
  none.sheet_voxels = 0;
  const PrepareStatus before = prepare_mesh(sheet, "sheet", (dir / "none").string(), none);
  const PrepareStatus after = prepare_mesh(sheet, "sheet", (dir / "slab").string(), s);
  CHECK(before.sheet_faces == 0);
  CHECK(after.sheet_faces == sheet.F.rows());
  // Without thickness the iso-surface at 0.003 exists only where a lattice point falls within 0.003 of the sheet:
  // most of the sheet has no ground truth near it. With half a voxel, all of it does, on both sides.
  Mesh gt_none;
  try {
    gt_none = read_mesh(ShapeFiles((dir / "none").string()).gt);
  } catch (const Error&) {
  }
  const Mesh gt = read_mesh(ShapeFiles((dir / "slab").string()).gt);
  const double reach = (0.5 + 0.5) * h + s.gt_iso;
  CHECK(covered_share(object, gt, reach) == doctest::Approx(1.0));
  MESSAGE("gt area without / with thickness, over twice the sheet's: " << surface_area(gt_none) / (2 * surface_area(object))
          << " / " << surface_area(gt) / (2 * surface_area(object)) << "; covered without: "
          << (gt_none.empty() ? 0.0 : covered_share(object, gt_none, reach)));
  CHECK(surface_area(gt_none) < 0.5 * 2 * surface_area(object));
  CHECK(surface_area(gt) == doctest::Approx(2 * surface_area(object)).epsilon(0.15));
  // The samples agree: the points closer than a quarter voxel to the sheet, away from its rim, are inside (sdf below
  // DISN's level).
  const MatrixXfR S = read_npy(ShapeFiles((dir / "slab").string()).samples);
  Mesh inner = object;  // the sheet's faces more than a tenth of its side from its rim
  inner.F = test::filter_faces(object, [&](const Vec3& c) {
              return (c - object.V.colwise().mean().transpose()).cwiseAbs().maxCoeff() < 0.3;
            }).F;
  const MeshDistance to_sheet(inner);
  long near = 0, inside = 0;
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    if (to_sheet(Vec3(S(i, 0), S(i, 1), S(i, 2))) >= 0.25 * h) continue;
    ++near;
    inside += S(i, 3) < s.gt_iso;
  }
  CHECK(near > 100);
  CHECK(inside == near);
  fs::remove_all(dir);
}

TEST_CASE("prepare: a chair's sling seat is thickened, its closed frame is not") {
  const fs::path dir = test::scratch_dir("sheets_chair");
  fs::remove_all(dir);
  PrepareSettings s;
  s.samples.count = 2000;
  s.grid.voxel_size = 0.02;
  s.grid.seal = true;
  const auto [chair, sling_faces] = sling_chair();
  const PrepareStatus st = prepare_mesh(chair, "chair", dir.string(), s);
  const Normalization norm = unit_sphere_normalization(chair);
  // The winding number fills the sag of the seat (its hollow side looks inside from close by) where it is deep, so
  // the seat is a sheet towards its rims: some of its faces, none of the frame's.
  const std::vector<char> flags = open_sheet_faces(apply_normalization(chair, norm), s.grid.voxel_size);
  const size_t frame = size_t(chair.F.rows() - sling_faces);
  CHECK(count_flags(flags, 0, frame) == 0);
  CHECK(count_flags(flags, frame, flags.size()) == st.sheet_faces);
  CHECK(st.sheet_faces > sling_faces / 8);
  Mesh sling = apply_normalization(chair, norm);
  sling.F = sling.F.bottomRows(sling_faces).eval();
  const Mesh gt = read_mesh(ShapeFiles(dir.string()).gt);
  CHECK(covered_share(sling, gt, 1.0 * s.grid.voxel_size + s.gt_iso) == doctest::Approx(1.0));
  const Json j = read_json(ShapeFiles(dir.string()).norm);
  CHECK(j["grid"]["sheet"].get<double>() == 0.5);
  CHECK(j["grid"]["sheet_faces"].get<long>() == st.sheet_faces);
  fs::remove_all(dir);
}

TEST_CASE("prepare: closed meshes give the same bytes whatever the sheet setting, and norm.json stays valid") {
  const fs::path dir = test::scratch_dir("sheets_closed");
  fs::remove_all(dir);
  PrepareSettings s;
  s.samples.count = 1000;
  s.grid.voxel_size = 0.02;
  const Mesh soup = concatenate(make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, -0.4, 0.5)),
                                make_sphere(Vec3(0, 0.2, 0), 0.3, 12, 24));
  PrepareSettings none = s;
  none.sheet_voxels = 0;
  prepare_mesh(soup, "soup", (dir / "a").string(), s);
  prepare_mesh(soup, "soup", (dir / "b").string(), none);
  const ShapeFiles a((dir / "a").string()), b((dir / "b").string());
  CHECK(read_file(a.sdf) == read_file(b.sdf));
  CHECK(read_file(a.samples) == read_file(b.samples));
  CHECK(read_file(a.gt) == read_file(b.gt));
  // A closed mesh prepared before the setting existed (no grid.sheet in norm.json) is still complete ...
  Json j = read_json(a.norm);
  j["grid"].erase("sheet");
  write_json(a.norm, j);
  CHECK(prepared_differences((dir / "a").string(), s).empty());
  // ... an open one is prepared again.
  prepare_mesh(tilted_sheet(), "sheet", (dir / "c").string(), none);
  const std::vector<std::string> diff = prepared_differences((dir / "c").string(), s);
  CHECK(diff == std::vector<std::string>{"grid.sheet"});
  fs::remove_all(dir);
}
