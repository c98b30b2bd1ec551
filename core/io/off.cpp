// OFF (Object File Format): reader and writer.
// sdfkit's own reader: assimp 5.2 crashes on small hostile OFF files that pass any cheap pre-check, and the format
// is simple. Accepted: an optional header line "OFF" (or COFF, NOFF, CNOFF, STOFF, ...; counts may follow the
// keyword on the same line), '#' comments and blank lines anywhere, a counts line "nv nf [ne]", nv vertex lines
// "x y z [more numbers]" (COFF: colour r g b [a] after the position, and after the normal for CNOFF; 0-255 integers
// or 0-1 floats), nf face lines "n i1 ... in [colour]" with 0-based indices. Polygons are fanned into triangles;
// faces of fewer than 3 vertices (points, lines) carry no surface and are skipped. Binary OFF and 4OFF/nOFF are
// refused. Line numbers in messages count from 1, as in an editor.
#include "core/files.h"
#include "core/io/formats.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace sdfkit::io {
namespace {

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

}  // namespace

RawMesh read_off(const std::string& path) {
  RawMesh raw;
  std::vector<Vec3>& V = raw.V;
  std::vector<std::array<int32_t, 3>>& F = raw.F;
  std::vector<Eigen::Vector3f>& C = raw.C;
  bool& colored = raw.colored;
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
  return raw;
}

void write_off(const std::string& path, const Mesh& mesh) {
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
}

}  // namespace sdfkit::io
