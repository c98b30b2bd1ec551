// For CLI-level tests: runs the built `sdfkit` executable (SDFKIT_EXE, defined by tests/CMakeLists.txt) and returns
// its exit code, stdout and stderr.
#pragma once

#include "core/files.h"
#include "scratch.h"

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace sdfkit::test {

struct CliRun {
  int code = -1;
  std::string out, err;
};

/// `PREFIX sdfkit ARGS` (PREFIX: a launcher such as "mpirun -np 2", or empty); stdout and stderr pass through
/// files in this process's own scratch folder (scratch.h).
inline CliRun run_sdfkit_under(const std::string& prefix, const std::string& args) {
  const std::filesystem::path scratch = scratch_dir("cli_io");
  const std::string out = (scratch / "stdout.txt").string(), err = (scratch / "stderr.txt").string();
  const int status =
      std::system((prefix + (prefix.empty() ? "" : " ") + SDFKIT_EXE + " " + args + " > " + out + " 2> " + err).c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = std::filesystem::exists(out) ? read_file(out) : "";
  r.err = std::filesystem::exists(err) ? read_file(err) : "";
  return r;
}

/// `sdfkit ARGS`.
inline CliRun run_sdfkit(const std::string& args) { return run_sdfkit_under("", args); }

}  // namespace sdfkit::test
