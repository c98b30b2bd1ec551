// PLY (ascii, binary little and big endian): sdfkit's own reader (why: core/io/ply.h) and the binary writer.
#include "core/io/ply.h"

#include "core/error.h"
#include "core/files.h"
#include "core/io/formats.h"

#include <algorithm>
#include <cstdint>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <vector>

namespace sdfkit {
namespace {

/// A value read where a vertex index was expected, for a message: the integer when it is one, else as read (a NaN, a
/// fraction or a value beyond any integer type is never cast).
std::string index_text(double v) {
  if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 9.0e15) return std::to_string(static_cast<long long>(v));
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64, kUnknown };

PlyType ply_type(const std::string& t) {
  if (t == "char" || t == "int8") return PlyType::kInt8;
  if (t == "uchar" || t == "uint8") return PlyType::kUInt8;
  if (t == "short" || t == "int16") return PlyType::kInt16;
  if (t == "ushort" || t == "uint16") return PlyType::kUInt16;
  if (t == "int" || t == "int32") return PlyType::kInt32;
  if (t == "uint" || t == "uint32") return PlyType::kUInt32;
  if (t == "float" || t == "float32") return PlyType::kFloat32;
  if (t == "double" || t == "float64") return PlyType::kFloat64;
  return PlyType::kUnknown;
}

size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8: case PlyType::kUInt8: return 1;
    case PlyType::kInt16: case PlyType::kUInt16: return 2;
    case PlyType::kInt32: case PlyType::kUInt32: case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
    case PlyType::kUnknown: return 0;
  }
  return 0;
}

bool is_integer(PlyType t) { return t != PlyType::kFloat32 && t != PlyType::kFloat64; }

/// What a property means to the mesh.
enum class Role { kSkip, kX, kY, kZ, kRed, kGreen, kBlue, kIndices };

struct Property {
  std::string name;
  PlyType type = PlyType::kUnknown;        ///< scalar type, or list item type
  PlyType count_type = PlyType::kUnknown;  ///< list count type; Unknown for scalars
  Role role = Role::kSkip;
  [[nodiscard]] bool list() const { return count_type != PlyType::kUnknown; }
};

struct Element {
  std::string name;
  long count = 0;
  std::vector<Property> props;
};

/// Reads values one at a time from the body, in the file's encoding; every read checks the bounds.
class BodyReader {
 public:
  BodyReader(const std::string& bytes, size_t begin, int format, const std::string& name)
      : data_(bytes.data()), size_(bytes.size()), pos_(begin), format_(format), name_(name) {}

