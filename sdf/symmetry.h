// Rotational symmetries of a shape about its vertical axis: the rotations under which a camera cannot be told
// from its turned twin (a table seen from the front and from the back). Used to score pose estimates modulo
// what an image can show (camera/pose_metrics.h, pose_errors_modulo).
#pragma once

#include "core/types.h"

#include <vector>

namespace sdfkit {

struct RotationSymmetry {
  int degrees = 0;           ///< rotation angle about the object frame's +y axis
  Mat3 R = Mat3::Identity();  ///< the rotation, object frame -> object frame
  bool symmetric = false;    ///< the mesh maps onto itself under R, to within the tolerance
};

/// The rotation about +y by a quarter, half or three-quarter turn (degrees 90, 180 or 270; exact entries, no
/// round-off). InvalidInput for any other angle.
Mat3 vertical_turn(int degrees);

/// Tests the rotations about +y by 90, 180 and 270 degrees: a rotation is a symmetry when every vertex and every
/// face centre of `mesh`, rotated, lies within `tol` (object units) of the mesh (exact distances, sdf/distance.h).
/// Deterministic. Throws InvalidInput for an empty mesh or a non-positive or non-finite tolerance.
std::vector<RotationSymmetry> vertical_symmetries(const Mesh& mesh, double tol);

/// The rotations of a vertical_symmetries result that are symmetries (the shape's group less the identity), in its
/// order (90, 180, 270 degrees).
std::vector<Mat3> symmetric_rotations(const std::vector<RotationSymmetry>& tested);

}  // namespace sdfkit
