// The formats read through assimp (OBJ with its materials and textures, STL, glTF, GLB): sdfkit's structural check
// of the format, then assimp's importer; the scene's parts are flattened into one mesh in the file's global frame.
#include "core/files.h"
#include "core/io/formats.h"
#include "core/glb.h"

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace sdfkit::io {
namespace {

/// The diffuse colour of a mesh's material: glTF's base colour factor, else the diffuse colour (OBJ's Kd). False
/// for assimp's default material (a file without materials) or a material without either.
bool material_diffuse(const aiScene* scene, const aiMesh* m, Eigen::Vector3f& out) {
  if (scene->mMaterials == nullptr || m->mMaterialIndex >= scene->mNumMaterials) return false;
  const aiMaterial* mat = scene->mMaterials[m->mMaterialIndex];
  aiString name;
  if (mat->Get(AI_MATKEY_NAME, name) == AI_SUCCESS && std::string(name.C_Str()) == AI_DEFAULT_MATERIAL_NAME) return false;
  aiColor4D c;
  if (mat->Get(AI_MATKEY_BASE_COLOR, c) != AI_SUCCESS && mat->Get(AI_MATKEY_COLOR_DIFFUSE, c) != AI_SUCCESS) return false;
  const float rgb[3] = {c.r, c.g, c.b};
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(rgb[k])) return false;
    out[k] = std::clamp(rgb[k], 0.f, 1.f);
  }
  return true;
}

/// What append_node needs besides the node: the scene, the file (for messages and texture paths), the texture
/// sampler (may be empty) and the report's texture counts.
struct AssimpInput {
  const aiScene* scene = nullptr;
  std::string path;
  const TextureSampler* textures = nullptr;
  long* textured_parts = nullptr;
  std::vector<std::string>* missing_textures = nullptr;
  bool linear_colours = false;  ///< glTF: COLOR_0 holds linear values, sdfkit's colours are sRGB
};

/// Per-vertex colours of mesh `m` from its material's diffuse (or glTF base colour) texture file, sampled at the
/// vertices' first UV set; false when there is no such texture, no UVs, no sampler, or the texture is embedded or
/// cannot be read (then recorded as missing).
bool texture_colours(const AssimpInput& in, const aiMesh* m, std::vector<Eigen::Vector3f>& out) {
  if (in.textures == nullptr || !*in.textures || !m->HasTextureCoords(0)) return false;
  if (in.scene->mMaterials == nullptr || m->mMaterialIndex >= in.scene->mNumMaterials) return false;
  const aiMaterial* mat = in.scene->mMaterials[m->mMaterialIndex];
  aiString tex;
  if (mat->GetTexture(aiTextureType_BASE_COLOR, 0, &tex) != AI_SUCCESS &&
      mat->GetTexture(aiTextureType_DIFFUSE, 0, &tex) != AI_SUCCESS)
    return false;
  std::string name = tex.C_Str();
  if (name.empty() || name[0] == '*') return false;  // embedded (GLB): not read
  // Found as exporters mean it (blanks, backslashes, drive letters, case: core/files.h). A missing or unreadable
  // file is reported once, however many parts use it.
  const std::string folder = std::filesystem::path(in.path).parent_path().string();
  const std::string file = find_referenced_file(folder, name);
  const auto missing = [&](const std::string& what) {
    if (in.missing_textures &&
        std::find(in.missing_textures->begin(), in.missing_textures->end(), what) == in.missing_textures->end())
      in.missing_textures->push_back(what);
    return false;
  };
  if (file.empty()) {
    std::string shown = name;
    while (!shown.empty() && std::isspace(static_cast<unsigned char>(shown.back()))) shown.pop_back();
    return missing((std::filesystem::path(folder) / shown).string());
  }
  std::vector<Eigen::Vector2f> uv(m->mNumVertices);
  for (unsigned v = 0; v < m->mNumVertices; ++v) uv[v] = {m->mTextureCoords[0][v].x, m->mTextureCoords[0][v].y};
  try {
    out = (*in.textures)(file, uv);
  } catch (const Error&) {
    return missing(file);
  }
  if (out.size() != uv.size()) return false;
  if (in.textured_parts) ++*in.textured_parts;
  return true;
}

