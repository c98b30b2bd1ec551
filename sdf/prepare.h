// The per-shape preparation pipeline of `sdfkit prep` as one library call: read and validate a mesh, normalise
// it to the unit-sphere object frame, build the sparse SDF, draw the DISN samples and write the ground-truth
// surface, every file atomically, norm.json last (its presence marks a complete shape).
#pragma once

#include "core/files.h"
#include "core/mesh_io.h"
#include "sdf/normalize.h"
#include "sdf/symmetry.h"
#include "sdf/samples.h"
#include "sdf/sparse_sdf.h"

#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

/// How gt.obj is made.
enum class GtSource {
  kAuto,        ///< the normalised input when it is closed, oriented and one part; otherwise the iso-surface
  kInput,       ///< always the normalised input mesh
  kIsoSurface,  ///< always the iso-surface of the SDF at `gt_iso`
};

struct PrepareSettings {
  SparseSdfSettings grid;
  SampleSettings samples;
  GtSource gt = GtSource::kAuto;
  double gt_iso = 0.003;  ///< DISN's level for the iso-surface ground truth
  /// Half-thickness given to open single-sided sheets (sdf/sheets.h), in voxels; 0 = none. With 0.5 the ground
  /// truth around a sheet is a slab 2 * (0.5 voxel + gt_iso) = 1.6 voxels thick, which the lattice cannot miss.
  /// Meshes without boundary edges are never changed.
  double sheet_voxels = 0.5;
  bool overwrite = false; ///< redo a shape even when its norm.json exists
  UpAxis up = UpAxis::kY; ///< the mesh file's up axis (prepare_shape turns it to +y first; norm.json records it)
};

struct PrepareStatus {
  bool skipped = false;     ///< already complete (norm.json present) with the same settings, and not overwritten
  /// A complete shape prepared again because its norm.json records other settings: their keys (prepared_differences).
  std::vector<std::string> redone;
  bool frame_changed = false;  ///< redone with another up axis: the object frame moved (views made before are stale)
  std::string shape_dir;
  MeshReport mesh;          ///< validation counts
  long flipped_faces = 0;
  bool closed_input = false;
  long sheet_faces = 0;     ///< faces of open single-sided sheets given a thickness (sdf/sheets.h)
  std::string gt_source;    ///< "input" or "iso"
  SignMethod sign = SignMethod::kNone;  ///< sign method used for the grid and the samples
  long active_voxels = 0;
  size_t grid_bytes = 0;
  SampleReport samples;
  double seconds = 0;       ///< wall time of this shape
  /// Wall seconds per stage: validate + normalise + orient, grid (SparseSdfStats has its stages), samples,
  /// gt mesh, files.
  double seconds_mesh = 0, seconds_samples = 0, seconds_gt = 0, seconds_files = 0;
  SparseSdfStats grid;
};

/// The files of a prepared shape folder.
struct ShapeFiles {
  std::string norm, sdf, samples, gt;
  std::string symmetries;  ///< symmetries.json: prepared_shape_symmetries' cache (not written by prep)
  explicit ShapeFiles(const std::string& shape_dir);
};

/// True when `shape_dir` holds a complete prepared shape (norm.json is written last).
bool shape_is_complete(const std::string& shape_dir);

/// Where a complete prepared shape came from, as its norm.json records it.
struct PreparedSource {
  std::string path;          ///< the source mesh file ("source")
  UpAxis up = UpAxis::kY;    ///< its up axis ("up"; +y when absent)
  Normalization norm;        ///< the map from its +y-up frame to the object frame ("norm")
};

/// The source of a complete prepared shape, without reading the mesh: IoError naming norm.json when it cannot be read
/// or records no source, no valid "up" or "norm", or naming the source file when it does not exist. A relative
/// source (recorded from the folder prep ran in) is looked for from the current folder, then from each folder above
/// the shape, nearest first; `path` is where it was found.
PreparedSource prepared_source(const std::string& shape_dir);

/// The mesh a complete prepared shape was made from, in its object frame (the views' frame): prepared_source's file
/// read with `textures` (colours kept), turned to +y up and mapped by its normalization. IoError as prepared_source,
/// or naming the source when it cannot be read.
Mesh read_prepared_source(const std::string& shape_dir, const TextureSampler& textures = {});
/// The same from a source prepared_source already checked (no second read of norm.json).
Mesh read_prepared_source(const PreparedSource& source, const TextureSampler& textures = {});

/// vertical_symmetries of a prepared shape's gt.obj at `tol`, cached in its symmetries.json: the symmetric turns
/// are stored per tolerance together with gt.obj's size and modification time, and reused while both match (finding
/// them reads and tests the whole mesh: about 0.1 s per benchmark shape, minutes for a training split). A missing,
/// unreadable or stale cache is recomputed and rewritten atomically; a folder that cannot be written (a read-only
/// dataset) is just not cached. IoError naming gt.obj when it cannot be read or vertical_symmetries refuses it.
/// `before_search`, when given, is called just before the mesh is read and searched, i.e. whenever no cache entry
/// answers (missing, unreadable, stale, or without `tol`): callers use it to say that a slow step has started.
std::vector<RotationSymmetry> prepared_shape_symmetries(const std::string& shape_dir, double tol,
                                                        const std::function<void()>& before_search = {});

/// The settings that a complete shape's norm.json records differently from `settings` (up, grid.voxel_size,
/// grid.band, grid.sign, grid.sealed, grid.sheet (only for meshes that were not closed), samples.count/offset/edges/uniform/seed, gt.setting, gt.iso), as their
/// norm.json keys; {"norm.json"} when it cannot be read; empty when the shape is what `settings` would make.
/// grid.sign differs only when the recorded method cannot come from the requested one (winding numbers asked and
/// pseudo-normals recorded, say).
std::vector<std::string> prepared_differences(const std::string& shape_dir, const PrepareSettings& settings);

/// Prepare one mesh file into `shape_dir` (created). A shape already complete with the same settings is skipped
/// (unless settings.overwrite); one complete with other settings is prepared again (PrepareStatus::redone). Throws
/// IoError/InvalidInput naming `mesh_path` when the input is unusable; on error nothing is left that looks
/// complete. `progress` may cancel.
PrepareStatus prepare_shape(const std::string& mesh_path, const std::string& shape_dir,
                            const PrepareSettings& settings = {}, const ProgressFn& progress = {});

/// Same, from a mesh already in memory (`source` names it in messages and norm.json).
PrepareStatus prepare_mesh(const Mesh& mesh, const std::string& source, const std::string& shape_dir,
                           const PrepareSettings& settings = {}, const ProgressFn& progress = {});

}  // namespace sdfkit
