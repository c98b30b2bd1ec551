#include "core/files.h"

#include "core/error.h"
#include "core/json.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace sdfkit {

void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write) {
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec)
      throw IoError(path + ": cannot create its folder " + target.parent_path().string() + " (" + ec.message() + ")");
  }
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    errno = 0;
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const std::string why = errno != 0 ? std::string(" (") + std::strerror(errno) + ")" : std::string();
      throw IoError(path + ": cannot open for writing" + why);
    }
    try {
      write(out);
    } catch (...) {
      out.close();
      fs::remove(tmp, ec);
      throw;
    }
    out.close();  // a full disk may only say so when the last buffer is written
    if (out.fail()) {
      fs::remove(tmp, ec);
      throw IoError(path + ": write failed (disk full?)");
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw IoError(path + ": cannot rename temporary file into place");
  }
}

void write_text_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, [&](std::ostream& o) { o << text; });
}

FolderLock::FolderLock(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(dir + ": cannot create the folder (" + ec.message() + ")");
  fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) throw IoError(dir + ": cannot open the folder (" + std::strerror(errno) + ")");
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) {
    held_ = true;
  } else if (errno != EWOULDBLOCK) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    fd_ = -1;
    throw IoError(dir + ": cannot lock the folder (" + why + ")");
  }
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the lock
}

int remove_stale_temporaries(const std::string& path) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string prefix = target.filename().string() + ".tmp.";
  std::error_code ec;
  int removed = 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    const pid_t pid = static_cast<pid_t>(std::stol(digits));
    if (pid == ::getpid() || (::kill(pid, 0) == 0 || errno == EPERM)) continue;  // a live writer's file
    std::error_code rm;
    if (fs::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open (" + std::strerror(errno) + ")");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_json(const std::string& path, const Json& j) { write_text_atomic(path, j.dump(2) + "\n"); }

Json read_json(const std::string& path) {
  const std::string text = read_file(path);
  try {
    return Json::parse(text);
  } catch (const std::exception& e) {
    throw IoError(path + ": invalid JSON (" + e.what() + ")");
  }
}

void write_npy(const std::string& path, const MatrixXfR& m) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(m.rows()) + ", " +
                       std::to_string(m.cols()) + "), }";
  // Magic (6) + version (2) + header length (2) + header + '\n' must be a multiple of 64.
  const size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  write_file_atomic(path, [&](std::ostream& o) {
    o.write("\x93NUMPY\x01\x00", 8);
    const auto len = static_cast<uint16_t>(header.size());
    const char lenb[2] = {static_cast<char>(len & 0xff), static_cast<char>(len >> 8)};
    o.write(lenb, 2);
    o.write(header.data(), static_cast<std::streamsize>(header.size()));
    o.write(reinterpret_cast<const char*>(m.data()), static_cast<std::streamsize>(m.size() * sizeof(float)));
  });
}

MatrixXfR read_npy(const std::string& path) {
  const std::string bytes = read_file(path);
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0) throw IoError(path + ": not a .npy file");
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0, offset = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) throw IoError(path + ": truncated .npy header");
    header_len = 0;
    for (int i = 0; i < 4; ++i) header_len |= static_cast<size_t>(static_cast<unsigned char>(bytes[8 + i])) << (8 * i);
    offset = 12;
  } else {
    throw IoError(path + ": unsupported .npy version " + std::to_string(major));
  }
  if (bytes.size() < offset + header_len) throw IoError(path + ": truncated .npy header");
  const std::string header = bytes.substr(offset, header_len);
  const size_t data_start = offset + header_len;
  const bool f4 = header.find("'<f4'") != std::string::npos;
  const bool f8 = header.find("'<f8'") != std::string::npos;
  if (!f4 && !f8) throw IoError(path + ": only little-endian float32/float64 .npy arrays are supported");
  if (header.find("'fortran_order': True") != std::string::npos) throw IoError(path + ": Fortran-order .npy not supported");
  const size_t key = header.find("'shape'");
  const size_t p0 = key == std::string::npos ? key : header.find('(', key);
  const size_t p1 = p0 == std::string::npos ? p0 : header.find(')', p0);
  if (p0 == std::string::npos || p1 == std::string::npos) throw IoError(path + ": .npy header has no shape");
  // Each dimension: decimal digits only, checked against the bytes the file holds before any product is formed,
  // so that no count can overflow, wrap or ask for more memory than the file could fill.
  const size_t elem = f4 ? 4 : 8;
  const uint64_t available = (bytes.size() - data_start) / elem;  // values the data section can hold
  std::vector<uint64_t> shape;
  std::stringstream ss(header.substr(p0 + 1, p1 - p0 - 1));
  std::string item;
  while (std::getline(ss, item, ',')) {
    item.erase(std::remove_if(item.begin(), item.end(), [](unsigned char c) { return std::isspace(c); }),
               item.end());
    if (item.empty()) continue;
    uint64_t n = 0;
    for (const char c : item)
      if (c < '0' || c > '9') throw IoError(path + ": .npy shape entry '" + item + "' is not a non-negative integer");
    if (item.size() > 18) throw IoError(path + ": .npy shape entry '" + item + "' is too large");
    for (const char c : item) n = n * 10 + static_cast<uint64_t>(c - '0');  // < 10^18: no overflow
    shape.push_back(n);
  }
  if (shape.empty() || shape.size() > 2) throw IoError(path + ": .npy array must be 1-D or 2-D");
  const uint64_t rows = shape[0], cols = shape.size() == 2 ? shape[1] : 1;
  if (cols > 0 && rows > available / cols)
    throw IoError(path + ": truncated .npy data (shape " + std::to_string(rows) + " x " + std::to_string(cols) +
                  " needs more than the " + std::to_string(bytes.size() - data_start) + " data bytes present)");
  const size_t count = static_cast<size_t>(rows * cols);
  MatrixXfR m(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
  if (count == 0) return m;  // (0,), (0, 3), (3, 0): nothing to copy
  const char* src = bytes.data() + data_start;
  if (f4) {
    std::memcpy(m.data(), src, count * 4);
  } else {
    for (size_t i = 0; i < count; ++i) {
      double v;
      std::memcpy(&v, src + 8 * i, 8);
      m.data()[i] = static_cast<float>(v);
    }
  }
  return m;
}

