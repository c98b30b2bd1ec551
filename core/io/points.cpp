// Point clouds: the .xyz text reader and the .npy columns (core/io/points.h).
#include "core/io/points.h"

#include "core/error.h"
#include "core/files.h"
#include "core/io/formats.h"

#include <cmath>
#include <string>
#include <vector>

namespace sdfkit {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// The start of a line for a message: at most 40 characters, anything unprintable (binary data) shown as '?'.
std::string excerpt(const std::string& line) {
  std::string out;
  for (size_t i = 0; i < line.size() && i < 40; ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    out += c >= 32 && c < 127 ? static_cast<char>(c) : '?';
  }
  return line.size() > 40 ? out + "..." : out;
}

}  // namespace

Points parse_xyz(const std::string& text, const std::string& name) {
  std::vector<Vec3> pts;
  long number = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    const char* c = line.c_str();
    const char* const stop = c + line.size();
    while (c < stop && is_blank(*c)) ++c;
    if (c == stop) continue;  // blank or comment line
    Vec3 p;
    for (int k = 0; k < 3; ++k) {
      const char* e = nullptr;
      // A number ends at a blank or the end of the line: "1,2,3" or "1.5f" is not three numbers.
      if (!io::parse_double(c, p[k], &e) || e > stop || (e < stop && !is_blank(*e)))
        io::fail_io(name, "line " + std::to_string(number) +
                              ": expected three numbers x y z separated by blanks, got '" + excerpt(line) + "'");
      c = e;
    }
    if (!p.allFinite())
      io::fail_input(name, "line " + std::to_string(number) + ": non-finite coordinates (NaN or Inf)");
    pts.push_back(p);
  }
  if (pts.empty()) io::fail_input(name, "no points");
  Points out(static_cast<Eigen::Index>(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
  return out;
}

Points read_xyz(const std::string& path) { return parse_xyz(read_file(path), path); }

bool has_point_cloud_extension(const std::string& path) {
  const std::string e = extension_of(path);
  return e == "xyz" || e == "txt" || e == "npy";
}

Points read_point_cloud(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == "xyz" || ext == "txt") return read_xyz(path);
  if (ext != "npy")
    io::fail_io(path, "unknown point cloud extension '." + ext + "' (expected .xyz, .txt or .npy)");
  const MatrixXfR a = read_npy(path);
  if (a.cols() < 3)
    io::fail_io(path, ".npy point cloud needs N x 3 or more columns, got N x " + std::to_string(a.cols()));
  Points out = a.leftCols(3).cast<double>();
  if (out.rows() == 0) io::fail_input(path, "no points");
  if (!out.allFinite()) io::fail_input(path, "non-finite (NaN or infinite) coordinate");
  return out;
}

}  // namespace sdfkit
