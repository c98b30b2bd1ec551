// A procedural shape: a polygon soup of closed parts with per-part colours, plus the record of which faces
// belong to which part (so tests can check every part and measure features such as slat thickness).
#pragma once

#include "core/types.h"

#include <string>
#include <vector>

namespace sdfkit {

/// One closed part of a shape: its role name (e.g. "back_slat", "leg") and its vertex and face ranges.
struct PartInfo {
  std::string name;
  Eigen::Index first_vertex = 0, num_vertices = 0;
  Eigen::Index first_face = 0, num_faces = 0;
};

struct SynthShape {
  Mesh mesh;                    ///< all parts concatenated (not merged), colours per vertex
  std::vector<PartInfo> parts;  ///< in the order they were added
};

/// Collects parts; every vertex of a part gets the part's colour.
class ShapeBuilder {
 public:
  void add(const std::string& name, const Mesh& part, const Vec3f& color);
  [[nodiscard]] SynthShape build() const;
  [[nodiscard]] size_t num_parts() const { return parts_.size(); }

 private:
  std::vector<Mesh> meshes_;
  std::vector<Vec3f> colors_;
  std::vector<std::string> names_;
  std::vector<PartInfo> parts_;
};

/// The faces of part `i` of `shape` as a mesh of its own (vertex indices rebased to the part).
Mesh part_mesh(const SynthShape& shape, size_t i);

}  // namespace sdfkit
