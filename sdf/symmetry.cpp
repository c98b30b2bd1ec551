#include "sdf/symmetry.h"

#include "core/error.h"
#include "sdf/distance.h"

#include <cmath>

namespace sdfkit {

Mat3 vertical_turn(int degrees) {
  require(degrees == 90 || degrees == 180 || degrees == 270, "vertical_turn: the angle must be 90, 180 or 270 degrees");
  const double c = degrees == 180 ? -1.0 : 0.0, sn = degrees == 90 ? 1.0 : degrees == 270 ? -1.0 : 0.0;
  Mat3 R;
  R << c, 0, sn, 0, 1, 0, -sn, 0, c;
  return R;
}

std::vector<RotationSymmetry> vertical_symmetries(const Mesh& mesh, double tol) {
  require(!mesh.empty(), "vertical_symmetries: empty mesh");
  require(std::isfinite(tol) && tol > 0, "vertical_symmetries: the tolerance must be positive and finite");
  const MeshDistance dist(mesh);
  // The test points: vertices, then face centres.
  Points P(mesh.V.rows() + mesh.F.rows(), 3);
  P.topRows(mesh.V.rows()) = mesh.V;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    P.row(mesh.V.rows() + f) = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
  std::vector<RotationSymmetry> out;
  for (const int degrees : {90, 180, 270}) {
    RotationSymmetry s;
    s.degrees = degrees;
    s.R = vertical_turn(degrees);
    s.symmetric = true;
    int32_t hint = -1;
    for (Eigen::Index i = 0; i < P.rows() && s.symmetric; ++i) {
      // A point farther than tol from the mesh ends the test: the bound lets the query stop early.
      const ClosestPoint cp = dist.closest(s.R * P.row(i).transpose(), tol, hint);
      if (cp.face < 0) s.symmetric = false;
      else hint = cp.face;
    }
    out.push_back(s);
  }
  return out;
}

std::vector<Mat3> symmetric_rotations(const std::vector<RotationSymmetry>& tested) {
  std::vector<Mat3> out;
  for (const RotationSymmetry& r : tested)
    if (r.symmetric) out.push_back(r.R);
  return out;
}

}  // namespace sdfkit