  /// format: 0 ascii, 1 binary little endian, 2 binary big endian.
  double read(PlyType t, const char* where_element, long where_index) {
    if (format_ == 0) return read_ascii(where_element, where_index);
    const size_t n = type_size(t);
    if (pos_ + n > size_) truncated(where_element, where_index);
    unsigned char b[8];
    std::memcpy(b, data_ + pos_, n);
    pos_ += n;
    const bool swap = (format_ == 2) != host_big_endian();
    if (swap)
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    switch (t) {
      case PlyType::kInt8: { int8_t v; std::memcpy(&v, b, 1); return v; }
      case PlyType::kUInt8: return b[0];
      case PlyType::kInt16: { int16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::kUInt16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::kInt32: { int32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::kUInt32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::kFloat32: { float v; std::memcpy(&v, b, 4); return v; }
      case PlyType::kFloat64: { double v; std::memcpy(&v, b, 8); return v; }
      case PlyType::kUnknown: break;
    }
    return 0;
  }

  /// Skip `count` binary values of type t (ascii: read them).
  void skip(PlyType t, long count, const char* where_element, long where_index) {
    if (format_ == 0) {
      for (long i = 0; i < count; ++i) read_ascii(where_element, where_index);
      return;
    }
    const size_t n = type_size(t) * static_cast<size_t>(count);
    if (pos_ + n > size_ || pos_ + n < pos_) truncated(where_element, where_index);
    pos_ += n;
  }

  /// A list length read from the file, as a count: a finite non-negative integer no larger than the values the
  /// rest of the body could hold (each takes at least one byte), else IoError. A cast of 1e30 or NaN to an
  /// integer would be undefined behaviour.
  long list_length(double n, const char* where_element, long where_index) const {
    if (!(n >= 0) || n != std::floor(n) || n > static_cast<double>(size_ - pos_))
      throw IoError(name_ + ": bad PLY list length " + format_number(n) + " in " + where_element + " " +
                    std::to_string(where_index) + " (expected a non-negative integer the remaining " +
                    std::to_string(size_ - pos_) + " bytes can hold)");
    return static_cast<long>(n);
  }

  [[nodiscard]] size_t remaining() const { return size_ - pos_; }

  /// Bytes left after the last element that are not whitespace (binary: any byte but '\n', '\r', ' ', '\0').
  [[nodiscard]] bool trailing_data() const {
    for (size_t i = pos_; i < size_; ++i) {
      const char c = data_[i];
      if (c != '\n' && c != '\r' && c != ' ' && c != '\t' && !(format_ != 0 && c == '\0')) return true;
    }
    return false;
  }

 private:
  static bool host_big_endian() {
    const uint16_t one = 1;
    unsigned char b;
    std::memcpy(&b, &one, 1);
    return b == 0;
  }

  double read_ascii(const char* where_element, long where_index) {
    while (pos_ < size_ && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ >= size_) truncated(where_element, where_index);
    // Tokens are short; copy one so that strtod never reads past the buffer.
    char token[64];
    size_t n = 0;
    while (pos_ + n < size_ && !std::isspace(static_cast<unsigned char>(data_[pos_ + n])) && n < sizeof token - 1) {
      token[n] = data_[pos_ + n];
      ++n;
    }
    token[n] = '\0';
    char* end = nullptr;
    const double v = std::strtod(token, &end);
    if (end != token + n || n == 0)
      throw IoError(name_ + ": malformed PLY value '" + token + "' in " + where_element + " " +
                    std::to_string(where_index));
    pos_ += n;
    return v;
  }

  static std::string format_number(double v) {
    std::ostringstream o;
    o << v;
    return o.str();
  }

  [[noreturn]] void truncated(const char* where_element, long where_index) const {
    throw IoError(name_ + (format_ == 0 ? ": truncated PLY" : ": truncated binary PLY") + " (data ends inside " +
                  where_element + " " + std::to_string(where_index) + ")");
  }

  const char* data_;
  size_t size_;
  size_t pos_;
  int format_;
  const std::string& name_;
};

}  // namespace

Mesh parse_ply(const std::string& bytes, const std::string& name, PlyInfo* info) {
  if (bytes.find_first_not_of(" \t\r\n") == std::string::npos) throw IoError(name + ": empty file");
  // ---- Header: lines up to "end_header" ----
  size_t pos = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= bytes.size()) return false;
    size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = end + 1;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply") throw IoError(name + ": not a PLY file (first line is not 'ply')");
  std::string format;
  std::vector<Element> elements;
  bool ended = false;
  while (next_line(line)) {
    std::istringstream in(line);
    std::string kw;
    in >> kw;
    if (kw.empty() || kw == "comment" || kw == "obj_info") continue;
    if (kw == "end_header") {
      ended = true;
      break;
    }
    auto bad = [&] { return IoError(name + ": malformed PLY header line '" + line + "'"); };
    if (kw == "format") {
      std::string version;
      if (!(in >> format >> version)) throw bad();
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        throw IoError(name + ": unknown PLY format '" + format + "'");
    } else if (kw == "element") {
      Element el;
      std::string count;
      if (!(in >> el.name >> count)) throw bad();
      char* end = nullptr;
      errno = 0;
      el.count = std::strtol(count.c_str(), &end, 10);
      if (*end != '\0' || el.count < 0 || errno == ERANGE || count.empty()) throw bad();
      elements.push_back(el);
    } else if (kw == "property") {
      if (elements.empty()) throw IoError(name + ": PLY property before any element ('" + line + "')");
      Property p;
      std::string t;
      if (!(in >> t)) throw bad();
      if (t == "list") {
        std::string ct, it;
        if (!(in >> ct >> it >> p.name)) throw bad();
        p.count_type = ply_type(ct);
        p.type = ply_type(it);
        if (p.count_type == PlyType::kUnknown || p.type == PlyType::kUnknown)
          throw IoError(name + ": unknown PLY type in '" + line + "'");
        if (!is_integer(p.count_type)) throw IoError(name + ": PLY list count must be an integer type ('" + line + "')");
      } else {
        p.type = ply_type(t);
        if (!(in >> p.name)) throw bad();
        if (p.type == PlyType::kUnknown) throw IoError(name + ": unknown PLY type '" + t + "' in '" + line + "'");
      }
      elements.back().props.push_back(p);
    } else {
      throw IoError(name + ": unknown PLY header keyword '" + kw + "'");
    }
  }
  if (!ended) throw IoError(name + ": truncated PLY header (no end_header)");
  if (format.empty()) throw IoError(name + ": PLY header has no format line");

