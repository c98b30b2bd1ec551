// Files written the safe way (temporary file + rename), .npy arrays, JSON files, content hashes.
#pragma once

#include "core/json_fwd.h"

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace sdfkit {

/// Write a file atomically: `write` fills a stream on `path + ".tmp.<pid>"`, which is renamed onto `path`
/// only when it succeeded, so a crash or error never leaves a half-written `path`. Parent folders are
/// created. Throws IoError naming the path.
void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write);
void write_text_atomic(const std::string& path, const std::string& text);
/// Removes the temporary files `path + ".tmp.<pid>"` that write_file_atomic left behind when its process was killed
/// (the pid no longer runs on this machine); a live writer's file is left alone. Returns how many were removed.
int remove_stale_temporaries(const std::string& path);
/// An exclusive lock on a folder (flock), held while the object lives and released by the kernel when the process
/// ends, however it ends. Two processes (or two objects in one process) cannot hold the same folder's lock.
class FolderLock {
 public:
  /// Creates `dir` when missing and tries to lock it without waiting: locked() tells whether it got it. Throws
  /// IoError naming the folder when it cannot be created or opened.
  explicit FolderLock(const std::string& dir);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  [[nodiscard]] bool locked() const { return held_; }

 private:
  int fd_ = -1;
  bool held_ = false;
};

/// Whole file as bytes; IoError naming the path when it cannot be read.
std::string read_file(const std::string& path);

/// JSON written with 2-space indent (stable key order: nlohmann sorts object keys).
void write_json(const std::string& path, const Json& j);
Json read_json(const std::string& path);

/// float32 N x C matrix <-> NumPy .npy (version 1.0, little endian, C order).
using MatrixXfR = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
void write_npy(const std::string& path, const MatrixXfR& m);
/// Reads '<f4' or '<f8' 1-D/2-D C-order arrays (converted to float32). IoError on anything else.
MatrixXfR read_npy(const std::string& path);

/// 64-bit FNV-1a of `n` bytes, continuing from `h` (the offset basis by default: continue with a previous result
/// to hash concatenated data without copying it).
uint64_t fnv1a(const char* data, size_t n, uint64_t h = 0xcbf29ce484222325ULL);
/// The start value of fnv1a_hex: one digit short of FNV's offset basis (14695981039346656037), a slip kept on
/// purpose: source hashes in norm.json, the per-shape sample seeds and the sdf.vdb UUIDs are derived from it, and
/// changing it would change every prepared dataset's bytes.
constexpr uint64_t kFnv1aHexStart = 1469598103934665603ULL;
/// fnv1a(bytes, kFnv1aHexStart), printed as 16 hex digits (identifies a source file in norm.json).
std::string fnv1a_hex(const std::string& bytes);

/// The file that `name`, as a mesh file's material names it (an MTL texture map, a glTF image uri), refers to from the
/// folder `dir`, found the way exporters' files are meant: `name` trimmed of surrounding blanks (spaces, tabs, CR)
/// and quotes, backslashes read as slashes, a drive letter ("f:", "K:/") dropped; then, in order, an existing
/// absolute path as written, and `dir` joined with the path without 0, 1, 2, ... of its leading folders (down to the
/// file name alone), each exactly and then matching every component case-insensitively (the first match in sorted
/// order). "" when none exists (only regular files count).
std::string find_referenced_file(const std::string& dir, const std::string& name);

/// Lower-case extension without the dot ("mesh.PLY" -> "ply"); "" when none.
std::string extension_of(const std::string& path);

/// Progress/cancel hook for long work: called with a fraction in [0, 1]; return false to cancel.
using ProgressFn = std::function<bool(double)>;

}  // namespace sdfkit
