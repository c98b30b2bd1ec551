#include "core/mesh_io.h"

#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/ply_io.h"

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <charconv>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <array>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace sdfkit {
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
  std::replace(name.begin(), name.end(), '\\', '/');
  const std::filesystem::path file = std::filesystem::path(in.path).parent_path() / name;
  std::vector<Eigen::Vector2f> uv(m->mNumVertices);
  for (unsigned v = 0; v < m->mNumVertices; ++v) uv[v] = {m->mTextureCoords[0][v].x, m->mTextureCoords[0][v].y};
  try {
    out = (*in.textures)(file.string(), uv);
  } catch (const Error&) {
    if (in.missing_textures) in.missing_textures->push_back(file.string());
    return false;
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
        C.emplace_back(c.r, c.g, c.b);
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

// ---- Structural checks before assimp ------------------------------------------------------------------------
// assimp is lax on broken files: it parses "nan" in OBJ as a finite number and drops broken faces silently. These
// checks read the file once and reject such input with a message naming the file; assimp then does the actual
// parsing. PLY and OFF files never reach assimp (core/ply_io.h, read_off below).

[[noreturn]] void fail_io(const std::string& path, const std::string& what) { throw IoError(path + ": " + what); }
[[noreturn]] void fail_input(const std::string& path, const std::string& what) { throw InvalidInput(path + ": " + what); }

bool parse_double(const char* s, double& out, const char** end = nullptr) {
  char* e = nullptr;
  out = std::strtod(s, &e);
  if (e == s) return false;
  if (end) *end = e;
  return true;
}

// OBJ messages name the 1-based line and count vertices and faces from 1, as OBJ indices and editors do.
void check_vertex(const std::string& path, long line, long i, const double* xyz) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(xyz[k]))
      fail_input(path, "line " + std::to_string(line) + ": non-finite coordinates (NaN or Inf) of vertex " +
                           std::to_string(i + 1));
}

void check_index(const std::string& path, long line, long face, long index, long written, long nv) {
  if (index < 0 || index >= nv)
    fail_input(path, "line " + std::to_string(line) + ": face index out of range: face " + std::to_string(face + 1) + " uses vertex " +
                         std::to_string(written) + " but the file has " + std::to_string(nv) +
                         " vertices (OBJ indices count from 1)");
}

void check_obj(const std::string& path, const std::string& text) {
  long nv = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    if (end - pos > 2 && text[pos] == 'v' && (text[pos + 1] == ' ' || text[pos + 1] == '\t')) ++nv;
    pos = end + 1;
  }
  long seen_v = 0, face = 0, number = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    const std::string at = "line " + std::to_string(number) + ": ";
    if (line.size() < 2 || !(line[1] == ' ' || line[1] == '\t')) continue;
    if (line[0] == 'v') {
      double xyz[3];
      const char* c = line.c_str() + 1;
      for (double& x : xyz)
        if (!parse_double(c, x, &c)) fail_io(path, at + "malformed vertex line '" + line + "'");
      check_vertex(path, number, seen_v++, xyz);
    } else if (line[0] == 'f') {
      const char* c = line.c_str() + 1;
      while (*c) {
        while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
        if (!*c) break;
        char* e = nullptr;
        const long idx = std::strtol(c, &e, 10);
        if (e == c) fail_io(path, at + "malformed face line '" + line + "'");
        const long zero_based = idx > 0 ? idx - 1 : seen_v + idx;  // negative: relative to the vertices so far
        if (idx == 0) fail_input(path, at + "face index 0 in '" + line + "' (OBJ indices start at 1)");
        check_index(path, number, face, zero_based, idx, nv);
        c = e;
        while (*c && *c != ' ' && *c != '\t') ++c;  // skip /texture/normal
      }
      ++face;
    }
  }
}

