#include "metrics/iou.h"

#include "core/error.h"
#include "core/random.h"
#include "sdf/winding.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace sdfkit {
namespace {

void check_mesh(const Mesh& mesh, const std::string& what) {
  require(!mesh.empty(), what + ": empty mesh (no faces or no vertices)");
  require(mesh.V.allFinite(), what + ": non-finite (NaN or infinite) vertex coordinate");
  require(mesh.F.minCoeff() >= 0 && mesh.F.maxCoeff() < mesh.V.rows(), what + ": face index out of range");
}

// Projections of the triangle (p0..p2) and of the box (radius r) on an axis must overlap.
bool axis_overlaps(const Vec3& axis, const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& h) {
  const double a = axis.dot(p0), b = axis.dot(p1), c = axis.dot(p2);
  const double r = h.x() * std::abs(axis.x()) + h.y() * std::abs(axis.y()) + h.z() * std::abs(axis.z());
  return !(std::min({a, b, c}) > r || std::max({a, b, c}) < -r);
}

}  // namespace

bool triangle_box_overlap(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& box_center,
                          const Vec3& half_size) {
  const Vec3 p0 = a - box_center, p1 = b - box_center, p2 = c - box_center;
  // Box face normals = the coordinate axes: the triangle's bounding box against the box.
  for (int d = 0; d < 3; ++d)
    if (std::min({p0[d], p1[d], p2[d]}) > half_size[d] || std::max({p0[d], p1[d], p2[d]}) < -half_size[d])
      return false;
  const std::array<Vec3, 3> edges = {p1 - p0, p2 - p1, p0 - p2};
  // Triangle normal (skipped when the triangle is degenerate: the edge axes then decide).
  const Vec3 n = edges[0].cross(edges[1]);
  if (n.squaredNorm() > 0 && !axis_overlaps(n, p0, p1, p2, half_size)) return false;
  for (const Vec3& e : edges)
    for (int d = 0; d < 3; ++d) {
      const Vec3 axis = Vec3::Unit(d).cross(e);
      if (axis.squaredNorm() == 0) continue;
      if (!axis_overlaps(axis, p0, p1, p2, half_size)) return false;
    }
  return true;
}

long VoxelGrid::count() const {
  long c = 0;
  for (uint8_t s : solid) c += s;
  return c;
}

VoxelGrid voxelize_solid(const Mesh& mesh, const VoxelGridSpec& spec, const std::string& what) {
  check_mesh(mesh, what);
  require(spec.resolution >= 1 && spec.resolution <= 2048 && spec.extent > 0, "voxel grid: bad resolution or extent");
  const int res = spec.resolution, pad = res + 2;  // padded grid: cell (x, y, z) of the grid is (x+1, y+1, z+1)
  const double h = spec.cell();
  auto pidx = [pad](int x, int y, int z) { return (static_cast<size_t>(z) * pad + y) * pad + x; };
  std::vector<uint8_t> state(static_cast<size_t>(pad) * pad * pad, 0);  // 0 unknown, 1 surface, 2 exterior
  const Vec3 half = Vec3::Constant(0.5 * h);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    int lo[3], hi[3];
    bool outside = false;
    for (int d = 0; d < 3; ++d) {
      const double mn = (std::min({a[d], b[d], c[d]}) - spec.origin) / h;
      const double mx = (std::max({a[d], b[d], c[d]}) - spec.origin) / h;
      // Cells touching the triangle's box (a face exactly on a cell boundary touches both cells).
      lo[d] = std::max(0, static_cast<int>(std::ceil(mn)) - 1);
      hi[d] = std::min(res - 1, static_cast<int>(std::floor(mx)));
      if (lo[d] > hi[d]) outside = true;
    }
    if (outside) continue;
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          uint8_t& s = state[pidx(x + 1, y + 1, z + 1)];
          if (s == 1) continue;
          const Vec3 center(spec.origin + (x + 0.5) * h, spec.origin + (y + 0.5) * h, spec.origin + (z + 0.5) * h);
          if (triangle_box_overlap(a, b, c, center, half)) s = 1;
        }
  }
  // Exterior flood fill from the border (always exterior: it lies outside the grid).
  std::vector<size_t> stack = {pidx(0, 0, 0)};
  state[stack[0]] = 2;
  const long strides[3] = {1, pad, static_cast<long>(pad) * pad};
  while (!stack.empty()) {
    const size_t i = stack.back();
    stack.pop_back();
    const int x = static_cast<int>(i % pad), y = static_cast<int>((i / pad) % pad), z = static_cast<int>(i / pad / pad);
    const int coord[3] = {x, y, z};
    for (int d = 0; d < 3; ++d)
      for (int s = -1; s <= 1; s += 2) {
        const int nc = coord[d] + s;
        if (nc < 0 || nc >= pad) continue;
        const size_t j = static_cast<size_t>(static_cast<long>(i) + s * strides[d]);
        if (state[j] == 0) {
          state[j] = 2;
          stack.push_back(j);
        }
      }
  }
  VoxelGrid g;
  g.spec = spec;
  g.solid.assign(static_cast<size_t>(res) * res * res, 0);
  for (int z = 0; z < res; ++z)
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x)
        g.solid[(static_cast<size_t>(z) * res + y) * res + x] = state[pidx(x + 1, y + 1, z + 1)] != 2;
  return g;
}