  // ---- Roles ----
  PlyInfo inf;
  inf.format = format;
  Element* vertex = nullptr;
  Element* face = nullptr;
  for (auto& el : elements) {
    if (el.name == "vertex" && !vertex) {
      vertex = &el;
      for (auto& p : el.props) {
        if (p.list()) continue;
        if (p.name == "x") p.role = Role::kX;
        else if (p.name == "y") p.role = Role::kY;
        else if (p.name == "z") p.role = Role::kZ;
        else if (p.name == "red" || p.name == "diffuse_red") p.role = Role::kRed;
        else if (p.name == "green" || p.name == "diffuse_green") p.role = Role::kGreen;
        else if (p.name == "blue" || p.name == "diffuse_blue") p.role = Role::kBlue;
      }
    } else if (el.name == "face" && !face) {
      face = &el;
      for (auto& p : el.props)
        if (p.list() && (p.name == "vertex_indices" || p.name == "vertex_index") &&
            std::none_of(el.props.begin(), el.props.end(), [](const Property& q) { return q.role == Role::kIndices; })) {
          if (!is_integer(p.type)) throw IoError(name + ": PLY face indices must be an integer type");
          p.role = Role::kIndices;
        }
    } else {
      ++inf.skipped_elements;
    }
  }
  if (!vertex) throw IoError(name + ": PLY file has no vertex element");
  int has[8] = {0};
  for (const auto& p : vertex->props) ++has[static_cast<int>(p.role)];
  if (!has[static_cast<int>(Role::kX)] || !has[static_cast<int>(Role::kY)] || !has[static_cast<int>(Role::kZ)])
    throw IoError(name + ": PLY vertex element lacks an x, y or z property");
  const bool colored = has[static_cast<int>(Role::kRed)] && has[static_cast<int>(Role::kGreen)] &&
                       has[static_cast<int>(Role::kBlue)];
  if (face && std::none_of(face->props.begin(), face->props.end(), [](const Property& p) { return p.role == Role::kIndices; }))
    throw IoError(name + ": PLY face element has no vertex_indices list");
  inf.vertices = vertex->count;
  inf.faces = face ? face->count : 0;
  if (vertex->count > 2'000'000'000L) throw IoError(name + ": PLY vertex count too large");

  // ---- Body ----
  const int fmt = format == "ascii" ? 0 : format == "binary_little_endian" ? 1 : 2;
  pos = std::min(pos, bytes.size());
  BodyReader body(bytes, pos, fmt, name);
  Mesh mesh;
  std::vector<int32_t> tris;  // flat triangle corner indices
  const long nv = vertex->count;
  // Guard the allocation against absurd counts in a short file (every vertex needs at least one byte).
  if (static_cast<size_t>(nv) > bytes.size() - pos)
    throw IoError(name + (fmt == 0 ? ": truncated PLY (" : ": truncated binary PLY (") + std::to_string(nv) + " vertices declared, " +
                  std::to_string(bytes.size() - pos) + " bytes of data)");
  mesh.V.resize(nv, 3);
  if (colored) mesh.colors.resize(nv, 3);
  std::vector<int32_t> poly;
  for (const auto& el : elements) {
    const char* ename = el.name.c_str();
    if (el.props.empty()) continue;  // holds no bytes, however many items it declares
    // Every item of an element with properties takes at least one byte: larger counts are truncated files,
    // refused before any loop or allocation sized by them.
    if (static_cast<size_t>(el.count) > body.remaining())
      throw IoError(name + (fmt == 0 ? ": truncated PLY (" : ": truncated binary PLY (") + std::to_string(el.count) +
                    " " + el.name + " items declared, " + std::to_string(body.remaining()) + " bytes of data left)");
    if (&el == vertex) {
      for (long i = 0; i < el.count; ++i) {
        for (const auto& p : el.props) {
          if (p.list()) {
            body.skip(p.type, body.list_length(body.read(p.count_type, ename, i), ename, i), ename, i);
            continue;
          }
          const double v = body.read(p.type, ename, i);
          switch (p.role) {
            case Role::kX: mesh.V(i, 0) = v; break;
            case Role::kY: mesh.V(i, 1) = v; break;
            case Role::kZ: mesh.V(i, 2) = v; break;
            case Role::kRed: case Role::kGreen: case Role::kBlue:
              if (colored)
                mesh.colors(i, static_cast<int>(p.role) - static_cast<int>(Role::kRed)) =
                    static_cast<float>(is_integer(p.type) ? v / 255.0 : v);
              break;
            default: break;
          }
        }
        if (!std::isfinite(mesh.V(i, 0)) || !std::isfinite(mesh.V(i, 1)) || !std::isfinite(mesh.V(i, 2)))
          throw InvalidInput(name + ": non-finite vertex coordinates (NaN or Inf) at vertex " + std::to_string(i));
      }
    } else if (&el == face) {
      // Reserve no more triangles than the rest of the file could describe (a face takes at least one byte per
      // value): a 187-byte file declaring 50 million faces must not allocate 600 MB before failing.
      tris.reserve(static_cast<size_t>(std::min<long>(el.count, static_cast<long>(body.remaining() / 4))) * 3);
      for (long f = 0; f < el.count; ++f) {
        for (const auto& p : el.props) {
          if (!p.list()) {
            body.read(p.type, ename, f);
            continue;
          }
          const long count = body.list_length(body.read(p.count_type, ename, f), ename, f);
          if (p.role != Role::kIndices) {
            body.skip(p.type, count, ename, f);
            continue;
          }
          poly.clear();
          for (long k = 0; k < count; ++k) {
            const double idx = body.read(p.type, ename, f);
            if (!(idx >= 0 && idx < static_cast<double>(nv)) || idx != std::floor(idx))  // NaN fails too
              throw InvalidInput(name + ": face index out of range: face " + std::to_string(f) + " uses vertex " +
                                 index_text(idx) + " but the file has " + std::to_string(nv) + " vertices");
            poly.push_back(static_cast<int32_t>(idx));
          }
          if (count < 3) {
            ++inf.skipped_faces;
            continue;
          }
          if (count > 3) ++inf.polygons;
          for (long k = 1; k + 1 < count; ++k) {  // fan
            tris.push_back(poly[0]);
            tris.push_back(poly[static_cast<size_t>(k)]);
            tris.push_back(poly[static_cast<size_t>(k + 1)]);
          }
        }
      }
    } else {
      for (long i = 0; i < el.count; ++i)
        for (const auto& p : el.props) {
          if (p.list()) {
            body.skip(p.type, body.list_length(body.read(p.count_type, ename, i), ename, i), ename, i);
          } else {
            body.skip(p.type, 1, ename, i);
          }
        }
    }
  }
  if (body.trailing_data())
    throw IoError(name + ": PLY file has more data than its header declares (element counts do not match)");
  mesh.F.resize(static_cast<Eigen::Index>(tris.size() / 3), 3);
  if (!tris.empty()) std::memcpy(mesh.F.data(), tris.data(), tris.size() * sizeof(int32_t));
  if (info) *info = inf;
  return mesh;
}

Mesh read_ply(const std::string& path, PlyInfo* info) { return parse_ply(read_file(path), path, info); }

void io::write_ply(const std::string& path, const Mesh& mesh) {
  const bool colored = mesh.has_colors();
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
}

}  // namespace sdfkit
