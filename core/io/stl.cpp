// STL (ASCII and binary): sdfkit's structural check before assimp reads the file (core/io/assimp.cpp), and the
// binary writer.
#include "core/files.h"
#include "core/io/formats.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace sdfkit::io {

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

void write_stl(const std::string& path, const Mesh& mesh) {
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
}

}  // namespace sdfkit::io
