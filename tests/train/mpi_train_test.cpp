// Data-parallel training over MPI (nets/comm.h): `mpirun -np 2 sdfkit train ...` must write the same checkpoint as
// one process. Compiled only when sdfkit was built with MPI (tests/CMakeLists.txt defines SDFKIT_TEST_MPI and
// SDFKIT_MPIEXEC then).
#ifdef SDFKIT_TEST_MPI

#include "camera/camera.h"
#include "camera/image.h"
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/random.h"
#include "nets/checkpoint.h"

#include <doctest/doctest.h>

#include <filesystem>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// gt.obj of a box [-a, a] x [-0.3, 0.3] x [-b, b] shifted by dx along x: a == b and dx == 0 give a shape with
/// quarter-turn symmetries, the others none (what `train pose --symmetry-tol` reads).
std::string box_obj(double a, double b, double dx) {
  std::string o;
  for (int k = 0; k < 8; ++k)
    o += "v " + std::to_string((k & 1 ? a : -a) + dx) + " " + std::to_string(k & 2 ? 0.3 : -0.3) + " " +
         std::to_string(k & 4 ? b : -b) + "\n";
  // Outward-facing quads split into triangles (1-based).
  const int q[6][4] = {{1, 3, 4, 2}, {5, 6, 8, 7}, {1, 2, 6, 5}, {3, 7, 8, 4}, {1, 5, 7, 3}, {2, 4, 8, 6}};
  for (const auto& f : q)
    o += "f " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\nf " +
         std::to_string(f[0]) + " " + std::to_string(f[2]) + " " + std::to_string(f[3]) + "\n";
  return o;
}

/// Three shapes x 2 views: coloured boxes on transparent renders, random SDF samples, exact cameras, and a gt.obj
/// (shape 0 symmetric under quarter turns).
fs::path make_dataset() {
  const fs::path root = test::scratch_dir("mpi_train");
  fs::remove_all(root);
  std::string list;
  for (int s = 0; s < 3; ++s) {
    const std::string id = "cat/s" + std::to_string(s);
    list += id + "\n";
    MatrixXfR samples(256, 4);
    Rng rng(s + 11);
    for (int r = 0; r < 256; ++r)
      samples.row(r) << float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)),
          float(rng.uniform(-0.1, 0.1));
    write_npy((root / id / "samples.npy").string(), samples);
    write_text_atomic((root / id / "gt.obj").string(), s == 0 ? box_obj(0.4, 0.4, 0) : box_obj(0.5, 0.2, 0.1 * s));
    for (int v = 0; v < 2; ++v) {
      const std::string nn = "0" + std::to_string(v);
      write_camera((root / id / "views" / (nn + ".json")).string(), look_at(70.0 * v + 30 * s, 27, 2.7));
      Image img(137, 137, 4, 0.f);
      for (int y = 40 + 10 * v; y < 90; ++y)
        for (int x = 30 + 15 * s; x < 100; ++x) {
          img.at(x, y, 0) = 0.3f * s;
          img.at(x, y, 1) = 0.5f;
          img.at(x, y, 3) = 1.f;
        }
      write_image((root / id / "views" / (nn + ".png")).string(), img);
    }
  }
  write_text_atomic((root / "train.lst").string(), list);
  return root;
}

// Under AddressSanitizer (scripts/test --sanitize) the ranks record allocation stacks with the slow unwinder: Open
// MPI's libraries keep no frame pointers, so the fast unwinder that the rest of the suite uses (tests/sanitizers/
// env.sh) stops inside them and the leak suppressions by library name (lsan.supp) would not see the library. A
// later option overrides an earlier one; without the sanitizer the variable is ignored.
const std::string kMpirun =
    std::string("env ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0\" ") + SDFKIT_MPIEXEC +
    " --allow-run-as-root --oversubscribe -np 2";