// ---- OFF ----------------------------------------------------------------------------------------------------
// sdfkit's own reader: assimp 5.2 crashes on small hostile OFF files that pass any cheap pre-check, and the format
// is simple. Accepted: an optional header line "OFF" (or COFF, NOFF, CNOFF, STOFF, ...; counts may follow the
// keyword on the same line), '#' comments and blank lines anywhere, a counts line "nv nf [ne]", nv vertex lines
// "x y z [more numbers]" (COFF: colour r g b [a] after the position, and after the normal for CNOFF; 0-255 integers
// or 0-1 floats), nf face lines "n i1 ... in [colour]" with 0-based indices. Polygons are fanned into triangles;
// faces of fewer than 3 vertices (points, lines) carry no surface and are skipped. Binary OFF and 4OFF/nOFF are
// refused. Line numbers in messages count from 1, as in an editor.

struct OffLine {
  long number;       // 1-based line number in the file
  std::string text;  // without comment and line break
};

[[noreturn]] void fail_off(const std::string& path, const OffLine& line, const std::string& what, bool io = true) {
  const std::string msg = path + ": line " + std::to_string(line.number) + ": " + what;
  if (io) throw IoError(msg);
  throw InvalidInput(msg);
}

/// Parses a non-negative decimal integer token at `c` (skipping blanks first); false when there is none or it
/// exceeds `limit`.
bool parse_count(const char*& c, long limit, long& out) {
  while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
  if (*c < '0' || *c > '9') return false;
  long v = 0;
  for (; *c >= '0' && *c <= '9'; ++c) {
    if (v > (limit - (*c - '0')) / 10) return false;
    v = v * 10 + (*c - '0');
  }
  if (*c != 0 && *c != ' ' && *c != '\t' && *c != '\r') return false;
  out = v;
  return true;
}

