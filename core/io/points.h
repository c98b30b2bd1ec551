// Point clouds: text files (.xyz, .txt) and numpy arrays (.npy), read as #P by 3 positions. `sdfkit eval` scores a
// prediction given as a point cloud as it scores the surface samples of a mesh (metrics/protocols.h).
#pragma once

#include "core/types.h"

#include <string>

namespace sdfkit {

/// Parse a text point cloud: one point per line, its first three numbers x y z separated by blanks (spaces or
/// tabs); further columns (normals, colours, ...) are ignored; '#' starts a comment; blank lines are skipped; "\r\n"
/// line ends are accepted. `name` starts every message; lines count from 1, as in an editor.
/// Throws IoError "<name>: line N: expected three numbers x y z ..." for any other line, InvalidInput
/// "<name>: line N: non-finite coordinates (NaN or Inf)" and "<name>: no points".
Points parse_xyz(const std::string& text, const std::string& name);

/// Read a text point cloud file (parse_xyz of its bytes, messages name `path`). IoError when it cannot be read.
Points read_xyz(const std::string& path);

/// True when `path` ends in an extension read_point_cloud reads (.xyz, .txt, .npy; case-insensitive).
bool has_point_cloud_extension(const std::string& path);

/// A point cloud by extension: .xyz and .txt through read_xyz; .npy: a float array of N x 3 or more columns
/// (read_npy of core/files.h), whose first three columns are the positions. IoError for another extension or
/// fewer columns, InvalidInput for no points or non-finite coordinates; every message names `path`.
Points read_point_cloud(const std::string& path);

}  // namespace sdfkit
