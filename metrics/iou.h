// Volumetric IoU of two meshes, two ways (docs/eval.md):
//  - voxel_iou: solid voxelisations on DISN's grid. A cell is "surface" when a triangle overlaps it (exact
//    triangle/box separating-axis test); the exterior is flood-filled (6-connected) from a one-cell border around
//    the grid; solid = not exterior (surface cells included). Works for closed meshes; an open mesh whose holes
//    are larger than a cell leaks and fills as its surface shell only.
//  - point_iou (Occupancy Networks): uniform points in the padded bounding box of both meshes, inside iff the
//    generalized winding number exceeds 0.5 (sdf/winding.h), which is robust for open meshes and soups.
#pragma once

#include "core/types.h"

#include <cstdint>
#include <vector>

namespace sdfkit {

/// Grid of `resolution`^3 cells; a point v falls in cell floor((v - origin) / extent * resolution) per axis.
/// Defaults are DISN's indexing: (v + 1.1) / 2.4 * 110, i.e. cells of 2.4/110 covering [-1.1, 1.3)^3 of the
/// object frame. Geometry outside the grid is ignored.
struct VoxelGridSpec {
  double origin = -1.1;
  double extent = 2.4;
  int resolution = 110;
  [[nodiscard]] double cell() const { return extent / resolution; }
};

/// Solid occupancy, x fastest: index = (z * res + y) * res + x.
struct VoxelGrid {
  VoxelGridSpec spec;
  std::vector<uint8_t> solid;
  [[nodiscard]] long count() const;
};

/// Throws InvalidInput (naming `what`) if the mesh is empty or not finite.
VoxelGrid voxelize_solid(const Mesh& mesh, const VoxelGridSpec& spec = {}, const std::string& what = "mesh");
/// |A and B| / |A or B| of two grids with the same spec (1 when both are empty).
double voxel_iou(const VoxelGrid& a, const VoxelGrid& b);
double voxel_iou(const Mesh& pred, const Mesh& gt, const VoxelGridSpec& spec = {});

/// Exact overlap test of a triangle and an axis-aligned box (separating axes: 3 box normals, the triangle normal,
/// 9 edge cross products). Touching counts as overlapping.
bool triangle_box_overlap(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& box_center,
                          const Vec3& half_size);

struct PointIouSettings {
  long points = 100000;    ///< uniform points (Occupancy Networks: 100k)
  double padding = 0.05;   ///< box = union bounding box grown by padding x its extent on each side
  double beta = 2.0;       ///< winding-number accuracy (sdf/winding.h)
};

struct PointIou {
  double iou = 0;
  long inside_pred = 0, inside_gt = 0, inside_both = 0, points = 0;
  Box3 box;
};

/// IoU estimated from uniform points; deterministic given `seed`. Because the points are uniform in a box that
/// contains both shapes, the ratio is an unbiased estimate of the volume IoU whatever the padding.
PointIou point_iou(const Mesh& pred, const Mesh& gt, uint64_t seed, const PointIouSettings& settings = {});

}  // namespace sdfkit
