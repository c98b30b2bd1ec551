// The per-format halves of read_mesh and write_mesh (core/mesh_io.h), one file per format in core/io/. Internal to
// core/: everyone else reads and writes meshes through core/mesh_io.h, which picks the format by extension, welds,
// validates and reports. Every message starts with the file's path; line numbers count from 1, as in an editor.
#pragma once

#include "core/error.h"
#include "core/mesh_io.h"
#include "core/types.h"

#include <array>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

namespace sdfkit::io {

/// A mesh as a format reader hands it to read_mesh, before welding and validation: one colour per vertex (0.7 grey
/// where the file gives none) and `colored` false unless every vertex had a colour of its own.
struct RawMesh {
  std::vector<Vec3> V;
  std::vector<std::array<int32_t, 3>> F;
  std::vector<Eigen::Vector3f> C;
  bool colored = true;
};

[[noreturn]] inline void fail_io(const std::string& path, const std::string& what) {
  throw IoError(path + ": " + what);
}
[[noreturn]] inline void fail_input(const std::string& path, const std::string& what) {
  throw InvalidInput(path + ": " + what);
}

/// strtod at `s` (leading blanks skipped, "nan" and "inf" accepted: callers check finiteness); false when no number
/// starts there. `end` (optional) receives the first character after the number.
inline bool parse_double(const char* s, double& out, const char** end = nullptr) {
  char* e = nullptr;
  out = std::strtod(s, &e);
  if (e == s) return false;
  if (end) *end = e;
  return true;
}

// ---- Readers --------------------------------------------------------------------------------------------------

/// OFF and its COFF/NOFF/CNOFF/STOFF variants (core/io/off.cpp): sdfkit's own reader.
RawMesh read_off(const std::string& path);

/// OBJ, STL, glTF and GLB (core/io/assimp.cpp): check_structure, then assimp; OBJ materials' diffuse colours and
/// glTF base colours become vertex colours, and with `textures` their texture files are sampled at the vertices
/// (counted in `report`'s textured_parts and missing_textures).
RawMesh read_with_assimp(const std::string& path, const std::string& ext, const TextureSampler& textures,
                         MeshReport& report);

// ---- Structural checks before assimp ----------------------------------------------------------------------------
// assimp is lax on broken files: it parses "nan" in OBJ as a finite number and drops broken faces silently. These
// checks read the file once and reject such input with a message naming the file; assimp then does the actual
// parsing. PLY and OFF files never reach assimp (core/io/ply.h, read_off).

/// Reads the file and runs the check of its format (`ext`: obj, stl, gltf, glb); IoError for an empty file.
void check_structure(const std::string& path, const std::string& ext);
/// OBJ (core/io/obj.cpp): every vertex line has three finite numbers, every face index names an existing vertex.
void check_obj(const std::string& path, const std::string& text);
/// STL (core/io/stl.cpp): a binary file's size matches its triangle count, ASCII starts with "solid", every vertex
/// has three finite numbers.
void check_stl(const std::string& path, const std::string& data);
/// glTF (core/io/gltf.cpp): `text` is a JSON object whose asset.version is "2.x"; `what` names it in messages.
void check_gltf_json(const std::string& path, const std::string& text, const char* what);
/// Binary glTF (core/io/gltf.cpp): the GLB container's lengths fit the file, its first chunk is glTF 2 JSON.
void check_glb(const std::string& path, const std::string& data);

// ---- Writers (atomic; write_mesh has already refused non-finite coordinates) -----------------------------------

void write_obj(const std::string& path, const Mesh& mesh);  ///< core/io/obj.cpp
void write_ply(const std::string& path, const Mesh& mesh);  ///< core/io/ply.cpp
void write_off(const std::string& path, const Mesh& mesh);  ///< core/io/off.cpp
void write_stl(const std::string& path, const Mesh& mesh);  ///< core/io/stl.cpp
void write_glb(const std::string& path, const Mesh& mesh);  ///< core/io/gltf.cpp (encoded by core/glb.h)

}  // namespace sdfkit::io
