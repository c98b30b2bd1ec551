// What a new user meets before the first command: configuring (scripts/build), the demo's build step.
#include "core/files.h"
#include "scratch.h"

#include <doctest/doctest.h>

#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// `sh -c COMMAND`'s exit code, its stdout and stderr in out/err.
int shell(const std::string& command, std::string& out, std::string& err) {
  const fs::path dir = test::scratch_dir("build_scripts_io");
  const std::string o = (dir / "stdout.txt").string(), e = (dir / "stderr.txt").string();
  const int status = std::system(("(" + command + ") > " + o + " 2> " + e).c_str());
  out = fs::exists(o) ? read_file(o) : "";
  err = fs::exists(e) ? read_file(e) : "";
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST_CASE("configuring sdfkit prints nothing but CMake's status lines (no stray line of OpenVDB's find module)") {
  const fs::path build = test::scratch_dir("configure_quiet") / "build";
  std::string out, err;
  const int code = shell(std::string("cmake -S ") + SDFKIT_SOURCE_DIR + " -B " + build.string() +
                             " -G Ninja -DCMAKE_BUILD_TYPE=Release -DSDFKIT_BUILD_TESTS=OFF",
                         out, err);
  REQUIRE_MESSAGE(code == 0, err);
  CHECK_MESSAGE(err.empty(), err);  // scripts/build sends stdout to /dev/null: stderr is what the user sees
  CHECK(out.find("COMPONENT") == std::string::npos);
  // The OpenVDB find module still ran: its target exists for sdf/ and extract/.
  CHECK(read_file((build / "CMakeCache.txt").string()).find("OpenVDB_INCLUDE_DIR") != std::string::npos);
}

TEST_CASE("scripts/demo builds the sdfkit executable only, through scripts/build --target") {
  // scripts/build with a stand-in `cmake` first on PATH that records its arguments.
  const fs::path dir = test::scratch_dir("demo_build_target");
  const fs::path bin = dir / "bin", log = dir / "cmake.log";
  fs::create_directories(bin);
  write_text_atomic((bin / "cmake").string(), "#!/bin/sh\necho \"$*\" >> " + log.string() + "\n");
  ::chmod((bin / "cmake").c_str(), 0755);
  std::string out, err;
  const std::string env = "PATH=" + bin.string() + ":$PATH SDFKIT_BUILD_DIR=" + (dir / "build").string() + " ";
  REQUIRE(shell(env + SDFKIT_SOURCE_DIR + "/scripts/build --target sdfkit -DSDFKIT_BUILD_TESTS=OFF", out, err) == 0);
  std::string calls = read_file(log.string());
  const auto build_call = calls.find("--build ");
  REQUIRE(build_call != std::string::npos);
  CHECK(calls.substr(build_call).find("--target sdfkit") != std::string::npos);
  CHECK(calls.substr(0, build_call).find("-DSDFKIT_BUILD_TESTS=OFF") != std::string::npos);  // to configure
  CHECK(calls.substr(0, build_call).find("--target") == std::string::npos);
  // Without --target, every target (the test suite when it is configured) as before.
  fs::remove(log);
  REQUIRE(shell(env + SDFKIT_SOURCE_DIR + "/scripts/build", out, err) == 0);
  calls = read_file(log.string());
  CHECK(calls.find("--target") == std::string::npos);
  CHECK(shell(env + SDFKIT_SOURCE_DIR + "/scripts/build --target", out, err) == 1);
  CHECK(err.find("--target needs a target name") != std::string::npos);

  // The demo's own build step names the sdfkit target.
  const std::string demo = read_file(std::string(SDFKIT_SOURCE_DIR) + "/scripts/demo");
  CHECK(demo.find("\nscripts/build --target sdfkit") != std::string::npos);
}
