// A sparse signed distance field: an OpenVDB FloatGrid level set (narrow band of exact distances around the
// surface, inside/outside tiles beyond it) hidden behind a small value type. Include sdf/sparse_sdf_vdb.h
// for the underlying openvdb::FloatGrid.
#pragma once

#include "core/files.h"
#include "core/types.h"

#include <memory>
#include <string>

namespace sdfkit {

/// How the sign of the distance is decided.
enum class SignMethod {
  WindingNumber,  ///< inside iff generalized winding number > 0.5: open, soup, self-intersecting meshes
  None,           ///< unsigned distances (no inside)
};

struct SparseSdfSettings {
  double voxel_size = 2.4 / 256;  ///< DISN: 256 cells over [-1.2, 1.2]; voxel centres at integer multiples
  /// Half-width of the stored band in object units. DISN supervises |sdf - 0.003| <= 0.1; the default adds
  /// the 0.003 offset and ~1.8 voxels so that continuous samples near 0.1 are surrounded by band voxels.
  double band = 0.12;
  SignMethod sign = SignMethod::WindingNumber;
  double winding_beta = 2.0;       ///< accuracy of the hierarchical winding numbers
  /// Make face orientation consistent per connected part first (sdf/orientation.h) so that flipped faces and
  /// inside-out parts do not corrupt the winding number.
  bool orient_faces = true;
};

/// What the construction did (for reports and benchmarks).
struct SparseSdfStats {
  long winding_evaluations = 0;  ///< winding numbers computed for voxels and tiles
  long band_voxels = 0;          ///< voxels whose sign was decided
  long inside_tiles = 0;         ///< 8^3 tiles marked inside beyond the band
  long flipped_faces = 0;        ///< faces re-oriented before signing
};

class SparseSdf {
 public:
  SparseSdf();  ///< an empty field (every value = +background)

  /// Build from a mesh (any frame; the grid uses the mesh's coordinates). Exact unsigned distances in the
  /// band come from OpenVDB's mesh-to-volume (closest triangle per voxel); signs from winding numbers,
  /// evaluated only where the sign can change (see docs/prep.md). Throws InvalidInput for bad settings or
  /// an empty mesh; `progress` may cancel (throws sdfkit::Error "cancelled").
  static SparseSdf from_mesh(const Mesh& mesh, const SparseSdfSettings& settings = {}, SparseSdfStats* stats = nullptr,
                             const ProgressFn& progress = {});

  /// Trilinear interpolation of the grid at p (object units). Beyond the band: +-background.
  [[nodiscard]] double value(const Vec3& p) const;
  /// Batch value() (TBB), row i -> value i.
  [[nodiscard]] Eigen::VectorXd values(const Points& P) const;
  /// Value stored at voxel (i, j, k), i.e. at position voxel_size * (i, j, k).
  [[nodiscard]] double voxel(int i, int j, int k) const;

  [[nodiscard]] double voxel_size() const;
  [[nodiscard]] double background() const;  ///< |value| beyond the band
  [[nodiscard]] long active_voxel_count() const;
  [[nodiscard]] size_t memory_bytes() const;
  /// Index bounds (inclusive) of the active voxels; invalid Box3 when empty. Positions = index * voxel_size.
  [[nodiscard]] Box3 active_index_bounds() const;

  /// Write a .vdb holding one FloatGrid named "sdf" (class level set). Byte-identical for identical grids
  /// (the file UUID is derived from the content). Atomic. Throws IoError naming the path.
  void write(const std::string& path) const;
  /// Read the grid named "sdf" (or the only FloatGrid) of a .vdb file. Throws IoError naming the path.
  static SparseSdf read(const std::string& path);

  struct Impl;
  [[nodiscard]] const Impl& impl() const { return *impl_; }
  explicit SparseSdf(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

 private:
  std::shared_ptr<const Impl> impl_;
};

}  // namespace sdfkit
