// read_mesh and write_mesh pick the format by extension (one file per format in core/io/); read_mesh then welds,
// validates and reports. Validation, the up-axis turn and concatenation live here too.
#include "core/mesh_io.h"

#include "core/error.h"
#include "core/files.h"
#include "core/io/formats.h"
#include "core/io/ply.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace sdfkit {
namespace {

/// Merge vertices with bit-identical positions (and colours, when every vertex has one), keeping first-seen order,
/// so that STL and per-face-vertex files become indexed meshes whose parts are connected through shared edges.
void weld_identical_vertices(io::RawMesh& raw) {
  std::vector<Vec3>& V = raw.V;
  std::vector<Eigen::Vector3f>& C = raw.C;
  const bool colored = raw.colored;
  struct Key {
    double p[3];
    float c[3];
    bool operator==(const Key& o) const { return std::memcmp(this, &o, sizeof(Key)) == 0; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      const auto* b = reinterpret_cast<const unsigned char*>(&k);
      size_t h = 1469598103934665603ULL;
      for (size_t i = 0; i < sizeof(Key); ++i) h = (h ^ b[i]) * 1099511628211ULL;
      return h;
    }
  };
  std::unordered_map<Key, int32_t, KeyHash> index;
  index.reserve(V.size());
  std::vector<int32_t> remap(V.size());
  std::vector<Vec3> V2;
  std::vector<Eigen::Vector3f> C2;
  for (size_t i = 0; i < V.size(); ++i) {
    Key k;
    std::memset(&k, 0, sizeof k);
    for (int a = 0; a < 3; ++a) {
      k.p[a] = V[i][a] == 0.0 ? 0.0 : V[i][a];  // -0.0 and 0.0 are the same point
      k.c[a] = colored ? C[i][a] : 0.f;
    }
    const auto [it, inserted] = index.emplace(k, static_cast<int32_t>(V2.size()));
    if (inserted) {
      V2.push_back(V[i]);
      C2.push_back(C[i]);
    }
    remap[i] = it->second;
  }
  for (auto& f : raw.F)
    for (auto& v : f) v = remap[static_cast<size_t>(v)];
  V.swap(V2);
  C.swap(C2);
}

/// A mesh from sdfkit's PLY reader as the other readers hand theirs over (0.7 grey where there are no colours).
io::RawMesh from_mesh(const Mesh& m) {
  io::RawMesh raw;
  raw.V.resize(static_cast<size_t>(m.V.rows()));
  raw.C.assign(raw.V.size(), Eigen::Vector3f::Constant(0.7f));
  raw.F.resize(static_cast<size_t>(m.F.rows()));
  raw.colored = m.has_colors();
  for (size_t i = 0; i < raw.V.size(); ++i) {
    raw.V[i] = m.V.row(static_cast<Eigen::Index>(i)).transpose();
    if (raw.colored) raw.C[i] = m.colors.row(static_cast<Eigen::Index>(i)).transpose();
  }
  for (size_t f = 0; f < raw.F.size(); ++f)
    for (int k = 0; k < 3; ++k) raw.F[f][k] = m.F(static_cast<Eigen::Index>(f), k);
  return raw;
}

Mesh to_mesh(const io::RawMesh& raw) {
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(raw.V.size()), 3);
  for (size_t i = 0; i < raw.V.size(); ++i) mesh.V.row(static_cast<Eigen::Index>(i)) = raw.V[i].transpose();
  mesh.F.resize(static_cast<Eigen::Index>(raw.F.size()), 3);
  for (size_t i = 0; i < raw.F.size(); ++i)
    mesh.F.row(static_cast<Eigen::Index>(i)) << raw.F[i][0], raw.F[i][1], raw.F[i][2];
  if (raw.colored && !raw.V.empty()) {
    mesh.colors.resize(static_cast<Eigen::Index>(raw.C.size()), 3);
    for (size_t i = 0; i < raw.C.size(); ++i) mesh.colors.row(static_cast<Eigen::Index>(i)) = raw.C[i].transpose();
  }
  return mesh;
}

}  // namespace

bool has_mesh_extension(const std::string& path) {
  const std::string e = extension_of(path);
  return e == "obj" || e == "ply" || e == "off" || e == "stl" || e == "gltf" || e == "glb";
}

UpAxis parse_up_axis(const std::string& name) {
  const std::string n = !name.empty() && name[0] == '+' ? name.substr(1) : name;
  if (n == "y" || n == "Y") return UpAxis::kY;
  if (n == "z" || n == "Z") return UpAxis::kZ;
  if (n == "x" || n == "X") return UpAxis::kX;
  throw InvalidInput("up axis '" + name + "': use y, z or x");
}

std::string up_axis_name(UpAxis up) {
  switch (up) {
    case UpAxis::kY: return "y";
    case UpAxis::kZ: return "z";
    case UpAxis::kX: return "x";
  }
  return "y";
}

Mesh to_y_up(const Mesh& mesh, UpAxis up) {
  Mesh out = mesh;
  if (up == UpAxis::kY) return out;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    const double x = mesh.V(i, 0), y = mesh.V(i, 1), z = mesh.V(i, 2);
    if (up == UpAxis::kZ)
      out.V.row(i) << x, z, -y;
    else
      out.V.row(i) << -y, x, z;
  }
  return out;
}

