// The spatial structures that every stage of a shape's preparation queries (exact distances, and the
// pseudo-normals or winding numbers behind the sign), built once per mesh and shared by the sparse grid
// (SparseSdf::from_mesh) and the samples (disn_samples) instead of being rebuilt by each.
#pragma once

#include "core/types.h"
#include "sdf/distance.h"
#include "sdf/pseudonormal.h"
#include "sdf/sparse_sdf.h"
#include "sdf/winding.h"

#include <memory>
#include <mutex>
#include <optional>

namespace sdfkit {

class MeshQueries {
 public:
  /// Resolves `sign` as resolve_sign_method(mesh, sign, spacing) does (Auto: pseudo-normals when the mesh is
  /// closed, oriented, one part and agrees with the winding number at 256 test points) and builds what the
  /// resolved method needs. `mesh` should already be oriented consistently (sdf/orientation.h); it is copied.
  /// Throws InvalidInput for an empty mesh.
  MeshQueries(const Mesh& mesh, SignMethod sign, double spacing, double winding_beta = 2.0);

  [[nodiscard]] const Mesh& mesh() const { return mesh_; }
  /// The resolved method: PseudoNormal, WindingNumber or None.
  [[nodiscard]] SignMethod sign() const { return sign_; }
  [[nodiscard]] const MeshDistance& distance() const { return *distance_; }
  /// Non-null when sign() is PseudoNormal.
  [[nodiscard]] const PseudoNormals* pseudo_normals() const { return normals_ ? &*normals_ : nullptr; }
  /// The winding-number hierarchy (built on first use, thread-safe).
  [[nodiscard]] const WindingNumber& winding() const;
  [[nodiscard]] double winding_beta() const { return beta_; }
  /// True when every edge is crossed as often in one direction as in the other (closed parts, possibly
  /// overlapping or self-intersecting): the winding number is then an integer off the surface and constant on
  /// any connected set the surface does not cross. False for open meshes (boundary edges).
  [[nodiscard]] bool boundary_free() const { return boundary_free_; }

 private:
  Mesh mesh_;
  SignMethod sign_ = SignMethod::kNone;
  double beta_ = 2.0;
  bool boundary_free_ = false;
  std::unique_ptr<MeshDistance> distance_;
  std::optional<PseudoNormals> normals_;
  mutable std::optional<WindingNumber> winding_;
  mutable std::unique_ptr<std::once_flag> winding_once_ = std::make_unique<std::once_flag>();
};

}  // namespace sdfkit
