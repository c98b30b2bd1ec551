// Binary glTF 2.0 writer (core/glb.h). Layout of the BIN chunk: positions, normals, colours (when any), indices,
// each a bufferView of its own; every offset is a multiple of 4 as the spec requires for float and uint32 data.
#include "core/glb.h"

#include "core/error.h"
#include "core/json.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace sdfkit {

float srgb_to_linear(float c) {
  c = std::clamp(c, 0.f, 1.f);
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float c) {
  c = std::clamp(c, 0.f, 1.f);
  return c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

namespace {

void append_bytes(std::string& out, const void* data, size_t n) {
  out.append(static_cast<const char*>(data), n);
}
void append_u32(std::string& out, uint32_t v) {
  const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                              static_cast<unsigned char>(v >> 16), static_cast<unsigned char>(v >> 24)};
  append_bytes(out, b, 4);
}
void append_f32(std::string& out, float f) {
  uint32_t v = 0;
  std::memcpy(&v, &f, 4);
  append_u32(out, v);
}

}  // namespace

std::string encode_glb(const Mesh& mesh) {
  if (mesh.empty()) throw InvalidInput("cannot write an empty mesh as glTF");
  if (!mesh.V.allFinite()) throw InvalidInput("refusing to write a mesh with non-finite coordinates as glTF");
  const bool colored = mesh.has_colors();
  if (colored && !mesh.colors.allFinite())
    throw InvalidInput("refusing to write a mesh with non-finite colours as glTF");
  const Eigen::Index nv = mesh.V.rows(), nf = mesh.F.rows();
  if (nv > 0xFFFFFFFEll || nf * 3 > 0xFFFFFFFFll) throw InvalidInput("mesh too large for a glTF file");
  for (Eigen::Index n = 0; n < mesh.F.size(); ++n)
    if (mesh.F.data()[n] < 0 || mesh.F.data()[n] >= nv)
      throw InvalidInput("cannot write a mesh whose face names vertex " + std::to_string(mesh.F.data()[n]) +
                         " of " + std::to_string(nv) + " as glTF");

  // Area-weighted vertex normals (the cross product's length is twice the face's area).
  Points N = Points::Zero(nv, 3);
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Vec3 n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) N.row(mesh.F(f, k)) += n.transpose();
  }

  std::string bin;
  bin.reserve(static_cast<size_t>(nv) * (colored ? 36 : 24) + static_cast<size_t>(nf) * 12);
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      const float p = static_cast<float>(mesh.V(i, k));
      if (i == 0 || p < lo[k]) lo[k] = p;
      if (i == 0 || p > hi[k]) hi[k] = p;
      append_f32(bin, p);
    }
  const size_t normals_at = bin.size();
  for (Eigen::Index i = 0; i < nv; ++i) {
    const Vec3 n = N.row(i);
    const double len = n.norm();
    const Vec3 u = len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3(0, 0, 1);
    for (int k = 0; k < 3; ++k) append_f32(bin, static_cast<float>(u[k]));
  }
  const size_t colors_at = bin.size();
  if (colored)
    for (Eigen::Index i = 0; i < nv; ++i)
      for (int k = 0; k < 3; ++k) append_f32(bin, srgb_to_linear(mesh.colors(i, k)));
  const size_t indices_at = bin.size();
  for (Eigen::Index n = 0; n < mesh.F.size(); ++n) append_u32(bin, static_cast<uint32_t>(mesh.F.data()[n]));

  const auto view = [&](size_t offset, size_t length, int target) {
    return Json{{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}, {"target", target}};
  };
  constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963, kFloat = 5126, kUnsignedInt = 5125;
  Json views = Json::array({view(0, normals_at, kArrayBuffer), view(normals_at, colors_at - normals_at, kArrayBuffer)});
  Json accessors = Json::array(
      {{{"bufferView", 0}, {"componentType", kFloat}, {"count", nv}, {"type", "VEC3"},
        {"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}},
       {{"bufferView", 1}, {"componentType", kFloat}, {"count", nv}, {"type", "VEC3"}}});
  Json attributes = {{"POSITION", 0}, {"NORMAL", 1}};
  if (colored) {
    views.push_back(view(colors_at, indices_at - colors_at, kArrayBuffer));
    accessors.push_back({{"bufferView", 2}, {"componentType", kFloat}, {"count", nv}, {"type", "VEC3"}});
    attributes["COLOR_0"] = 2;
  }
  views.push_back(view(indices_at, bin.size() - indices_at, kElementArrayBuffer));
  accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", kUnsignedInt}, {"count", nf * 3},
                       {"type", "SCALAR"}});
  const double grey = colored ? 1.0 : 0.7;  // read_mesh gives this base colour to every vertex
  const Json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "sdfkit"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives", {{{"attributes", attributes}, {"indices", accessors.size() - 1}, {"material", 0}, {"mode", 4}}}}}}},
      {"materials",
       {{{"pbrMetallicRoughness",
          {{"baseColorFactor", {grey, grey, grey, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
         {"doubleSided", true}}}},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"bufferViews", views},
      {"accessors", accessors}};
  std::string json = gltf.dump();
  json.append((4 - json.size() % 4) % 4, ' ');  // chunks are padded to 4 bytes: JSON with spaces, BIN with zeros
  bin.append((4 - bin.size() % 4) % 4, '\0');

  std::string out;
  out.reserve(12 + 8 + json.size() + 8 + bin.size());
  append_u32(out, 0x46546C67u);  // "glTF"
  append_u32(out, 2);
  append_u32(out, static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  append_u32(out, static_cast<uint32_t>(json.size()));
  append_u32(out, 0x4E4F534Au);  // "JSON"
  out += json;
  append_u32(out, static_cast<uint32_t>(bin.size()));
  append_u32(out, 0x004E4942u);  // "BIN\0"
  out += bin;
  return out;
}

}  // namespace sdfkit
