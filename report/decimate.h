// Vertex-clustering decimation (Rossignac & Borrel 1993): the vertices in one cell of a uniform grid become one
// vertex at their mean (their colours averaged), faces whose corners meet in one cell vanish. Coarse but fast,
// deterministic and colour-preserving: what a page of 500 turnable thumbnails needs, not a mesh to measure.
#pragma once

#include "core/types.h"

namespace sdfkit {

/// `mesh` with at most `max_faces` faces: clustered on the finest grid (cells per longest box side, starting at
/// 256 and shrinking by 1/sqrt(2)) whose result fits; returned as it is when it already fits. Duplicate faces
/// (two triangles on the same three cells) are kept once. InvalidInput when max_faces < 1.
Mesh decimate_to(const Mesh& mesh, long max_faces);

/// One clustering pass on a grid of `cells` cells along the mesh box's longest side.
Mesh cluster_vertices(const Mesh& mesh, int cells);

}  // namespace sdfkit
