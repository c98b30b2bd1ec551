// `sdfkit extract SDF -o OUT`: the mesh of a prepared sparse SDF grid (sdf.vdb) at a chosen grid resolution, with
// the extraction and clean-up `recon` applies to the network's field. On a prepared dataset it writes one mesh per
// shape in the layout `sdfkit eval` reads, so that the exact field's scores bound what any network can reach at
// that resolution under a protocol (docs/results/sdf.md, "ceiling" row).
#include "apps/command.h"
#include "core/error.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "extract/adaptive.h"
#include "extract/cleanup.h"
#include "sdf/sparse_sdf.h"
#include "train/dataset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

namespace sdfkit::app {
namespace {

namespace fs = std::filesystem;

struct Opts {
  std::string input, out, split, format = "obj";
  int resolution = 65;
  double iso = 0.003;
  double box_half = 1.05;
  double keep_fraction = kDefaultKeepFraction;
  bool json = false;
  bool split_given = false, format_given = false;
};

struct Extracted {
  Mesh mesh;
  long evaluations = 0;
  int components_removed = 0;
  double seconds = 0;
};

// The grid's field minus iso on the dense grid points of the recon box, marching cubes, then DISN's clean-up. Dense:
// beyond the stored band the grid holds +-background (a few voxels), which is no distance bound for the adaptive
// extraction's coarse cells, and a dense pass over the trilinear grid costs little.
Extracted extract_grid(const std::string& vdb, const Opts& o) {
  const SparseSdf sdf = SparseSdf::read(vdb);
  if (sdf.active_voxel_count() == 0) throw InvalidInput(vdb + ": the grid has no active voxels (no surface)");
  // Beyond its band the grid holds +-background, so levels at or past it are not stored (a box would come out).
  if (std::abs(o.iso) >= sdf.background())
    throw InvalidInput(vdb + ": no surface at iso " + std::to_string(o.iso) + ": the grid stores distances within +-" +
                       std::to_string(sdf.background()) + " only (prep --band)");
  const BatchField field = [&](const Points& p, Eigen::VectorXd& values) {
    values = sdf.values(p).array() - o.iso;
  };
  ExtractSettings es;
  es.resolution = o.resolution;
  es.box_min = Vec3::Constant(-o.box_half);
  es.box_size = 2 * o.box_half;
  es.iso = 0.0;
  es.close_boundary = true;
  const ExtractResult ex = dense_extract(field, es);
  if (ex.mesh.empty())
    throw InvalidInput(vdb + ": no surface at iso " + std::to_string(o.iso) + " inside the box [-" +
                       std::to_string(o.box_half) + ", " + std::to_string(o.box_half) + "]^3");
  CleanupSettings cs;
  cs.min_component_fraction = o.keep_fraction;
  CleanupReport rep;
  Extracted r;
  r.mesh = cleanup(ex.mesh, cs, &rep);
  r.evaluations = ex.evaluations;
  r.components_removed = rep.components - rep.kept_components;
  r.seconds = ex.seconds;
  return r;
}

Json item_json(const std::string& id, const std::string& out, const Extracted& e) {
  return {{"shape", id},
          {"mesh", out},
          {"vertices", e.mesh.num_vertices()},
          {"faces", e.mesh.num_faces()},
          {"components_removed", e.components_removed},
          {"evaluations", e.evaluations},
          {"seconds", e.seconds}};
}

int run(const Opts& o) {
  if (fs::is_regular_file(o.input)) {
    if (fs::path(o.input).extension() != ".vdb")
      throw InvalidInput(o.input + ": not a .vdb grid (give sdf.vdb or a prepared dataset folder)");
    if (o.split_given || o.format_given)
      throw InvalidInput(std::string(o.split_given ? "--split" : "--format") +
                         " applies to a dataset folder, not to one grid (the format follows -o's extension)");
    if (!is_mesh_out_path(o.out))
      throw InvalidInput("-o " + o.out + ": one grid makes one mesh: give a .obj, .ply, .off, .stl or .glb path");
    const Extracted e = extract_grid(o.input, o);
    write_mesh(o.out, e.mesh);
    if (o.json)
      std::cout << item_json(o.input, o.out, e).dump(2) << '\n';
    else
      std::cout << o.out << ": " << e.mesh.num_vertices() << " vertices, " << e.mesh.num_faces() << " faces ("
                << o.resolution << "^3, iso " << o.iso << ")\n";
    return kOk;
  }
  if (!fs::is_directory(o.input)) throw InvalidInput(o.input + ": no such grid file or dataset folder");
  if (is_mesh_out_path(o.out))
    throw InvalidInput("-o " + o.out + ": a dataset makes one mesh per shape: give a folder, not a mesh path");
  // The shapes: a split of the dataset, or every <category>/<shape>/sdf.vdb below it.
  std::vector<std::string> ids;
  if (!o.split.empty()) {
    ids = read_split_file(resolve_split_file(o.input, o.split));
    if (ids.empty()) throw InvalidInput("--split " + o.split + ": the split lists no shapes");
  } else {
    for (const auto& c : fs::directory_iterator(o.input)) {
      if (!c.is_directory()) continue;
      for (const auto& s : fs::directory_iterator(c.path()))
        if (fs::exists(s.path() / "sdf.vdb")) ids.push_back(c.path().filename().string() + "/" + s.path().filename().string());
    }
    std::sort(ids.begin(), ids.end());
    if (ids.empty()) throw InvalidInput(o.input + ": no <category>/<shape>/sdf.vdb below it (not a prepared dataset)");
  }
  ProgressBar bar("extract", static_cast<long>(ids.size()));
  Json items = Json::array();
  std::vector<std::string> failed;
  for (const std::string& id : ids) {
    const fs::path vdb = fs::path(o.input) / id / "sdf.vdb";
    const fs::path out = fs::path(o.out) / (id + "." + o.format);
    try {
      if (!fs::exists(vdb)) throw IoError(vdb.string() + ": no such grid");
      const Extracted e = extract_grid(vdb.string(), o);
      fs::create_directories(out.parent_path());
      write_mesh(out.string(), e.mesh);
      items.push_back(item_json(id, out.string(), e));
      if (!o.json)
        bar.print_line(stdout, id + ": " + std::to_string(e.mesh.num_vertices()) + " vertices, " +
                                   std::to_string(e.mesh.num_faces()) + " faces");
    } catch (const Error& e) {
      failed.push_back(id);
      items.push_back({{"shape", id}, {"error", e.what()}});
      bar.print_line(stderr, std::string("sdfkit: error: ") + e.what());
    }
    bar.tick();
  }
  bar.finish();
  if (o.json)
    std::cout << Json{{"resolution", o.resolution}, {"iso", o.iso}, {"items", items}, {"failed", failed}}.dump(2)
              << '\n';
  else
    std::cout << "extract: " << ids.size() - failed.size() << " of " << ids.size() << " shapes written to " << o.out
              << " (" << o.resolution << "^3, iso " << o.iso << ")\n";
  if (failed.empty()) return kOk;
  std::string list;
  for (const auto& f : failed) list += (list.empty() ? "" : ", ") + f;
  std::cerr << "sdfkit: extract: " << failed.size() << " shape(s) failed: " << list << '\n';
  return failed.size() == ids.size() ? kUserError : kPartialFailure;
}

std::function<int()> setup_extract(CLI::App& app) {
  auto o = std::make_shared<Opts>();
  app.add_option("sdf", o->input,
                 "a sparse SDF grid (sdf.vdb from `sdfkit prep`) or a prepared dataset folder "
                 "(<category>/<shape>/sdf.vdb)")
      ->required();
  app.add_option("-o,--out", o->out,
                 "the mesh (.obj .ply .off .stl) for one grid; for a dataset, a folder that receives "
                 "<category>/<shape>.<format> (the layout `sdfkit eval` reads)")
      ->required();
  app.add_option("--res", o->resolution, "grid points per axis over the box (recon's --res: 65, 129, 257, ...)")
      ->capture_default_str()
      ->check(in_range(3, 2049));
  app.add_option("--iso", o->iso,
                 "level extracted, in object units (default DISN's 0.003: the level the SDF network's zero and the "
                 "prepared gt.obj lie on)")
      ->capture_default_str();
  app.add_option("--box-half", o->box_half, "sampled cube [-B, B]^3 (recon's: the unit sphere + 5%)")
      ->capture_default_str()
      ->check(positive());
  app.add_option("--keep-fraction", o->keep_fraction,
                 "drop mesh components with fewer faces than this fraction of the largest (recon's default; DISN: 0.3)")
      ->capture_default_str()
      ->check(in_range(0, 1));
  CLI::Option* split_opt = app.add_option("--split", o->split, "dataset: only the shapes of this split (a name looked up as SDF/NAME.lst, or a list file)");
  CLI::Option* format_opt = app.add_option("--format", o->format, "dataset: mesh format of the files written (obj, ply, off, stl)")
      ->capture_default_str()
      ->check(CLI::IsMember(kMeshOutExtensions));
  app.add_flag("--json", o->json, "print JSON on stdout (one grid: the mesh's figures; dataset: every item and the failures)");
  return [o, split_opt, format_opt] {
    o->split_given = split_opt->count() > 0;
    o->format_given = format_opt->count() > 0;
    return run(*o);
  };
}

SDFKIT_REGISTER_COMMAND("extract", "extract the mesh of a prepared SDF grid (or of every shape of a dataset) at a chosen resolution",
                        setup_extract);

}  // namespace
}  // namespace sdfkit::app
