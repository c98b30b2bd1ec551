// Hard-case meshes shared by the sdf/ tests (one property looped over every case).
#pragma once

#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "core/types.h"

#include <functional>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

namespace sdfkit::test {

/// Faces of `m` whose centroid satisfies `keep`.
inline Mesh filter_faces(const Mesh& m, const std::function<bool(const Vec3&)>& keep) {
  Mesh out;
  out.V = m.V;
  std::vector<Eigen::Index> rows;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Vec3 c = (m.V.row(m.F(f, 0)) + m.V.row(m.F(f, 1)) + m.V.row(m.F(f, 2))).transpose() / 3.0;
    if (keep(c)) rows.push_back(f);
  }
  out.F.resize(static_cast<Eigen::Index>(rows.size()), 3);
  for (size_t i = 0; i < rows.size(); ++i) out.F.row(static_cast<Eigen::Index>(i)) = m.F.row(rows[i]);
  return out;
}

/// Box [-0.5, 0.5]^3 scaled by `s` without its top (+z) face.
inline Mesh open_box(double s = 0.5) {
  return filter_faces(make_box(Vec3::Constant(-s), Vec3::Constant(s)), [s](const Vec3& c) { return c.z() < 0.99 * s; });
}

/// Every k-th face reversed.
inline Mesh flip_every(Mesh m, int k) {
  for (Eigen::Index f = 0; f < m.F.rows(); f += k) std::swap(m.F(f, 1), m.F(f, 2));
  return m;
}

/// A cabinet [-0.5, 0.5]^3 of closed slabs `wall` thick (back, sides, bottom, top) closed in front (+z) by two doors
/// with a gap `gap` between them at x = 0, as one soup: the exact sign calls the hollow outside whatever the gap.
inline Mesh slab_cabinet(double gap, double wall = 0.06) {
  const double s = 0.5, t = wall;
  const std::pair<Vec3, Vec3> slabs[] = {
      {Vec3(-s, -s, -s), Vec3(s, s, -s + t)},     {Vec3(-s, -s, -s), Vec3(-s + t, s, s)},
      {Vec3(s - t, -s, -s), Vec3(s, s, s)},       {Vec3(-s, -s, -s), Vec3(s, -s + t, s)},
      {Vec3(-s, s - t, -s), Vec3(s, s, s)},       {Vec3(-s, -s, s - t), Vec3(-gap / 2, s, s)},
      {Vec3(gap / 2, -s, s - t), Vec3(s, s, s)}};
  Mesh m = make_box(slabs[0].first, slabs[0].second);
  for (size_t i = 1; i < std::size(slabs); ++i) m = concatenate(m, make_box(slabs[i].first, slabs[i].second));
  return m;
}

/// A case: mesh and what a person expects: signed distance where defined (nullptr = only the sign test).
struct Case {
  std::string name;
  Mesh mesh;
  std::function<double(const Vec3&)> sdf;     ///< exact SDF of the solid a person sees
  std::function<int(const Vec3&)> expected;   ///< -1 inside, +1 outside, 0 = don't care
};

inline std::vector<Case> hard_cases() {
  std::vector<Case> cases;
  const Vec3 c0(0.05, -0.03, 0.02);
  cases.push_back({"sphere", make_icosphere(c0, 0.6, 4), [c0](const Vec3& p) { return sphere_sdf(p, c0, 0.6); }, {}});
  const Vec3 lo(-0.6, -0.4, -0.3), hi(0.5, 0.45, 0.35);
  cases.push_back({"box", make_box(lo, hi), [lo, hi](const Vec3& p) { return box_sdf(p, lo, hi); }, {}});
  cases.push_back({"torus", make_torus(Vec3::Zero(), 0.55, 0.2, 96, 48),
                   [](const Vec3& p) { return torus_sdf(p, Vec3::Zero(), 0.55, 0.2); }, {}});
  cases.push_back({"flipped faces", flip_every(make_icosphere(c0, 0.6, 4), 7),
                   [c0](const Vec3& p) { return sphere_sdf(p, c0, 0.6); }, {}});
  {
    Mesh inv = make_box(lo, hi);
    inv.F.col(1).swap(inv.F.col(2));
    cases.push_back({"inside-out box", inv, [lo, hi](const Vec3& p) { return box_sdf(p, lo, hi); }, {}});
  }
  {  // Open box: inside negative away from the hole, outside positive away from the hole's column.
    const double s = 0.5;
    cases.push_back({"open box", open_box(s), nullptr, [s](const Vec3& p) {
                       const double d = box_sdf(p, Vec3::Constant(-s), Vec3::Constant(s));
                       if (d < -0.05 && p.z() < s - 0.2) return -1;
                       if (d > 0.05 && p.z() < s - 0.05) return 1;
                       return 0;
                     }});
  }
  {  // Two interpenetrating closed boxes as one soup: the union is the solid.
    const Vec3 a0(-0.6, -0.3, -0.3), a1(0.2, 0.3, 0.3), b0(-0.1, -0.5, -0.2), b1(0.6, 0.1, 0.4);
    auto u = [=](const Vec3& p) { return std::min(box_sdf(p, a0, a1), box_sdf(p, b0, b1)); };
    cases.push_back({"interpenetrating soup", concatenate(make_box(a0, a1), make_box(b0, b1)), nullptr,
                     [u](const Vec3& p) {
                       const double d = u(p);
                       return d < -0.01 ? -1 : (d > 0.01 ? 1 : 0);
                     }});
    // Outside the union the nearest soup point lies on the union's boundary: exact SDF there.
    cases.back().sdf = [u](const Vec3& p) { return u(p) > 0 ? u(p) : std::nan(""); };
  }
  {  // Duplicate and zero-area triangles on a sphere.
    Mesh m = make_icosphere(c0, 0.6, 4);
    const Eigen::Index nf = m.F.rows();
    m.F.conservativeResize(nf + 40, 3);
    for (int i = 0; i < 20; ++i) m.F.row(nf + i) = m.F.row(i * 17);
    for (int i = 0; i < 20; ++i) m.F.row(nf + 20 + i) << m.F(i, 0), m.F(i, 0), m.F(i, 1);
    cases.push_back({"duplicate and zero-area faces", m, [c0](const Vec3& p) { return sphere_sdf(p, c0, 0.6); }, {}});
  }
  {  // A plate thinner than a voxel.
    const Vec3 p0(-0.5, -0.4, -0.002), p1(0.5, 0.4, 0.002);
    cases.push_back({"thin plate", make_box(p0, p1), [p0, p1](const Vec3& p) { return box_sdf(p, p0, p1); }, {}});
  }
  return cases;
}

}  // namespace sdfkit::test