void read_off(const std::string& path, std::vector<Vec3>& V, std::vector<std::array<int32_t, 3>>& F,
              std::vector<Eigen::Vector3f>& C, bool& colored) {
  const std::string text = read_file(path);
  std::vector<OffLine> lines;
  long number = 0;
  for (size_t pos = 0; pos <= text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    ++number;
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    if (line.find('\0') != std::string::npos)
      fail_io(path, "line " + std::to_string(number) + ": binary data (binary OFF is not supported)");
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    if (line.find_first_not_of(" \t\r") != std::string::npos) lines.push_back({number, std::move(line)});
  }
  if (lines.empty()) fail_io(path, "empty file");
  size_t li = 0;
  bool has_normals = false, has_colors = false;
  const char* c = lines[0].text.c_str();
  while (*c == ' ' || *c == '\t') ++c;
  if (std::isalpha(static_cast<unsigned char>(*c)) || (*c >= '0' && *c <= '9' && std::strstr(c, "OFF") != nullptr)) {
    // Header keyword: [ST][C][N][4][n]OFF.
    const char* k = c;
    std::string prefix;
    while (*k && *k != ' ' && *k != '\t' && *k != '\r') ++k;
    const std::string keyword(c, k);
    if (keyword.size() < 3 || keyword.compare(keyword.size() - 3, 3, "OFF") != 0)
      fail_off(path, lines[0], "not an OFF file (the header '" + keyword + "' is not OFF, COFF, NOFF, ...)");
    prefix = keyword.substr(0, keyword.size() - 3);
    if (prefix.rfind("ST", 0) == 0) prefix.erase(0, 2);  // texture coordinates: after the colour, ignored
    if (!prefix.empty() && prefix[0] == 'C') has_colors = true, prefix.erase(0, 1);
    if (!prefix.empty() && prefix[0] == 'N') has_normals = true, prefix.erase(0, 1);
    if (!prefix.empty())
      fail_off(path, lines[0], "unsupported OFF variant '" + keyword + "' (4OFF, nOFF and binary OFF are not read)");
    c = k;
    while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
    if (std::strncmp(c, "BINARY", 6) == 0) fail_off(path, lines[0], "binary OFF is not supported");
    if (*c == 0) {  // counts on the next line
      if (lines.size() < 2) fail_off(path, lines[0], "truncated OFF file (no vertex/face counts)");
      li = 1;
      c = lines[li].text.c_str();
    }
  }
  const OffLine& counts_line = lines[li];
  const size_t data_lines = lines.size() - li - 1;
  // Counts beyond what the file can hold (one line per vertex and per face) are refused before any allocation;
  // vertex indices must fit the int32 face type.
  long nv = 0, nf = 0;
  if (!parse_count(c, std::numeric_limits<int32_t>::max(), nv) || !parse_count(c, std::numeric_limits<long>::max(), nf))
    fail_off(path, counts_line,
             "malformed OFF counts line '" + counts_line.text + "' (expected: vertices faces [edges])");
  if (static_cast<size_t>(nv) > data_lines || static_cast<size_t>(nf) > data_lines - static_cast<size_t>(nv))
    fail_off(path, counts_line,
             "truncated OFF file (" + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                 " faces announced, " + std::to_string(data_lines) + " data lines follow)");
  V.reserve(static_cast<size_t>(nv));
  C.reserve(static_cast<size_t>(nv));
  colored = has_colors;
  for (long v = 0; v < nv; ++v) {
    const OffLine& line = lines[li + 1 + static_cast<size_t>(v)];
    const char* p = line.text.c_str();
    double x[10];
    int n = 0;
    const int wanted = 3 + (has_normals ? 3 : 0) + (has_colors ? 3 : 0);
    for (; n < wanted; ++n)
      if (!parse_double(p, x[n], &p)) break;
    if (n < wanted)
      fail_off(path, line, "malformed OFF vertex line '" + line.text + "' (expected " + std::to_string(wanted) +
                               " numbers: x y z" + (has_normals ? " nx ny nz" : "") + (has_colors ? " r g b" : "") + ")");
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
      fail_off(path, line, "non-finite coordinates (NaN or Inf) of vertex " + std::to_string(v + 1), false);
    V.emplace_back(x[0], x[1], x[2]);
    if (has_colors) {
      const double* rgb = x + (has_normals ? 6 : 3);
      const bool bytes = rgb[0] > 1 || rgb[1] > 1 || rgb[2] > 1;
      Eigen::Vector3f col;
      for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(rgb[k]) || rgb[k] < 0 || rgb[k] > 255)
          fail_off(path, line, "vertex colour outside 0-255 or 0-1");
        col[k] = static_cast<float>(bytes ? rgb[k] / 255.0 : rgb[k]);
      }
      C.push_back(col);
    } else {
      C.emplace_back(0.7f, 0.7f, 0.7f);
    }
  }
  for (long f = 0; f < nf; ++f) {
    const OffLine& line = lines[li + 1 + static_cast<size_t>(nv + f)];
    const char* p = line.text.c_str();
    long n = 0;
    if (!parse_count(p, std::numeric_limits<long>::max(), n))
      fail_off(path, line, "malformed OFF face line '" + line.text + "' (expected: n i1 ... in)");
    long first = -1, prev = -1;
    for (long k = 0; k < n; ++k) {
      while (*p == ' ' || *p == '\t' || *p == '\r') ++p;
      if (*p == 0)
        fail_off(path, line, "truncated OFF face line '" + line.text + "' (" + std::to_string(n) +
                                 " indices announced, " + std::to_string(k) + " present)");
      char* e = nullptr;
      errno = 0;
      const long idx = std::strtol(p, &e, 10);
      if (e == p || (*e != 0 && *e != ' ' && *e != '\t' && *e != '\r'))
        fail_off(path, line, "malformed OFF face line '" + line.text + "' (indices are integers)");
      if (errno == ERANGE || idx < 0 || idx >= nv)
        fail_off(path, line,
                 "face index out of range: face " + std::to_string(f + 1) + " uses vertex " + std::string(p, static_cast<const char*>(e)) +
                     " but the file has " + std::to_string(nv) + " vertices (OFF indices count from 0)",
                 false);
      p = e;
      if (k == 0) first = idx;
      else if (k >= 2)
        F.push_back({static_cast<int32_t>(first), static_cast<int32_t>(prev), static_cast<int32_t>(idx)});
      prev = idx;
    }
  }
}

