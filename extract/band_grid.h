// A narrow band of a sampled field stored sparsely (an OpenVDB FloatGrid inside), for code that should not
// include OpenVDB: build it from a dense grid or read it from a .vdb file, extract its surface.
#pragma once

#include "core/types.h"
#include "extract/marching_cubes.h"

#include <memory>
#include <string>

namespace sdfkit {

class BandGrid {
 public:
  /// Band of a dense grid; see dense_to_band in extract/marching_cubes_vdb.h.
  static BandGrid from_dense(const DenseGrid& grid, double half_width_voxels, double iso = 0.0);
  /// The FloatGrid called `name` in a .vdb file (the first float grid when `name` is empty). IoError naming
  /// the file when it cannot be read or holds no such grid.
  static BandGrid read(const std::string& path, const std::string& name = "");

  [[nodiscard]] long active_voxels() const;
  [[nodiscard]] double voxel_size() const;
  /// Marching cubes over the band (extract/marching_cubes_vdb.h).
  [[nodiscard]] Mesh extract(const MarchingCubesSettings& settings = {}, MarchingCubesStats* stats = nullptr) const;

  /// The openvdb::FloatGrid behind (cast with std::static_pointer_cast<const openvdb::FloatGrid>).
  [[nodiscard]] std::shared_ptr<const void> grid() const { return grid_; }

 private:
  std::shared_ptr<const void> grid_;
};

}  // namespace sdfkit
