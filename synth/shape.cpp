#include "synth/shape.h"

#include "core/error.h"

namespace sdfkit {

void ShapeBuilder::add(const std::string& name, const Mesh& part, const Vec3f& color) {
  require(!part.empty(), "ShapeBuilder::add: part '" + name + "' is empty");
  require(part.V.allFinite(), "ShapeBuilder::add: part '" + name + "' has non-finite coordinates");
  PartInfo info;
  info.name = name;
  info.first_vertex = parts_.empty() ? 0 : parts_.back().first_vertex + parts_.back().num_vertices;
  info.first_face = parts_.empty() ? 0 : parts_.back().first_face + parts_.back().num_faces;
  info.num_vertices = part.V.rows();
  info.num_faces = part.F.rows();
  parts_.push_back(info);
  meshes_.push_back(part);
  colors_.push_back(color.cwiseMax(0.f).cwiseMin(1.f));
  names_.push_back(name);
}

SynthShape ShapeBuilder::build() const {
  require(!parts_.empty(), "ShapeBuilder::build: no parts");
  SynthShape s;
  s.parts = parts_;
  const Eigen::Index nv = parts_.back().first_vertex + parts_.back().num_vertices;
  const Eigen::Index nf = parts_.back().first_face + parts_.back().num_faces;
  s.mesh.V.resize(nv, 3);
  s.mesh.F.resize(nf, 3);
  s.mesh.colors.resize(nv, 3);
  for (size_t i = 0; i < parts_.size(); ++i) {
    const PartInfo& p = parts_[i];
    s.mesh.V.middleRows(p.first_vertex, p.num_vertices) = meshes_[i].V;
    s.mesh.F.middleRows(p.first_face, p.num_faces) =
        meshes_[i].F.array() + static_cast<int32_t>(p.first_vertex);
    s.mesh.colors.middleRows(p.first_vertex, p.num_vertices).rowwise() = colors_[i].transpose();
  }
  return s;
}

Mesh part_mesh(const SynthShape& shape, size_t i) {
  require(i < shape.parts.size(), "part_mesh: part index out of range");
  const PartInfo& p = shape.parts[i];
  Mesh m;
  m.V = shape.mesh.V.middleRows(p.first_vertex, p.num_vertices);
  m.F = shape.mesh.F.middleRows(p.first_face, p.num_faces).array() - static_cast<int32_t>(p.first_vertex);
  if (shape.mesh.has_colors()) m.colors = shape.mesh.colors.middleRows(p.first_vertex, p.num_vertices);
  return m;
}

}  // namespace sdfkit
