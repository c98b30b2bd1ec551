// A small exception family thrown at library boundaries. apps/ catches them, prints one line and exits 1.
#pragma once

#include <stdexcept>
#include <string>

namespace sdfkit {

/// Base of everything sdfkit throws on purpose.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The caller's data is unusable: empty mesh, NaN coordinates, bad indices, bad flag value, shape mismatch.
struct InvalidInput : Error {
  using Error::Error;
};

/// A file could not be read or written, or its content is malformed / truncated.
struct IoError : Error {
  using Error::Error;
};

/// Throw InvalidInput with `message` unless `condition` holds (public-entry argument checks).
inline void require(bool condition, const std::string& message) {
  if (!condition) throw InvalidInput(message);
}

}  // namespace sdfkit