double voxel_iou(const VoxelGrid& a, const VoxelGrid& b) {
  require(a.solid.size() == b.solid.size() && a.spec.resolution == b.spec.resolution &&
              a.spec.origin == b.spec.origin && a.spec.extent == b.spec.extent,
          "voxel IoU: grids differ");
  long inter = 0, uni = 0;
  for (size_t i = 0; i < a.solid.size(); ++i) {
    inter += a.solid[i] & b.solid[i];
    uni += a.solid[i] | b.solid[i];
  }
  return uni == 0 ? 1.0 : static_cast<double>(inter) / static_cast<double>(uni);
}

double voxel_iou(const Mesh& pred, const Mesh& gt, const VoxelGridSpec& spec) {
  return voxel_iou(voxelize_solid(pred, spec, "prediction"), voxelize_solid(gt, spec, "ground truth"));
}

PointIou point_iou(const Mesh& pred, const Mesh& gt, uint64_t seed, const PointIouSettings& settings) {
  check_mesh(pred, "prediction");
  check_mesh(gt, "ground truth");
  require(settings.points > 0 && settings.padding >= 0, "point IoU: need points > 0 and padding >= 0");
  PointIou r;
  for (const Mesh* m : {&pred, &gt})
    for (Eigen::Index i = 0; i < m->V.rows(); ++i) r.box.extend(m->V.row(i).transpose());
  const Vec3 grow = settings.padding * r.box.extent();
  r.box.lo -= grow;
  r.box.hi += grow;
  Rng rng(seed);
  Points P(settings.points, 3);
  for (long i = 0; i < settings.points; ++i)
    for (int d = 0; d < 3; ++d) P(i, d) = rng.uniform(r.box.lo[d], r.box.hi[d]);
  const Eigen::VectorXd wp = WindingNumber(pred, settings.beta).query(P);
  const Eigen::VectorXd wg = WindingNumber(gt, settings.beta).query(P);
  long uni = 0;
  for (long i = 0; i < settings.points; ++i) {
    const bool ip = wp(i) > 0.5, ig = wg(i) > 0.5;
    r.inside_pred += ip;
    r.inside_gt += ig;
    r.inside_both += ip && ig;
    uni += ip || ig;
  }
  r.points = settings.points;
  r.iou = uni == 0 ? 1.0 : static_cast<double>(r.inside_both) / static_cast<double>(uni);
  return r;
}

}  // namespace sdfkit
