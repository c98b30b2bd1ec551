// Marching cubes over the narrow band of an OpenVDB FloatGrid. This is the only extract/ header that includes
// OpenVDB; code that should not can use extract/band_grid.h.
//
// A cell is extracted when its 8 corners are all active voxels (values known, not background). Its triangles are
// exactly those the dense marching cubes (extract/marching_cubes.h) gives for the same cell with the same values,
// and cells are visited in the same z, y, x order, so a band that covers every crossing cell yields the dense
// mesh: same faces in the same order, vertices equal up to the index -> world transform's rounding.
#pragma once

#include "core/types.h"
#include "extract/marching_cubes.h"

#include <openvdb/openvdb.h>

namespace sdfkit {

/// Marching cubes over the active band of `grid` (`settings.close_boundary` is ignored: there is no padding; a
/// band that encloses the surface gives a closed mesh). Vertices are in world space (the grid's transform).
/// Active tiles are voxelised first. Throws InvalidInput for a band with non-finite values or wider than 2^19
/// voxels from the origin.
Mesh marching_cubes(const openvdb::FloatGrid& grid, const MarchingCubesSettings& settings = {},
                    MarchingCubesStats* stats = nullptr);

/// A level-set band of a dense grid: points with |value - iso| <= half_width_voxels * voxel become active voxels
/// (index (i, j, k) = dense point (i, j, k), transform = the dense grid's origin and voxel), the rest inactive
/// with the sign-correct background +-half_width_voxels * voxel (about iso).
openvdb::FloatGrid::Ptr dense_to_band(const DenseGrid& grid, double half_width_voxels, double iso = 0.0);

}  // namespace sdfkit
