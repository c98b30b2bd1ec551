// CLI-level checks of two output conventions: a progress bar on a terminal is cleared before a message is printed
// under it, and `bench prep --json` is a flag that prints JSON on stdout (as --json is everywhere else).
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/primitives.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const std::string kSource = SDFKIT_SOURCE_DIR;

/// What a terminal shows of each output line: the text after its last carriage return, without the erase-line
/// sequence that may start it.
std::vector<std::string> visible_lines(const std::string& typescript) {
  std::vector<std::string> lines;
  std::istringstream in(typescript);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // the pty's CR LF
    const size_t cr = line.rfind('\r');
    std::string shown = cr == std::string::npos ? line : line.substr(cr + 1);
    if (shown.rfind("\033[K", 0) == 0) shown = shown.substr(3);
    lines.push_back(shown);
  }
  return lines;
}

}  // namespace

// Issue 19: the recon progress bar was not cleared before the next line, so a message was printed after the bar's
// text on the same terminal line. Under a pseudo-terminal (util-linux `script`), every line a terminal shows is
// now either the bar or a message, never the bar followed by a message.
TEST_CASE("recon on a terminal: every message line is printed on a cleared line, never after the progress bar") {
  REQUIRE(fs::exists("/usr/bin/script"));  // util-linux, essential in Debian
  const fs::path dir = test::scratch_dir("progress_tty");
  fs::create_directories(dir / "in");
  // Three good images, then one that fails (sorted last, so the bar is drawn when its error is printed).
  int n = 0;
  for (const auto& e : fs::directory_iterator(kSource + "/data/examples"))
    if (e.path().extension() == ".png" && n < 3 && e.path().string().find(".mask") == std::string::npos)
      fs::copy_file(e.path(), dir / "in" / ("a" + std::to_string(n++) + ".png"));
  REQUIRE(n == 3);
  write_text_atomic((dir / "in" / "z_broken.png").string(), "not a png");
  const std::string cmd = std::string(SDFKIT_EXE) + " --threads 1 recon " + (dir / "in").string() + " -o " +
                          (dir / "out").string() + " --res 17";
  const std::string typescript = (dir / "typescript.txt").string();
  const int status = std::system(("/usr/bin/script -qec '" + cmd + "' " + typescript + " > /dev/null 2>&1").c_str());
  (void)status;  // script returns the command's exit code (2: one item failed); the output is what is checked
  const std::string text = read_file(typescript);
  CHECK(text.find("\033[K") != std::string::npos);  // the bar was drawn and cleared at least once
  bool saw_error = false, saw_bar = false;
  for (const std::string& line : visible_lines(text)) {
    const bool bar = line.rfind("recon [", 0) == 0;
    saw_bar |= bar;
    if (bar) CHECK_MESSAGE(line.back() == ')', "progress bar followed by other text: " << line);
    if (line.find("z_broken.png") != std::string::npos) {
      saw_error = true;
      CHECK_MESSAGE(line.find("recon [") == std::string::npos, "message on the bar's line: " << line);
    }
  }
  CHECK(saw_bar);
  CHECK(saw_error);
}

TEST_CASE("bench prep --json is a flag: JSON on stdout, and a file name after it is taken as a mesh to time") {
  const fs::path dir = test::scratch_dir("bench_prep_json");
  const std::string mesh = (dir / "cube.obj").string();
  write_mesh(mesh, make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5)));
  const test::CliRun r = test::run_sdfkit("bench prep " + mesh + " --only cube --repeats 1 --no-dense --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);  // stdout is JSON alone (the table went to stderr)
  CHECK(j.dump().find("cube") != std::string::npos);
  // The old form `--json FILE`: FILE is now a mesh argument, and a missing one is an error naming it.
  const test::CliRun old = test::run_sdfkit("bench prep --json " + (dir / "results.json").string() + " --only x");
  CHECK(old.code == 1);
  CHECK(old.err.find("results.json") != std::string::npos);
  CHECK(!fs::exists(dir / "results.json"));
}