void check_stl(const std::string& path, const std::string& data) {
  if (data.size() >= 84) {
    uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    if (data.size() == 84 + 50 * static_cast<size_t>(n)) {  // binary
      for (uint32_t t = 0; t < n; ++t)
        for (int v = 0; v < 3; ++v) {
          float f[3];
          std::memcpy(f, data.data() + 84 + 50 * static_cast<size_t>(t) + 12 + 12 * v, 12);
          const double xyz[3] = {f[0], f[1], f[2]};
          for (const double x : xyz)
            if (!std::isfinite(x))
              fail_input(path, "non-finite coordinates (NaN or Inf) in triangle " + std::to_string(t + 1));
        }
      return;
    }
  }
  const size_t start = data.find_first_not_of(" \t\r\n");
  if (start == std::string::npos || data.compare(start, 5, "solid") != 0) {
    if (data.size() >= 84) {
      uint32_t n = 0;
      std::memcpy(&n, data.data() + 80, 4);
      fail_io(path, "truncated or malformed binary STL (" + std::to_string(n) + " triangles need " +
                        std::to_string(84 + 50 * static_cast<size_t>(n)) + " bytes, the file has " +
                        std::to_string(data.size()) + ")");
    }
    fail_io(path, "not an STL file (too small for binary, no 'solid' keyword)");
  }
  long v = 0;
  for (size_t p = data.find("vertex"); p != std::string::npos; p = data.find("vertex", p + 6)) {
    double xyz[3];
    const char* c = data.c_str() + p + 6;
    for (double& x : xyz)
      if (!parse_double(c, x, &c)) fail_io(path, "malformed STL vertex " + std::to_string(v + 1));
    for (const double x : xyz)
      if (!std::isfinite(x)) fail_input(path, "non-finite coordinates (NaN or Inf) of vertex " + std::to_string(v + 1));
    ++v;
  }
}

/// A glTF's JSON (the .gltf file, or a GLB's first chunk): an object whose "asset" names version 2. assimp hands a
/// file its glTF importer declines to every other importer, which then read it as something else (a 41-byte
/// ".gltf" found by fuzzing made one read past its buffer); so only what the glTF 2 importer takes reaches assimp.
void check_gltf_json(const std::string& path, const std::string& text, const char* what) {
  const Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object())
    fail_io(path, std::string("not a glTF file (") + what + " is not a JSON object)");
  const auto asset = j.find("asset");
  if (asset == j.end() || !asset->is_object() || !asset->contains("version") || !asset->at("version").is_string())
    fail_io(path, "not a glTF file (no asset.version)");
  const std::string version = asset->at("version").get<std::string>();
  if (version.rfind("2.", 0) != 0) fail_io(path, "glTF version '" + version + "' (only version 2 is read)");
}

/// A binary glTF's container (glTF 2.0 spec, "GLB File Format"): 12-byte header (magic, version 2, total length =
/// the file size), then chunks of (length, type, data) that fit in the file, the first a JSON chunk. assimp trusts
/// the length fields and allocates what they say (4 GB for a 748-byte file found by fuzzing).
void check_glb(const std::string& path, const std::string& data) {
  const auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, data.data() + at, 4);  // little endian, as the format and x86-64 / aarch64
    return v;
  };
  if (data.size() < 20) fail_io(path, "truncated binary glTF file (" + std::to_string(data.size()) + " bytes)");
  if (u32(4) != 2) fail_io(path, "binary glTF version " + std::to_string(u32(4)) + " (only version 2 is read)");
  if (u32(8) != data.size())
    fail_io(path, "binary glTF header says " + std::to_string(u32(8)) + " bytes, the file has " +
                      std::to_string(data.size()));
  for (size_t at = 12, index = 0; at < data.size(); ++index) {
    if (data.size() - at < 8) fail_io(path, "truncated binary glTF chunk header at byte " + std::to_string(at));
    const uint32_t length = u32(at), type = u32(at + 4);
    if (length > data.size() - at - 8)
      fail_io(path, "binary glTF chunk " + std::to_string(index) + " says " + std::to_string(length) +
                        " bytes, the file has " + std::to_string(data.size() - at - 8) + " after its header");
    if (index == 0 && type != 0x4E4F534Au) fail_io(path, "binary glTF file whose first chunk is not JSON");
    if (index == 0) check_gltf_json(path, data.substr(at + 8, length), "its JSON chunk");
    at += 8 + static_cast<size_t>(length);
  }
}

