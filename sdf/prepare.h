// The per-shape preparation pipeline of `sdfkit prep` as one library call: read and validate a mesh, normalise
// it to the unit-sphere object frame, build the sparse SDF, draw the DISN samples and write the ground-truth
// surface, every file atomically, norm.json last (its presence marks a complete shape).
#pragma once

#include "core/files.h"
#include "core/mesh_io.h"
#include "sdf/samples.h"
#include "sdf/sparse_sdf.h"

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
  explicit ShapeFiles(const std::string& shape_dir);
};

/// True when `shape_dir` holds a complete prepared shape (norm.json is written last).
bool shape_is_complete(const std::string& shape_dir);

/// The mesh a complete prepared shape was made from, in its object frame (the views' frame): norm.json's "source"
/// file read with `textures` (colours kept), turned to +y up by its "up" and mapped by its "norm". IoError naming
/// norm.json when it records no source, or naming the source when it cannot be read.
Mesh read_prepared_source(const std::string& shape_dir, const TextureSampler& textures = {});

/// The settings that a complete shape's norm.json records differently from `settings` (up, grid.voxel_size,
/// grid.band, grid.sign, grid.sealed, samples.count/offset/edges/uniform/seed, gt.setting, gt.iso), as their
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
