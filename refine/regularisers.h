// Mesh regularisers with their gradients, as PyTorch3D defines them for mesh fitting (the refinement paper's
// generator losses): edge length, normal consistency, uniform Laplacian smoothing. Each returns the loss and adds
// weight * d loss / d V to `grad` (#V x 3, same rows as V).
#pragma once

#include "core/types.h"

#include <array>
#include <cstdint>
#include <vector>

namespace sdfkit {

/// The connectivity the regularisers need, built once per topology.
struct MeshTopology {
  /// Unique undirected edges (a < b).
  std::vector<std::array<int32_t, 2>> edges;
  /// Interior edges shared by exactly two faces: the two faces, and whether the second one runs the edge in the
  /// same direction as the first (inconsistent orientation: its normal is flipped for the comparison).
  struct FacePair {
    int32_t f0 = 0, f1 = 0;
    bool flip = false;
  };
  std::vector<FacePair> face_pairs;
  /// Vertex neighbours (CSR): vertex v's are neighbours[offsets[v] .. offsets[v + 1]).
  std::vector<int64_t> offsets;
  std::vector<int32_t> neighbours;
};

/// Throws InvalidInput for indices outside [0, num_vertices).
MeshTopology mesh_topology(const Faces& F, Eigen::Index num_vertices);

/// Mean over edges of |v_a - v_b|^2 (target length 0, as PyTorch3D's mesh_edge_loss).
double edge_length_loss(const Points& V, const MeshTopology& topo, double weight, Points& grad);

/// Mean over interior edges of 1 - n0 . n1, the unit normals of the edge's two faces (mesh_normal_consistency).
/// Degenerate faces (zero area) contribute no gradient.
double normal_consistency_loss(const Points& V, const Faces& F, const MeshTopology& topo, double weight, Points& grad);

/// Mean over vertices of |mean of the neighbours - v| (uniform Laplacian, mesh_laplacian_smoothing "uniform");
/// isolated vertices count 0.
double laplacian_loss(const Points& V, const MeshTopology& topo, double weight, Points& grad);

}  // namespace sdfkit
