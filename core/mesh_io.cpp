#include "core/mesh_io.h"

#include "core/error.h"
#include "core/files.h"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <unordered_set>
#include <vector>

namespace sdfkit {
namespace {

void append_node(const aiScene* scene, const aiNode* node, const aiMatrix4x4& parent, std::vector<Vec3>& V,
                 std::vector<std::array<int32_t, 3>>& F, std::vector<Eigen::Vector3f>& C, bool& all_colored,
                 const std::string& path) {
  const aiMatrix4x4 xf = parent * node->mTransformation;
  for (unsigned mi = 0; mi < node->mNumMeshes; ++mi) {
    const aiMesh* m = scene->mMeshes[node->mMeshes[mi]];
    const auto base = static_cast<int64_t>(V.size());
    const bool colored = m->HasVertexColors(0);
    all_colored = all_colored && colored;
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      const aiVector3D p = xf * m->mVertices[v];
      V.emplace_back(p.x, p.y, p.z);
      if (colored) {
        const aiColor4D c = m->mColors[0][v];
        C.emplace_back(c.r, c.g, c.b);
      } else {
        C.emplace_back(0.7f, 0.7f, 0.7f);
      }
    }
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices < 3) continue;  // points and lines carry no surface
      for (unsigned k = 1; k + 1 < face.mNumIndices; ++k) {  // fan (assimp already triangulated polygons)
        std::array<int64_t, 3> idx{face.mIndices[0], face.mIndices[k], face.mIndices[k + 1]};
        for (int64_t i : idx)
          if (i < 0 || i >= m->mNumVertices) throw InvalidInput(path + ": face index out of range");
        F.push_back({static_cast<int32_t>(base + idx[0]), static_cast<int32_t>(base + idx[1]),
                     static_cast<int32_t>(base + idx[2])});
      }
    }
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c) append_node(scene, node->mChildren[c], xf, V, F, C, all_colored, path);
}

}  // namespace

Mesh read_mesh(const std::string& path, MeshReport* report) {
  const std::string ext = extension_of(path);
  if (ext != "obj" && ext != "ply" && ext != "off" && ext != "stl")
    throw IoError(path + ": unknown mesh extension '." + ext + "' (expected .obj, .ply, .off or .stl)");
  if (!std::filesystem::is_regular_file(path)) throw IoError(path + ": no such file");
  Assimp::Importer importer;
  // Keep lines/points out, keep every face as is: sdfkit counts degenerate faces itself.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "cannot parse";
    throw IoError(path + ": " + why);
  }
  std::vector<Vec3> V;
  std::vector<std::array<int32_t, 3>> F;
  std::vector<Eigen::Vector3f> C;
  bool all_colored = true;
  append_node(scene, scene->mRootNode, aiMatrix4x4(), V, F, C, all_colored, path);
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) mesh.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  mesh.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i)
    mesh.F.row(static_cast<Eigen::Index>(i)) << F[i][0], F[i][1], F[i][2];
  if (all_colored && !V.empty()) {
    mesh.colors.resize(static_cast<Eigen::Index>(C.size()), 3);
    for (size_t i = 0; i < C.size(); ++i) mesh.colors.row(static_cast<Eigen::Index>(i)) = C[i].transpose();
  }
  return validate_mesh(mesh, path, report);
}

Mesh validate_mesh(const Mesh& mesh, const std::string& what, MeshReport* report) {
  if (mesh.V.rows() == 0 || mesh.F.rows() == 0) throw InvalidInput(what + ": empty mesh (no vertices or no faces)");
  if (!mesh.V.allFinite()) throw InvalidInput(what + ": non-finite vertex coordinates (NaN or Inf)");
  const auto nv = static_cast<int32_t>(mesh.V.rows());
  if ((mesh.F.array() < 0).any() || (mesh.F.array() >= nv).any())
    throw InvalidInput(what + ": face index out of range (mesh has " + std::to_string(nv) + " vertices)");
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
  std::vector<char> used(static_cast<size_t>(nv), 0);
  for (Eigen::Index n = 0; n < out.F.size(); ++n) used[static_cast<size_t>(out.F.data()[n])] = 1;
  r.unreferenced_vertices = static_cast<long>(std::count(used.begin(), used.end(), 0));
  if (report) *report = r;
  return out;
}

void write_mesh(const std::string& path, const Mesh& mesh) {
  if (!mesh.V.allFinite()) throw InvalidInput(path + ": refusing to write a mesh with non-finite coordinates");
  const std::string ext = extension_of(path);
  const bool colored = mesh.has_colors();
  if (ext == "obj") {
    write_file_atomic(path, [&](std::ostream& o) {
      char buf[160];
      o << "# sdfkit mesh: " << mesh.V.rows() << " vertices, " << mesh.F.rows() << " faces\n";
      for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
        if (colored)
          std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g %.4g %.4g %.4g\n", mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2),
                        mesh.colors(i, 0), mesh.colors(i, 1), mesh.colors(i, 2));
        else
          std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
        o << buf;
      }
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        o << "f " << mesh.F(f, 0) + 1 << ' ' << mesh.F(f, 1) + 1 << ' ' << mesh.F(f, 2) + 1 << '\n';
    });
  } else if (ext == "ply") {
    write_file_atomic(path, [&](std::ostream& o) {
      o << "ply\nformat binary_little_endian 1.0\ncomment sdfkit\nelement vertex " << mesh.V.rows()
        << "\nproperty float x\nproperty float y\nproperty float z\n";
      if (colored) o << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
      o << "element face " << mesh.F.rows() << "\nproperty list uchar int vertex_indices\nend_header\n";
      for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
        const float p[3] = {static_cast<float>(mesh.V(i, 0)), static_cast<float>(mesh.V(i, 1)),
                            static_cast<float>(mesh.V(i, 2))};
        o.write(reinterpret_cast<const char*>(p), sizeof p);
        if (colored) {
          unsigned char c[3];
          for (int k = 0; k < 3; ++k)
            c[k] = static_cast<unsigned char>(std::clamp(mesh.colors(i, k), 0.f, 1.f) * 255.f + 0.5f);
          o.write(reinterpret_cast<const char*>(c), 3);
        }
      }
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
        const unsigned char n = 3;
        o.write(reinterpret_cast<const char*>(&n), 1);
        const int32_t idx[3] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
        o.write(reinterpret_cast<const char*>(idx), sizeof idx);
      }
    });
  } else if (ext == "off") {
    write_file_atomic(path, [&](std::ostream& o) {
      char buf[128];
      o << "OFF\n" << mesh.V.rows() << ' ' << mesh.F.rows() << " 0\n";
      for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
        std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g\n", mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
        o << buf;
      }
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        o << "3 " << mesh.F(f, 0) << ' ' << mesh.F(f, 1) << ' ' << mesh.F(f, 2) << '\n';
    });
  } else {
    throw InvalidInput(path + ": cannot write mesh with extension '." + ext + "' (use .obj, .ply or .off)");
  }
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
