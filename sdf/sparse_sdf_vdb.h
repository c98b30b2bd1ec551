// The OpenVDB grid inside a SparseSdf, for code that works with OpenVDB directly (e.g. sparse marching
// cubes over the active leaves). Including this header pulls in OpenVDB: do it from .cpp files only.
#pragma once

#include "sdf/sealed.h"
#include "sdf/sparse_sdf.h"

#include <openvdb/openvdb.h>

namespace sdfkit {

struct SparseSdf::Impl {
  openvdb::FloatGrid::Ptr grid;  ///< never null; treated as immutable once wrapped
  std::shared_ptr<const SealedCavities> sealed;  ///< the cavities the signs took as inside (seal), else null
};

/// The grid (shared, read-only). Index (i, j, k) sits at world position voxel_size * ((i, j, k) - offset), see
/// grid_index_offset.
inline openvdb::FloatGrid::ConstPtr vdb_grid(const SparseSdf& sdf) { return sdf.impl().grid; }

/// Wrap an existing grid (it must not be modified afterwards). Throws InvalidInput if null or not uniform.
SparseSdf sparse_sdf_from_grid(openvdb::FloatGrid::Ptr grid, std::shared_ptr<const SealedCavities> sealed = nullptr);

/// Grids built by sdfkit shift their index space by this many voxels on each axis, so that the object frame's
/// [-1.2, 1.2]^3 box lies inside one of OpenVDB's 4096^3 top-level nodes: around index 0 it would straddle
/// eight of them (~270 KB each). Index (i, j, k) sits at voxel_size * ((i, j, k) - offset).
constexpr int32_t kGridIndexOffset = 2048;

/// The index offset of a grid, read from its transform (0 for grids without one): index (i, j, k) sits at
/// voxel_size * ((i, j, k) - offset).
openvdb::Coord grid_index_offset(const openvdb::FloatGrid& grid);

/// openvdb::initialize() once per process (thread-safe).
void ensure_openvdb_initialized();

}  // namespace sdfkit