void append_node(const AssimpInput& in, const aiNode* node, const aiMatrix4x4& parent, std::vector<Vec3>& V,
                 std::vector<std::array<int32_t, 3>>& F, std::vector<Eigen::Vector3f>& C, bool& all_colored) {
  const aiScene* scene = in.scene;
  const aiMatrix4x4 xf = parent * node->mTransformation;
  for (unsigned mi = 0; mi < node->mNumMeshes; ++mi) {
    const aiMesh* m = scene->mMeshes[node->mMeshes[mi]];
    const auto base = static_cast<int64_t>(V.size());
    const bool colored = m->HasVertexColors(0);
    std::vector<Eigen::Vector3f> textured;
    const bool from_texture = !colored && texture_colours(in, m, textured);
    Eigen::Vector3f material_colour;
    const bool from_material = !colored && !from_texture && material_diffuse(scene, m, material_colour);
    all_colored = all_colored && (colored || from_texture || from_material);
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      const aiVector3D p = xf * m->mVertices[v];
      V.emplace_back(p.x, p.y, p.z);
      if (colored) {
        const aiColor4D c = m->mColors[0][v];
        if (in.linear_colours) C.emplace_back(linear_to_srgb(c.r), linear_to_srgb(c.g), linear_to_srgb(c.b));
        else C.emplace_back(c.r, c.g, c.b);
      } else if (from_texture) {
        C.push_back(textured[v]);
      } else if (from_material) {
        C.push_back(material_colour);
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
          if (i < 0 || i >= m->mNumVertices) throw InvalidInput(in.path + ": face index out of range");
        F.push_back({static_cast<int32_t>(base + idx[0]), static_cast<int32_t>(base + idx[1]),
                     static_cast<int32_t>(base + idx[2])});
      }
    }
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c) append_node(in, node->mChildren[c], xf, V, F, C, all_colored);
}

}  // namespace

void check_structure(const std::string& path, const std::string& ext) {
  const std::string data = read_file(path);
  if (data.find_first_not_of(" \t\r\n") == std::string::npos) fail_io(path, "empty file");
  if (ext == "gltf") check_gltf_json(path, data, "the file");
  if (ext == "glb" && data.compare(0, 4, "glTF") != 0) fail_io(path, "not a binary glTF file (no 'glTF' magic)");
  if (ext == "glb") check_glb(path, data);
  if (ext == "obj") check_obj(path, data);
  else if (ext == "stl") check_stl(path, data);
}

RawMesh read_with_assimp(const std::string& path, const std::string& ext, const TextureSampler& textures,
                         MeshReport& report) {
  check_structure(path, ext);
  Assimp::Importer importer;
  // Keep lines/points out, keep every face as is: sdfkit counts degenerate faces itself.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // No assimp post-processing: assimp 5.2 (Debian 12) segfaults in its post-processing steps on some valid
  // coloured binary PLYs (seen on procedural benchmark shapes). append_node fans polygons into triangles and skips
  // points and lines; read_mesh welds identical vertices.
  const aiScene* scene = importer.ReadFile(path, 0);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    // assimp's reason in sdfkit's words, on one line: "<file>: cannot read mesh: <reason>".
    std::string why = importer.GetErrorString();
    if (why.rfind(path, 0) == 0) why.erase(0, path.size());  // assimp sometimes names the file itself
    std::replace_if(why.begin(), why.end(), [](char c) { return c == '\n' || c == '\r'; }, ' ');
    const size_t start = why.find_first_not_of(" :\t");
    why = start == std::string::npos ? std::string() : why.substr(start);
    while (!why.empty() && why.back() == ' ') why.pop_back();
    throw IoError(path + ": cannot read mesh: " + (why.empty() ? std::string("assimp gives no reason") : why));
  }
  AssimpInput in;
  in.scene = scene;
  in.path = path;
  in.textures = &textures;
  in.textured_parts = &report.textured_parts;
  in.missing_textures = &report.missing_textures;
  in.linear_colours = ext == "gltf" || ext == "glb";
  RawMesh raw;
  append_node(in, scene->mRootNode, aiMatrix4x4(), raw.V, raw.F, raw.C, raw.colored);
  return raw;
}

}  // namespace sdfkit::io
