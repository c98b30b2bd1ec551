// Open single-sided sheets (a sling seat, a cane back, a leaf, a sheet of paper): surfaces with no inside on
// either side. Their signed distance never goes negative, so the iso-surface that prep takes as the ground truth
// (the SDF at +0.003, DISN's level) is a shell 0.006 thick around them, thinner than one voxel of the 257^3
// lattice (0.0094): marching cubes misses it between lattice points and gt.obj is full of holes, and the DISN
// samples say that no point near the sheet is inside. prep gives each such face a thickness first.
#pragma once

#include "core/types.h"

#include <vector>

namespace sdfkit {

/// Faces with no inside on either side, in parts with a rim (faces connected through shared edges, one of whose
/// edges has a single face: a sheet always has one; a closed part, even a non-manifold soup of touching boxes, has
/// none, and a face of it that looks outside on both sides is a mis-oriented face, not a sheet): the generalized
/// winding number of the whole mesh (sdf/winding.h), probed at
/// `probe` on both sides of the face's centroid along its normal, is at most 0.5 on both, so the winding-number sign
/// (inside iff w > 0.5) calls both sides outside (a face of a closed surface has about 1 on its inner side, a lone
/// flat sheet just under +-0.5). Degenerate faces are never sheets. One flag per face.
std::vector<char> open_sheet_faces(const Mesh& mesh, double probe, double winding_beta = 2.0);

struct SheetReport {
  long sheet_faces = 0;  ///< faces found to be open sheets, each given a prism
};

/// The mesh plus a closed slab of half-thickness `half_thickness` around its open sheet faces (open_sheet_faces at
/// `probe`), listed twice, so that signs and iso-surfaces see a solid about 2 * half_thickness thick. Faces whose
/// normal agrees with each corner's (creases under about 60 degrees) share offset vertices, moved by
/// +-half_thickness along the corner's angle-weighted normal over the sheet faces: a top and a bottom layer joined
/// by walls along the region's rim (edges not shared by two such faces in opposite directions); any other sheet face
/// (a fold, an inconsistently oriented neighbour) gets a prism of its own along its normal. The sheet faces themselves
/// stay (the mesh's vertices and faces come first, unchanged): a closed slab adds nothing to the winding number
/// outside itself, so every point outside the slabs keeps its sign and its distance, and inside a slab the winding
/// number is at least 2 - 0.5 (the sheet's own +-0.5 near it): inside, robustly. Inside a slab the distance is to
/// the nearer of the sheet and the slab's walls (at most half_thickness off). Offset vertices take the colour of the
/// vertex they come from. A mesh without rims (closed parts, possibly many, possibly touching) is returned unchanged
/// without probing.
Mesh thicken_open_sheets(const Mesh& mesh, double half_thickness, double probe, SheetReport* report = nullptr,
                         double winding_beta = 2.0);

}  // namespace sdfkit
