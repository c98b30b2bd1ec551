// OBJ (Wavefront): sdfkit's structural check before assimp reads the file (core/io/assimp.cpp), and the writer.
#include "core/files.h"
#include "core/io/formats.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

namespace sdfkit::io {
namespace {

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

}  // namespace

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

void write_obj(const std::string& path, const Mesh& mesh) {
  const bool colored = mesh.has_colors();
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
}

}  // namespace sdfkit::io
