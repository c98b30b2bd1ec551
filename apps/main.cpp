// `sdfkit`: parse the sub-command, run it, turn every error into one line and the contract's exit code.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "nets/comm.h"
#include "nets/denormals.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <malloc.h>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace sdfkit::app {

std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}

bool register_command(Command command) {
  registry().push_back(std::move(command));
  return true;
}

const std::vector<std::string> kMeshOutExtensions = {"obj", "ply", "off", "stl", "glb"};

bool is_mesh_out_path(const std::string& path) {
  const std::string e = extension_of(path);
  return std::find(kMeshOutExtensions.begin(), kMeshOutExtensions.end(), e) != kMeshOutExtensions.end();
}

bool stderr_is_tty() { return ::isatty(STDERR_FILENO) == 1; }

namespace {
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// A validator that parses the value as a number and applies `ok`; `rule` completes "must be ...".
CLI::Validator numeric_check(std::function<bool(double)> ok, const std::string& rule, const std::string& help) {
  return CLI::Validator(
      [ok, rule](std::string& in) -> std::string {
        double v = 0;
        try {
          size_t used = 0;
          v = std::stod(in, &used);
          if (used != in.size()) return "'" + in + "' is not a number";
        } catch (const std::exception&) {
          return "'" + in + "' is not a number";
        }
        if (!ok(v)) return "must be " + rule + " (got " + in + ")";
        return std::string();
      },
      help);
}
}  // namespace

CLI::Validator positive() {
  return numeric_check([](double v) { return v > 0; }, "> 0", "POSITIVE");
}
CLI::Validator non_negative() {
  return numeric_check([](double v) { return v >= 0; }, ">= 0", "NONNEGATIVE");
}
CLI::Validator in_range(double lo, double hi) {
  return numeric_check([lo, hi](double v) { return v >= lo && v <= hi; },
                       "between " + number_text(lo) + " and " + number_text(hi),
                       "in [" + number_text(lo) + " - " + number_text(hi) + "]");
}

namespace {

/// The comma-separated items of `text`, empty ones included ("a,,b" and "a," have an empty item; "" has one).
std::vector<std::string> comma_items(const std::string& text) {
  std::vector<std::string> items(1);
  for (const char c : text) {
    if (c == ',')
      items.emplace_back();
    else
      items.back() += c;
  }
  return items;
}

}  // namespace

std::vector<int> parse_widths(const std::string& text, const std::string& what) {
  std::vector<int> out;
  if (text.empty()) throw InvalidInput(what + ": empty list");
  for (const std::string& item : comma_items(text)) {
    try {
      size_t used = 0;
      const int v = std::stoi(item, &used);
      if (used != item.size() || v <= 0) throw std::invalid_argument(item);
      out.push_back(v);
    } catch (const std::exception&) {
      throw InvalidInput(what + " '" + text + "': expected positive integers separated by commas");
    }
  }
  return out;
}

std::string join_widths(const std::vector<int>& widths) {
  std::string text;
  for (size_t i = 0; i < widths.size(); ++i) text += (i ? "," : "") + std::to_string(widths[i]);
  return text;
}

std::pair<double, double> parse_positive_range(const std::string& text, const std::string& what) {
  double lo = 0, hi = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf%c", &lo, &hi, &tail) != 2 || !(lo > 0) || !(hi >= lo) || !std::isfinite(hi))
    throw InvalidInput(what + " wants MIN,MAX with 0 < MIN <= MAX, got '" + text + "'");
  return {lo, hi};
}

std::vector<double> parse_zoom_list(const std::string& text, const std::string& what) {
  std::vector<double> out;
  if (text == "none") return out;
  if (text.empty()) throw InvalidInput(what + " wants magnifications in [0.5, 2] or none; got ''");
  for (const std::string& item : comma_items(text)) {
    double k = 0;
    char tail = 0;
    if (std::sscanf(item.c_str(), "%lf%c", &k, &tail) != 1 || !std::isfinite(k) || k < 0.5 || k > 2 || k == 1)
      throw InvalidInput(what + " wants magnifications in [0.5, 2] other than 1, comma-separated, or none; got '" +
                         text + "'");
    out.push_back(k);
  }
  return out;
}

std::string zoom_list(const std::vector<double>& zooms) {
  if (zooms.empty()) return "none";
  std::string out;
  for (double k : zooms) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", k);
    out += (out.empty() ? "" : ",") + std::string(buf);
  }
  return out;
}

std::string default_model_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("SDFKIT_MODEL_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const fs::path dir = exe.parent_path().parent_path() / "share" / "sdfkit" / "models";
  return fs::is_directory(dir, ec) ? dir.string() : std::string();
}

std::string default_model_path(const std::string& file) {
  const std::string dir = default_model_dir();
  return dir.empty() ? std::string() : (std::filesystem::path(dir) / file).string();
}

std::string require_model_path(const std::string& path, const std::string& flag) {
  if (!path.empty()) return path;
  throw sdfkit::InvalidInput("no default model folder (SDFKIT_MODEL_DIR is unset and " +
                             std::string("<sdfkit's folder>/../share/sdfkit/models does not exist): give ") + flag +
                             " or set SDFKIT_MODEL_DIR");
}