void check_structure(const std::string& path, const std::string& ext) {
  const std::string data = read_file(path);
  if (data.find_first_not_of(" \t\r\n") == std::string::npos) fail_io(path, "empty file");
  if (ext == "gltf") check_gltf_json(path, data, "the file");
  if (ext == "glb" && data.compare(0, 4, "glTF") != 0) fail_io(path, "not a binary glTF file (no 'glTF' magic)");
  if (ext == "glb") check_glb(path, data);
  if (ext == "obj") check_obj(path, data);
  else if (ext == "stl") check_stl(path, data);
}

/// Merge vertices with bit-identical positions (and colours, when every vertex has one), keeping first-seen order,
/// so that STL and per-face-vertex files become indexed meshes whose parts are connected through shared edges.
void weld_identical_vertices(std::vector<Vec3>& V, std::vector<Eigen::Vector3f>& C,
                             std::vector<std::array<int32_t, 3>>& F, bool colored) {
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
  for (auto& f : F)
    for (auto& v : f) v = remap[static_cast<size_t>(v)];
  V.swap(V2);
  C.swap(C2);
}

/// OBJ, STL, glTF and GLB: sdfkit's structural checks, then assimp.
void read_with_assimp(const std::string& path, const std::string& ext, std::vector<Vec3>& V,
                      std::vector<std::array<int32_t, 3>>& F, std::vector<Eigen::Vector3f>& C, bool& all_colored,
                      const TextureSampler& textures, MeshReport& report) {
  check_structure(path, ext);
  Assimp::Importer importer;
  // Keep lines/points out, keep every face as is: sdfkit counts degenerate faces itself.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // No assimp post-processing: assimp 5.2 (Debian 12) segfaults in its post-processing steps on some valid
  // coloured binary PLYs (seen on procedural benchmark shapes). append_node fans polygons into triangles and skips
  // points and lines; identical vertices are welded below.
  const aiScene* scene = importer.ReadFile(path, 0);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "cannot parse";
    if (why.rfind(path, 0) == 0) throw IoError(why);  // assimp already named the file
    throw IoError(path + ": " + why);
  }
  AssimpInput in;
  in.scene = scene;
  in.path = path;
  in.textures = &textures;
  in.textured_parts = &report.textured_parts;
  in.missing_textures = &report.missing_textures;
  append_node(in, scene->mRootNode, aiMatrix4x4(), V, F, C, all_colored);
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
  if (!std::filesystem::is_regular_file(path)) throw IoError(path + ": no such file");
  if (ext == "ply") {
    // Our own reader (core/ply_io.h): assimp 5.2 misreads some valid binary PLYs.
    Mesh raw = read_ply(path);
    std::vector<Vec3> V(static_cast<size_t>(raw.V.rows()));
    std::vector<Eigen::Vector3f> C(V.size(), Eigen::Vector3f::Constant(0.7f));
    std::vector<std::array<int32_t, 3>> F(static_cast<size_t>(raw.F.rows()));
    const bool colored = raw.has_colors();
    for (size_t i = 0; i < V.size(); ++i) {
      V[i] = raw.V.row(static_cast<Eigen::Index>(i)).transpose();
      if (colored) C[i] = raw.colors.row(static_cast<Eigen::Index>(i)).transpose();
    }
    for (size_t f = 0; f < F.size(); ++f)
      for (int k = 0; k < 3; ++k) F[f][k] = raw.F(static_cast<Eigen::Index>(f), k);
    weld_identical_vertices(V, C, F, colored);
    Mesh mesh;
    mesh.V.resize(static_cast<Eigen::Index>(V.size()), 3);
    for (size_t i = 0; i < V.size(); ++i) mesh.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
    mesh.F.resize(static_cast<Eigen::Index>(F.size()), 3);
    for (size_t i = 0; i < F.size(); ++i) mesh.F.row(static_cast<Eigen::Index>(i)) << F[i][0], F[i][1], F[i][2];
    if (colored) {
      mesh.colors.resize(static_cast<Eigen::Index>(C.size()), 3);
      for (size_t i = 0; i < C.size(); ++i) mesh.colors.row(static_cast<Eigen::Index>(i)) = C[i].transpose();
    }
    return validate_mesh(mesh, path, report);
  }
  std::vector<Vec3> V;
  std::vector<std::array<int32_t, 3>> F;
  std::vector<Eigen::Vector3f> C;
  bool all_colored = true;
  MeshReport texture_report;
  if (ext == "off") {
    read_off(path, V, F, C, all_colored);
  } else {
    read_with_assimp(path, ext, V, F, C, all_colored, textures, texture_report);
  }
  weld_identical_vertices(V, C, F, all_colored);
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
  Mesh valid = validate_mesh(mesh, path, report);
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
  const bool colored = mesh.has_colors();
  if (ext == "obj") {
    write_file_atomic(path, [&](std::ostream& o) {
      // std::to_chars with (general, precision) prints exactly what printf's %.<precision>g prints, without the
      // locale and format parsing (the gt mesh of a 50k-triangle shape was 7% of its preparation in printf).
      std::string text;
      text.reserve(static_cast<size_t>(mesh.V.rows()) * 40 + static_cast<size_t>(mesh.F.rows()) * 24 + 64);
      char buf[64];
      auto put_float = [&](double v, int precision) {
        text += ' ';
        const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, precision);
        text.append(buf, r.ptr);
      };
      auto put_int = [&](long v) {
        text += ' ';
        const auto r = std::to_chars(buf, buf + sizeof buf, v);
        text.append(buf, r.ptr);
      };
      text += "# sdfkit mesh: " + std::to_string(mesh.V.rows()) + " vertices, " + std::to_string(mesh.F.rows()) +
              " faces\n";
      for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
        text += 'v';
        for (int k = 0; k < 3; ++k) put_float(mesh.V(i, k), 9);
        if (colored)
          for (int k = 0; k < 3; ++k) put_float(static_cast<double>(mesh.colors(i, k)), 4);
        text += '\n';
      }
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
        text += 'f';
        for (int k = 0; k < 3; ++k) put_int(static_cast<long>(mesh.F(f, k)) + 1);
        text += '\n';
      }
      o.write(text.data(), static_cast<std::streamsize>(text.size()));
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
  } else if (ext == "stl") {
    // Binary STL: 80-byte header, triangle count, then per triangle the unit normal, 3 vertices (float32,
    // little-endian) and a zero attribute word. Degenerate faces get a zero normal.
    write_file_atomic(path, [&](std::ostream& o) {
      char header[80] = {};
      std::snprintf(header, sizeof header, "sdfkit binary STL");
      o.write(header, sizeof header);
      const auto put_u32 = [&](uint32_t v) {
        const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                                    static_cast<unsigned char>(v >> 16), static_cast<unsigned char>(v >> 24)};
        o.write(reinterpret_cast<const char*>(b), 4);
      };
      const auto put_f32 = [&](double d) {
        const float f = static_cast<float>(d);
        uint32_t v = 0;
        std::memcpy(&v, &f, 4);
        put_u32(v);
      };
      put_u32(static_cast<uint32_t>(mesh.F.rows()));
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
        const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
        Vec3 n = (b - a).cross(c - a);
        const double len = n.norm();
        n = len > 0 ? Vec3(n / len) : Vec3::Zero();
        for (const Vec3& p : {n, a, b, c})
          for (int k = 0; k < 3; ++k) put_f32(p[k]);
        o.write("\0\0", 2);
      }
    });
  } else {
    throw InvalidInput(path + ": cannot write mesh with extension '." + ext + "' (use .obj, .ply, .off or .stl)");
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
