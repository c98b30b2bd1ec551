// The OpenVDB grid inside a SparseSdf, for code that works with OpenVDB directly (e.g. sparse marching
// cubes over the active leaves). Including this header pulls in OpenVDB: do it from .cpp files only.
#pragma once

#include "sdf/sparse_sdf.h"

#include <openvdb/openvdb.h>

namespace sdfkit {

struct SparseSdf::Impl {
  openvdb::FloatGrid::Ptr grid;  ///< never null; treated as immutable once wrapped
};

/// The grid (shared, read-only). Index (i, j, k) sits at world position voxel_size * (i, j, k).
inline openvdb::FloatGrid::ConstPtr vdb_grid(const SparseSdf& sdf) { return sdf.impl().grid; }

/// Wrap an existing grid (it must not be modified afterwards). Throws InvalidInput if null or not uniform.
SparseSdf sparse_sdf_from_grid(openvdb::FloatGrid::Ptr grid);

/// openvdb::initialize() once per process (thread-safe).
void ensure_openvdb_initialized();

}  // namespace sdfkit