struct ProgressBar::Impl {
  std::string label;
  long total;
  std::atomic<long> done{0};
  std::mutex mutex;
  int last_permille = -1;
  bool tty = stderr_is_tty();
  bool finished = false;
};

ProgressBar::ProgressBar(std::string label, long total) : impl_(new Impl) {
  impl_->label = std::move(label);
  impl_->total = std::max(1L, total);
}
ProgressBar::~ProgressBar() {
  finish();
  delete impl_;
}
void ProgressBar::tick() { update(impl_->done.fetch_add(1) + 1); }
namespace {
void draw_bar(const std::string& label, int permille, long done, long total) {
  const int width = 30, fill = permille * width / 1000;
  std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%% (%ld/%ld)", label.c_str(), fill, "##############################",
               width - fill, "", permille / 10.0, done, total);
  std::fflush(stderr);
}
}  // namespace
void ProgressBar::update(long done) {
  impl_->done = done;
  if (!impl_->tty) return;
  const int permille = static_cast<int>(1000 * std::min(done, impl_->total) / impl_->total);
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (permille == impl_->last_permille || impl_->finished) return;
  impl_->last_permille = permille;
  draw_bar(impl_->label, permille, std::min(done, impl_->total), impl_->total);
}
void ProgressBar::print_line(std::FILE* stream, const std::string& line) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const bool drawn = impl_->tty && !impl_->finished && impl_->last_permille >= 0;
  if (drawn) std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  std::fprintf(stream, "%s\n", line.c_str());
  std::fflush(stream);
  if (drawn)
    draw_bar(impl_->label, impl_->last_permille, std::min(impl_->done.load(), impl_->total), impl_->total);
}
void ProgressBar::finish() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->tty && !impl_->finished && impl_->last_permille >= 0) std::fputc('\n', stderr);
  impl_->finished = true;
}

}  // namespace sdfkit::app

int main(int argc, char** argv) {
  using namespace sdfkit::app;
  // Before any thread exists, so that TBB's workers inherit it too (nets/denormals.h says why).
  sdfkit::flush_denormals_on_this_thread();
  // Keep freed memory for reuse instead of returning it to the kernel: training and reconstruction allocate and
  // free the same large buffers (activations, gradients, im2col columns) at every step, and with glibc's default
  // thresholds each of them was a fresh mmap whose pages faulted in again (measured: 6% of a training step's
  // time in the kernel's page-fault path). The price is a process that keeps its peak heap until it exits.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest allowed value on 64-bit
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  auto& commands = registry();
  std::sort(commands.begin(), commands.end(), [](const Command& a, const Command& b) { return a.name < b.name; });

  CLI::App app{"sdfkit " SDFKIT_VERSION
               ": single-view 3D reconstruction with implicit signed distance fields (DISN-style), in C++.\n"
               "Exit codes: 0 success, 1 user error (bad file or flag), 2 some items of a batch failed."};
  app.require_subcommand(1);
  app.fallthrough();  // global flags such as --threads may follow the sub-command too
  app.set_version_flag("--version", std::string("sdfkit ") + SDFKIT_VERSION);
  int threads = 0;
  app.add_option("--threads", threads, "worker threads for parallel work (default: all cores)")
      ->check(non_negative());
  std::function<int()> run;
  // "bench prep" registers `prep` under the group `bench`; groups are created on first use.
  const std::map<std::string, std::string> group_summaries = {
      {"bench", "speed-against-error studies (results go to docs/BENCHMARKS.md)"},
      {"train", "train the pose network, the SDF network or the foreground segmenter"}};
  for (auto& cmd : commands) {
    CLI::App* parent = &app;
    std::string leaf = cmd.name;
    if (const auto space = cmd.name.find(' '); space != std::string::npos) {
      const std::string group = cmd.name.substr(0, space);
      leaf = cmd.name.substr(space + 1);
      parent = nullptr;
      for (CLI::App* existing : app.get_subcommands([](CLI::App*) { return true; }))
        if (existing->get_name() == group) parent = existing;
      if (parent == nullptr) {
        const auto it = group_summaries.find(group);
        parent = app.add_subcommand(group, it == group_summaries.end() ? group : it->second);
        parent->require_subcommand(1);
        parent->fallthrough();
      }
    }
    CLI::App* sub = parent->add_subcommand(leaf, cmd.summary);
    auto runner = std::make_shared<std::function<int()>>(cmd.setup(*sub));
    sub->callback([&run, runner] { run = *runner; });
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the parse error
    return code == 0 ? kOk : kUserError;
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<size_t>(threads));
  try {
    return run ? run() : kUserError;
  } catch (const sdfkit::Error& e) {
    std::cerr << "sdfkit: error: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "sdfkit: error: " << e.what() << '\n';
  }
  // In an MPI job the other ranks may be waiting for this one in a collective: end the job.
  sdfkit::Comm::abort_if_distributed(kUserError);
  return kUserError;
}
