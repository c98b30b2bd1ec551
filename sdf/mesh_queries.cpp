#include "sdf/mesh_queries.h"

#include "core/error.h"
#include "sdf/orientation.h"

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

namespace sdfkit {

MeshQueries::MeshQueries(const Mesh& mesh, SignMethod sign, double spacing, double winding_beta)
    : mesh_(mesh), beta_(winding_beta) {
  require(!mesh.empty() && mesh.F.rows() > 0, "mesh queries: empty mesh");
  distance_ = std::make_unique<MeshDistance>(mesh_);
  boundary_free_ = edges_balanced(mesh_);
  sign_ = sign;
  if (sign == SignMethod::kAuto || sign == SignMethod::kPseudoNormal) {
    sign_ = SignMethod::kWindingNumber;
    if (pseudo_normal_sign_applies(mesh_)) {
      normals_.emplace(mesh_);
      // Explicit PseudoNormal: no agreement test (as resolve_sign_method).
      // The agreement guard counts ray crossings (exact here: closed meshes have balanced edges), so that closed
      // meshes never build the winding-number hierarchy they do not use.
      const auto tree = [this]() -> const WindingNumber& { return winding(); };
      const auto agree = [&] {
        return boundary_free_ ? pseudo_normal_agrees_with_rays(mesh_, *distance_, *normals_, spacing, tree, 256)
                              : pseudo_normal_agrees_with_winding(mesh_, *distance_, *normals_, spacing, winding(), 256);
      };
      if (sign == SignMethod::kPseudoNormal || agree())
        sign_ = SignMethod::kPseudoNormal;
      else
        normals_.reset();
    }
  }
}

const WindingNumber& MeshQueries::winding() const {
  std::call_once(*winding_once_, [this] { winding_.emplace(mesh_, beta_); });
  return *winding_;
}

}  // namespace sdfkit