/// Every block and the header of two checkpoints, except the wall-clock seconds recorded in the header.
void check_same_checkpoint(const std::string& a_path, const std::string& b_path) {
  Checkpoint a = load_checkpoint(a_path), b = load_checkpoint(b_path);
  REQUIRE(a.blocks.size() == b.blocks.size());
  for (size_t i = 0; i < a.blocks.size(); ++i) {
    CAPTURE(a.blocks[i].first);
    CHECK(a.blocks[i].first == b.blocks[i].first);
    CHECK(a.blocks[i].second == b.blocks[i].second);
  }
  for (Json* h : {&a.header, &b.header}) {
    h->erase("seconds");
    if (h->contains("training")) (*h)["training"].erase("seconds");
    if (h->contains("curve"))
      for (auto& row : (*h)["curve"]) row[6] = nullptr;  // the curve's seconds column
  }
  CHECK(a.header == b.header);
}

/// Runs `sdfkit --threads 1 ARGS -o ROOT/one.ckpt` in one process and the same with `-o ROOT/two.ckpt` on 2 MPI
/// ranks; both must succeed. Returns the MPI run.
test::CliRun run_one_and_two(const fs::path& root, const std::string& args) {
  const test::CliRun r1 = test::run_sdfkit("--threads 1 " + args + " -o " + (root / "one.ckpt").string());
  REQUIRE_MESSAGE(r1.code == 0, r1.err);
  const test::CliRun r2 = test::run_sdfkit_under(kMpirun, "--threads 1 " + args + " -o " + (root / "two.ckpt").string());
  REQUIRE_MESSAGE(r2.code == 0, r2.err);
  return r2;
}

}  // namespace

TEST_CASE("train sdf on 2 MPI ranks writes the checkpoint of one process, bit for bit") {
  const fs::path root = make_dataset();
  const test::CliRun r2 = run_one_and_two(
      root, "train sdf --data " + root.string() +
                " --val-split '' --encoder 4,6,8 --global 16 --point-mlp 16,32 --decoder 32,16 --batch 3 --points 64 "
                "--steps 4 --val-every 2 --val-shapes 2 --json");
  check_same_checkpoint((root / "one.ckpt").string(), (root / "two.ckpt").string());
  // Rank 0 alone reports: stdout is one JSON document.
  const Json j = Json::parse(r2.out);
  CHECK(j.at("steps").get<long>() == 4);
  fs::remove_all(root);
}

TEST_CASE("train pose on 2 MPI ranks writes the model and the state of one process, bit for bit") {
  const fs::path root = make_dataset();
  const test::CliRun r2 = run_one_and_two(root, "train pose --data " + root.string() +
                            " --val-split '' --width 2 --batch 3 --points 32 --steps 4 --val-every 2 --val-items 3 "
                            "--aug-colour 0.2 --azimuth-bins 8 --json");
  const std::string one = (root / "one.ckpt").string(), two = (root / "two.ckpt").string();
  check_same_checkpoint(one + ".train.ckpt", two + ".train.ckpt");
  check_same_checkpoint(one, two);
  // The defaults take L_cam modulo the shapes' symmetries (shape 0's quarter turns); the state records it.
  CHECK(Json::parse(r2.out).at("symmetric_shapes").get<long>() == 1);
  const Checkpoint state = load_checkpoint(one + ".train.ckpt");
  CHECK(state.header.at("settings").at("symmetries").get<std::string>().find("tol 0.01") != std::string::npos);
  CHECK(state.header.at("settings").at("azimuth_weight").get<double>() > 0);
  fs::remove_all(root);
}

TEST_CASE("more MPI ranks than batch items is a one-line error") {
  const fs::path root = make_dataset();
  const test::CliRun r = test::run_sdfkit_under(
      kMpirun, "train sdf --data " + root.string() + " --val-split '' --batch 1 --steps 1 -o " +
                   (root / "x.ckpt").string());
  CHECK(r.code != 0);
  CHECK(r.err.find("more MPI ranks") != std::string::npos);
  CHECK_FALSE(fs::exists(root / "x.ckpt"));
  fs::remove_all(root);
}

#endif  // SDFKIT_TEST_MPI