Mesh read_mesh(const std::string& path, MeshReport* report, const TextureSampler& textures) {
  const std::string ext = extension_of(path);
  if (!has_mesh_extension(path))
    throw IoError(path + ": unknown mesh extension '." + ext + "' (expected .obj, .ply, .off, .stl, .gltf or .glb)");
  if (!std::filesystem::is_regular_file(path)) {
    if (std::filesystem::is_directory(path)) throw IoError(path + ": is a folder, not a mesh file");
    throw IoError(path + (std::filesystem::exists(path) ? ": not a regular file" : ": no such file"));
  }
  io::RawMesh raw;
  MeshReport texture_report;
  if (ext == "ply")
    raw = from_mesh(read_ply(path));  // sdfkit's own reader: assimp 5.2 misreads some valid binary PLYs
  else if (ext == "off")
    raw = io::read_off(path);
  else
    raw = io::read_with_assimp(path, ext, textures, texture_report);
  weld_identical_vertices(raw);
  Mesh valid = validate_mesh(to_mesh(raw), path, report);
  if (report != nullptr) {
    report->textured_parts = texture_report.textured_parts;
    report->missing_textures = std::move(texture_report.missing_textures);
  }
  return valid;
}

void check_face_indices(const Mesh& mesh, const std::string& what) {
  const Eigen::Index nv = mesh.V.rows();
  // Face indices are int: with more vertices than an int can count, every non-negative index is in range.
  const int limit = static_cast<int>(std::min<Eigen::Index>(nv, std::numeric_limits<int>::max()));
  if ((mesh.F.array() >= 0).all() && (nv > limit || (mesh.F.array() < limit).all())) return;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.F(f, k) < 0 || mesh.F(f, k) >= nv)
        throw InvalidInput(what + ": face index out of range: face " + std::to_string(f) + " uses vertex " +
                           std::to_string(mesh.F(f, k)) + " of " + std::to_string(nv));
}

Mesh validate_mesh(const Mesh& mesh, const std::string& what, MeshReport* report) {
  if (mesh.V.rows() == 0 || mesh.F.rows() == 0) throw InvalidInput(what + ": empty mesh (no vertices or no faces)");
  if (!mesh.V.allFinite()) throw InvalidInput(what + ": non-finite vertex coordinates (NaN or Inf)");
  check_face_indices(mesh, what);
  MeshReport r;
  r.input_faces = static_cast<long>(mesh.F.rows());
  // Zero-area test relative to the mesh size so that tiny but valid meshes are not emptied.
  const double scale = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
  const double area_eps = 1e-14 * scale * scale;
  struct Key {
    int32_t a, b, c;
    bool operator==(const Key& o) const { return a == o.a && b == o.b && c == o.c; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return (static_cast<size_t>(k.a) * 73856093u) ^ (static_cast<size_t>(k.b) * 19349663u) ^
             (static_cast<size_t>(k.c) * 83492791u);
    }
  };
  std::unordered_set<Key, KeyHash> seen;
  seen.reserve(static_cast<size_t>(mesh.F.rows()) * 2);
  std::vector<Eigen::Index> keep;
  keep.reserve(static_cast<size_t>(mesh.F.rows()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int32_t i = mesh.F(f, 0), j = mesh.F(f, 1), k = mesh.F(f, 2);
    const double area2 = (mesh.V.row(j) - mesh.V.row(i)).cross(mesh.V.row(k) - mesh.V.row(i)).norm();
    if (i == j || j == k || i == k || area2 <= area_eps) {
      ++r.degenerate_faces;
      continue;
    }
    std::array<int32_t, 3> s{i, j, k};
    std::sort(s.begin(), s.end());
    if (!seen.insert({s[0], s[1], s[2]}).second) {
      ++r.duplicate_faces;
      continue;
    }
    keep.push_back(f);
  }
  Mesh out;
  out.V = mesh.V;
  out.colors = mesh.colors;
  out.F.resize(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t n = 0; n < keep.size(); ++n) out.F.row(static_cast<Eigen::Index>(n)) = mesh.F.row(keep[n]);
  if (out.F.rows() == 0) throw InvalidInput(what + ": every face is degenerate");
  std::vector<char> used(static_cast<size_t>(mesh.V.rows()), 0);
  for (Eigen::Index n = 0; n < out.F.size(); ++n) used[static_cast<size_t>(out.F.data()[n])] = 1;
  r.unreferenced_vertices = static_cast<long>(std::count(used.begin(), used.end(), 0));
  if (report) *report = r;
  return out;
}

void write_mesh(const std::string& path, const Mesh& mesh) {
  if (!mesh.V.allFinite()) throw InvalidInput(path + ": refusing to write a mesh with non-finite coordinates");
  const std::string ext = extension_of(path);
  if (ext == "obj")
    io::write_obj(path, mesh);
  else if (ext == "ply")
    io::write_ply(path, mesh);
  else if (ext == "off")
    io::write_off(path, mesh);
  else if (ext == "stl")
    io::write_stl(path, mesh);
  else if (ext == "glb")
    io::write_glb(path, mesh);
  else
    throw InvalidInput(path + ": cannot write mesh with extension '." + ext + "' (use .obj, .ply, .off, .stl or .glb)");
}

Mesh concatenate(const Mesh& a, const Mesh& b) {
  Mesh out;
  out.V.resize(a.V.rows() + b.V.rows(), 3);
  out.V.topRows(a.V.rows()) = a.V;
  out.V.bottomRows(b.V.rows()) = b.V;
  out.F.resize(a.F.rows() + b.F.rows(), 3);
  out.F.topRows(a.F.rows()) = a.F;
  out.F.bottomRows(b.F.rows()) = b.F.array() + static_cast<int32_t>(a.V.rows());
  if (a.has_colors() && b.has_colors()) {
    out.colors.resize(out.V.rows(), 3);
    out.colors.topRows(a.colors.rows()) = a.colors;
    out.colors.bottomRows(b.colors.rows()) = b.colors;
  }
  return out;
}

}  // namespace sdfkit