// The vocabulary of sdfkit, defined once: point/face matrices (row-major N x 3), the triangle Mesh.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

namespace sdfkit {

using Vec3 = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;
using Mat3 = Eigen::Matrix3d;

/// #V by 3 vertex positions (double: geometry is computed in double, networks in float).
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #P by 3 float points (network inputs, sample files).
using PointsF = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #F by 3 vertex indices of triangles.
using Faces = Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #V by 3 per-vertex RGB colours in [0, 1].
using Colors = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// An indexed triangle mesh. Polygon soups are meshes too: nothing here assumes manifoldness,
/// closedness or consistent orientation. `colors` is empty or has one row per vertex.
struct Mesh {
  Points V;
  Faces F;
  Colors colors;

  [[nodiscard]] Eigen::Index num_vertices() const { return V.rows(); }
  [[nodiscard]] Eigen::Index num_faces() const { return F.rows(); }
  [[nodiscard]] bool empty() const { return F.rows() == 0 || V.rows() == 0; }
  [[nodiscard]] bool has_colors() const { return colors.rows() == V.rows() && V.rows() > 0; }
};

/// Axis-aligned box.
struct Box3 {
  Vec3 lo = Vec3::Constant(1e300);
  Vec3 hi = Vec3::Constant(-1e300);
  void extend(const Vec3& p) { lo = lo.cwiseMin(p); hi = hi.cwiseMax(p); }
  [[nodiscard]] bool valid() const { return (lo.array() <= hi.array()).all(); }
  [[nodiscard]] Vec3 center() const { return 0.5 * (lo + hi); }
  [[nodiscard]] Vec3 extent() const { return hi - lo; }
};

}  // namespace sdfkit