uint64_t fnv1a(const char* data, size_t n, uint64_t h) {
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ULL;
  }
  return h;
}

std::string fnv1a_hex(const std::string& bytes) {
  const uint64_t h = fnv1a(bytes.data(), bytes.size(), kFnv1aHexStart);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

namespace {

/// `dir/rel` with every component of `rel` matched case-insensitively when the exact one is missing; "" if none.
fs::path case_insensitive_path(const fs::path& dir, const fs::path& rel) {
  fs::path at = dir;
  for (const fs::path& part : rel) {
    if (part.empty() || part == ".") continue;
    if (part == "..") {
      at /= part;
      continue;
    }
    std::error_code ec;
    if (fs::exists(at / part, ec)) {
      at /= part;
      continue;
    }
    std::string want = part.string();
    std::transform(want.begin(), want.end(), want.begin(), [](unsigned char c) { return std::tolower(c); });
    fs::path found;
    for (fs::directory_iterator it(at.empty() ? fs::path(".") : at, ec), end; !ec && it != end; it.increment(ec)) {
      std::string got = it->path().filename().string();
      std::transform(got.begin(), got.end(), got.begin(), [](unsigned char c) { return std::tolower(c); });
      // The first match in sorted order, so that the answer does not depend on the directory's order.
      if (got == want && (found.empty() || it->path().filename() < found)) found = it->path().filename();
    }
    if (found.empty()) return {};
    at /= found;
  }
  return at;
}

bool is_regular(const fs::path& p) {
  std::error_code ec;
  return !p.empty() && fs::is_regular_file(p, ec);
}

}  // namespace

std::string find_referenced_file(const std::string& dir, const std::string& name) {
  std::string n = name;
  const auto blank = [](unsigned char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!n.empty() && blank(static_cast<unsigned char>(n.back()))) n.pop_back();
  size_t start = 0;
  while (start < n.size() && blank(static_cast<unsigned char>(n[start]))) ++start;
  n.erase(0, start);
  if (n.size() >= 2 && (n.front() == '"' || n.front() == '\'') && n.back() == n.front()) n = n.substr(1, n.size() - 2);
  std::replace(n.begin(), n.end(), '\\', '/');
  if (n.empty()) return "";
  const bool drive = n.size() >= 2 && std::isalpha(static_cast<unsigned char>(n[0])) && n[1] == ':';
  if (drive) n.erase(0, 2);
  const fs::path rel(n);
  const fs::path base = dir.empty() ? fs::path(".") : fs::path(dir);
  if (rel.is_absolute() && !drive && is_regular(rel)) return rel.lexically_normal().string();
  // The path as written, then without its leading folders one by one (an absolute or foreign path whose tail is
  // the layout beside the mesh: "f:/models/chair/Textures/wood.jpg" -> "Textures/wood.jpg" -> "wood.jpg").
  std::vector<fs::path> parts;
  for (const fs::path& part : rel.relative_path())
    if (!part.empty() && part != ".") parts.push_back(part);
  for (size_t from = 0; from < parts.size(); ++from) {
    fs::path tail;
    for (size_t k = from; k < parts.size(); ++k) tail /= parts[k];
    if (is_regular(base / tail)) return (base / tail).lexically_normal().string();
    const fs::path found = case_insensitive_path(base, tail);
    if (is_regular(found)) return found.lexically_normal().string();
  }
  return "";
}

std::string extension_of(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace sdfkit
