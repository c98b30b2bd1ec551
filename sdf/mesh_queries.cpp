#include "sdf/mesh_queries.h"

#include "core/error.h"

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

namespace sdfkit {

MeshQueries::MeshQueries(const Mesh& mesh, SignMethod sign, double spacing, double winding_beta)
    : mesh_(mesh), beta_(winding_beta) {
  require(!mesh.empty() && mesh.F.rows() > 0, "mesh queries: empty mesh");
  distance_ = std::make_unique<MeshDistance>(mesh_);
  {
    // Directed edges as (undirected key, +-1); every key must sum to zero.
    std::vector<std::pair<uint64_t, int>> e;
    e.reserve(static_cast<size_t>(mesh_.F.rows()) * 3);
    for (Eigen::Index f = 0; f < mesh_.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const auto a = static_cast<uint32_t>(mesh_.F(f, k)), b = static_cast<uint32_t>(mesh_.F(f, (k + 1) % 3));
        if (a == b) continue;
        e.emplace_back((static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b), a < b ? 1 : -1);
      }
    std::sort(e.begin(), e.end());
    boundary_free_ = true;
    for (size_t i = 0; i < e.size() && boundary_free_;) {
      int sum = 0;
      size_t j = i;
      for (; j < e.size() && e[j].first == e[i].first; ++j) sum += e[j].second;
      boundary_free_ = sum == 0;
      i = j;
    }
  }
  sign_ = sign;
  if (sign == SignMethod::Auto || sign == SignMethod::PseudoNormal) {
    sign_ = SignMethod::WindingNumber;
    if (pseudo_normal_sign_applies(mesh_)) {
      normals_.emplace(mesh_);
      // Explicit PseudoNormal: no agreement test (as resolve_sign_method).
      if (sign == SignMethod::PseudoNormal || pseudo_normal_agrees_with_winding(mesh_, *distance_, *normals_, spacing,
                                                                                winding(), 256))
        sign_ = SignMethod::PseudoNormal;
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
