// Consistent face orientation for meshes from the wild: flipped faces and inside-out parts are re-oriented
// before winding numbers decide inside from outside.
#pragma once

#include "core/types.h"

#include <array>
#include <cstdint>
#include <vector>

namespace sdfkit {

struct OrientationReport {
  long flipped_faces = 0;     ///< faces whose winding order was reversed
  long components = 0;        ///< parts connected through manifold edges (edges with exactly two faces)
  long closed_components = 0; ///< parts without boundary or non-manifold edges
  long inverted_components = 0;  ///< closed parts turned inside out (negative volume, not a cavity)
  bool closed = false;        ///< every edge has exactly two faces with opposite directions (after orienting)
};

/// Returns the mesh with faces re-oriented: within each part, faces follow the orientation of the part's
/// lowest-index face across manifold edges; then every part with negative signed volume is flipped as a
/// whole, unless it lies inside the other parts (an inner shell bounding a cavity keeps its orientation).
Mesh orient_consistently(const Mesh& mesh, OrientationReport* report = nullptr);

/// True when every undirected edge is used by exactly two faces in opposite directions (closed, oriented,
/// edge-manifold). Says nothing about self-intersections.
bool is_closed_oriented(const Mesh& mesh);

/// For a closed, consistently oriented mesh (is_closed_oriented): per face and edge k (corner k -> corner k + 1),
/// the face across that edge. Empty when the mesh is not closed and consistently oriented. Linear time.
std::vector<std::array<int32_t, 3>> closed_edge_neighbours(const Mesh& mesh);

/// True when every undirected edge is traversed as often in one direction as in the other (closed parts,
/// possibly non-manifold, overlapping or self-intersecting; edges of zero length ignored). False when the mesh
/// has boundary edges.
bool edges_balanced(const Mesh& mesh);

}  // namespace sdfkit
