// Silhouette carving (space carving with known cameras): the visual hull of a view set, the set of points that
// project inside the object's silhouette in every view, optionally intersected with the solid of a starting mesh.
// `sdfkit refine --carve` starts its optimisation from it: a `recon` mesh loses the volume that some view sees
// through (the slab between a table's legs), which deforming the mesh alone cannot open (it keeps its topology).
//
// The field sampled on a grid is f(p) = max(threshold - min_v alpha_v(p), 0.5 - w(p)): alpha_v(p) is view v's
// silhouette (bilinear, 0 outside the image) at p's projection, w(p) the starting mesh's generalized winding number
// (sdf/winding.h; robust to recon meshes with holes); the surface is its zero level set (marching cubes). Neither
// term is a distance, so the grid is sampled densely.
#pragma once

#include "core/types.h"
#include "refine/refine.h"

#include <vector>

namespace sdfkit {

/// The smallest component a refinement keeps, as a fraction of the largest component's faces: carve's result and
/// `refine --init MESH`'s starting mesh drop the pieces under it (extract/cleanup.h). recon keeps smaller ones
/// (kDefaultKeepFraction), but a piece of a few pixels gets silhouette gradients it cannot follow.
inline constexpr double kRefineKeepFraction = 0.05;

struct CarveSettings {
  int resolution = 129;      ///< grid points per axis over the box
  double threshold = 0.5;    ///< a point is inside a silhouette where the view's alpha is >= this, (0, 1)
  Vec3 box_min = Vec3::Constant(-1.05);  ///< the sampled cube (the unit sphere's box padded by 5%)
  double box_size = 2.1;
  /// Components under this fraction of the largest's faces are dropped (extract/cleanup.h); 0 keeps all.
  double min_component_fraction = kRefineKeepFraction;
  /// With a starting mesh: also add what it misses. The pixels of each view's silhouette that the carved mesh
  /// leaves uncovered, less complete_erode pixels from their edge (the one-pixel slivers a grid leaves along every
  /// contour), are unexplained; every point of the hull whose projection falls on unexplained pixels in
  /// complete_views of the views joins the solid, and the surface is extracted again. A part the starting mesh
  /// lacks (a recon chair without its base) comes back as the hull of what most views show of it.
  bool complete = false;
  int complete_erode = 1;
  /// A hull point joins when its projection is unexplained in at least this many views (more than the views:
  /// all of them); 0 = a majority (n / 2 + 1). One view is too few: a pixel one view misses along a thin part
  /// brings back the whole hull wedge behind it, which matches every silhouette and so stays.
  int complete_views = 0;
};

struct CarveReport {
  long evaluations = 0;      ///< grid points sampled
  long init_faces = 0;       ///< faces of the starting mesh (0 without one)
  long faces = 0, vertices = 0;
  double init_volume = 0;    ///< enclosed volume of the starting mesh (core/primitives.h signed_volume; 0 without one)
  double volume = 0;         ///< enclosed volume of the carved mesh
  /// With CarveSettings::complete: unexplained pixels over all views (after the erosion) and the volume before
  /// they were added (volume is after).
  long unexplained_pixels = 0;
  double carved_volume = 0;
  double seconds = 0;
};

/// Throws InvalidInput naming the bad field.
void validate_carve_settings(const CarveSettings& settings);

/// The carved mesh (no colours). `init` may be null (the visual hull alone; CarveSettings::complete then changes
/// nothing). Throws InvalidInput for no views, bad settings, or when nothing is left (no point inside every
/// silhouette and the starting mesh).
Mesh carve_mesh(const std::vector<TargetView>& views, const Mesh* init, const CarveSettings& settings = {},
                CarveReport* report = nullptr);

/// View v's silhouette at pixel position (x, y) (pixel centres at +0.5), bilinear, 0 outside the image.
double sample_alpha(const Image& alpha, double x, double y);

}  // namespace sdfkit
