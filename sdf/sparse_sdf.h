// A sparse signed distance field: an OpenVDB FloatGrid level set (narrow band of exact distances around the
// surface, inside/outside tiles beyond it) hidden behind a small value type. Include sdf/sparse_sdf_vdb.h
// for the underlying openvdb::FloatGrid.
#pragma once

#include "core/files.h"
#include "core/types.h"

#include <memory>
#include <string>

namespace sdfkit {

class MeshQueries;
class SealedCavities;

/// How the sign of the distance is decided.
enum class SignMethod {
  kWindingNumber,  ///< inside iff generalized winding number > 0.5: open, soup, self-intersecting meshes
  kNone,           ///< unsigned distances (no inside)
  kPseudoNormal,   ///< angle-weighted pseudo-normal at the closest feature: closed, oriented, one-part meshes
  kAuto,           ///< PseudoNormal when it applies (see resolve_sign_method), else WindingNumber
};

/// What `requested` means for `mesh`: Auto becomes PseudoNormal when the mesh is closed, consistently
/// oriented and one part (sdf/pseudonormal.h) and the pseudo-normal sign agrees with the winding number at 256
/// test points 0.5-4 `spacing` off the surface (a guard against self-intersections); else WindingNumber.
/// PseudoNormal (explicit, no agreement test) on a mesh that is not closed, oriented and one part falls back to
/// WindingNumber too. Others are returned as is.
SignMethod resolve_sign_method(const Mesh& mesh, SignMethod requested, double spacing);
/// "winding_number", "pseudo_normal", "none" or "auto".
const char* sign_method_name(SignMethod m);

struct SparseSdfSettings {
  double voxel_size = 2.4 / 256;  ///< DISN: 256 cells over [-1.2, 1.2]; voxel centres at integer multiples
  /// Half-width of the stored band in object units; 0 = 3 voxels (OpenVDB's level-set half width). The DISN
  /// samples (sdf/samples.h) are computed exactly from the mesh and need no wide band; use 0.12 (0.1 + the
  /// 0.003 offset + ~1.8 voxels) when the grid itself must hold every |sdf - 0.003| <= 0.1.
  double band = 0.0;
  SignMethod sign = SignMethod::kAuto;
  double winding_beta = 2.0;       ///< accuracy of the hierarchical winding numbers
  /// Make face orientation consistent per connected part first (sdf/orientation.h) so that flipped faces and
  /// inside-out parts do not corrupt the winding number.
  bool orient_faces = true;
  /// DISN's polygon-soup convention on top of `sign`: cavities that the surface seals at the voxel size (gaps under
  /// about 1.7 voxels, sdf/sealed.h) count as inside. Samples drawn from the grid (disn_samples) follow it.
  bool seal = false;
};

/// What the construction did (for reports and benchmarks).
struct SparseSdfStats {
  long winding_evaluations = 0;  ///< winding numbers computed for voxels and tiles
  long band_voxels = 0;          ///< voxels whose sign was decided
  long inside_tiles = 0;         ///< 8^3 tiles marked inside beyond the band
  long flipped_faces = 0;        ///< faces re-oriented before signing
  SignMethod sign = SignMethod::kNone;  ///< the method actually used (Auto resolved)
  long sealed_voxels = 0;        ///< with `seal`: non-wall voxels the exterior flood did not reach
  /// Wall seconds per stage: orient + sign-method choice, exact band (per leaf), leaf insertion, signs.
  double seconds_setup = 0, seconds_topology = 0, seconds_exact = 0, seconds_sign = 0;
};

class SparseSdf {
 public:
  SparseSdf();  ///< an empty field (every value = +background)

  /// Build from a mesh (any frame; the grid uses the mesh's coordinates), in four stages (sparse_sdf.cpp): the
  /// exact unsigned band, built per 8^3 leaf from the triangles whose grown bounding boxes touch it; the band's
  /// signs, from pseudo-normals or winding numbers probed per component of voxels with no surface between them;
  /// the signs applied; inside tiles beyond the band (docs/prep.md). Throws InvalidInput for bad settings or an
  /// empty mesh; `progress` may cancel (throws sdfkit::Error "cancelled").
  static SparseSdf from_mesh(const Mesh& mesh, const SparseSdfSettings& settings = {}, SparseSdfStats* stats = nullptr,
                             const ProgressFn& progress = {});
  /// Same, from a mesh whose query structures are already built (sdf/mesh_queries.h): the sign method is the
  /// one `queries` resolved, and the mesh is taken as it is (settings.sign and settings.orient_faces are not
  /// used). Lets a caller share the structures with disn_samples.
  static SparseSdf from_mesh(const MeshQueries& queries, const SparseSdfSettings& settings = {},
                             SparseSdfStats* stats = nullptr, const ProgressFn& progress = {});

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
  /// The sealed cavities the grid was signed with (SparseSdfSettings::seal), null otherwise and for grids read
  /// from files.
  [[nodiscard]] const SealedCavities* sealed() const;

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
