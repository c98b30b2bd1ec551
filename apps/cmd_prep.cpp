// `sdfkit prep MESH|DIR|LIST -o OUT`: prepare a DISN-style dataset (sparse SDF grid, samples, ground truth).
// Thin: gathers the shape list, maps flags onto sdfkit::PrepareSettings, runs sdfkit::prepare_shape per shape
// (TBB, --jobs), writes manifest.json and prints a summary. See docs/prep.md.
#include "apps/command.h"
#include "camera/texture.h"
#include "camera/views.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "core/random.h"
#include "sdf/normalize.h"
#include "sdf/prepare.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <utility>

namespace sdfkit::app {
namespace {
namespace fs = std::filesystem;

struct ShapeJob {
  ShapeJob(std::string c, std::string s, std::string p)
      : category(std::move(c)), shape(std::move(s)), path(std::move(p)) {}
  std::string category, shape, path;
  std::string status = "pending";  // ok | failed
  std::string reason;
  bool skipped = false;
};

/// A mesh path to prepare: a file with a mesh extension, or a dangling symbolic link with one (reported as a
/// failed item, not silently dropped).
bool is_mesh_file(const fs::path& p) {
  if (!has_mesh_extension(p.string())) return false;
  std::error_code ec;
  return fs::is_regular_file(p, ec) || (fs::is_symlink(fs::symlink_status(p, ec)) && !fs::exists(p, ec));
}

/// Mesh files below `dir`, as listed (every path starts with `dir`; links are never resolved into the paths).
/// Sub-folders reached through symbolic links are walked like real ones; a link back to a folder that is being
/// walked (a cycle) is not entered again. `active`: canonical paths of the folders being walked.
void collect_meshes(const fs::path& dir, std::vector<fs::path>& out, std::vector<fs::path>& active) {
  std::error_code ec;
  const fs::path canonical = fs::canonical(dir, ec);
  if (ec || std::find(active.begin(), active.end(), canonical) != active.end()) return;
  active.push_back(canonical);
  std::vector<fs::path> entries{fs::directory_iterator(dir), fs::directory_iterator{}};
  std::sort(entries.begin(), entries.end());
  for (const auto& p : entries) {
    if (fs::is_directory(p, ec))
      collect_meshes(p, out, active);
    else if (is_mesh_file(p))
      out.push_back(p);
  }
  active.pop_back();
}

/// Shape id of a mesh below a category folder: its stem when it sits directly in the category, else the name of
/// the first folder below the category (ShapeNet's <synset>/<id>/models/model_normalized.obj). Computed from the
/// path as listed, never from where a symbolic link points.
std::string shape_id(const fs::path& category_dir, const fs::path& file) {
  const fs::path rel = file.lexically_relative(category_dir);
  auto it = rel.begin();
  if (it == rel.end() || std::next(it) == rel.end()) return file.stem().string();
  return it->string();
}

/// Why `name` cannot be one folder level below the output folder ("" when it can). Category and shape ids come
/// from file names and list lines; "..", "." or a '/' would put a shape's files outside <out>/<category>/<shape>/,
/// on top of the dataset or of another shape.
std::string bad_id_part(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name == "..") return "it names the parent folder";
  if (name == ".") return "it names the folder itself";
  if (name.find('/') != std::string::npos) return "it contains '/'";
  return "";
}

std::vector<ShapeJob> gather(const std::string& input) {
  std::vector<ShapeJob> jobs;
  const fs::path in(input);
  if (!fs::exists(in)) throw IoError(input + ": no such file or folder");
  if (fs::is_directory(in)) {
    std::vector<fs::path> entries{fs::directory_iterator(in), fs::directory_iterator{}};
    std::sort(entries.begin(), entries.end());
    for (const auto& e : entries) {
      if (is_mesh_file(e)) {
        jobs.push_back({"default", e.stem().string(), e.string()});
      } else if (fs::is_directory(e)) {
        std::vector<fs::path> files, active;
        collect_meshes(e, files, active);
        for (const auto& f : files) jobs.push_back({e.filename().string(), shape_id(e, f), f.string()});
      }
    }
    if (jobs.empty()) throw InvalidInput(input + ": no .obj/.ply/.off/.stl meshes in this folder or its sub-folders");
    return jobs;
  }
  if (has_mesh_extension(input)) {
    jobs.push_back({"default", in.stem().string(), input});
    return jobs;
  }
  // A list file: one mesh per line, optionally "category<TAB>path"; '#' starts a comment; relative paths are
  // relative to the list's folder.
  std::ifstream list(input);
  if (!list) throw IoError(input + ": cannot read the list file");
  std::string line;
  long number = 0;
  while (std::getline(list, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::string category = "default", path = line;
    if (const auto tab = line.find('\t'); tab != std::string::npos) {
      category = line.substr(0, tab);
      path = line.substr(tab + 1);
    }
    if (!bad_id_part(category).empty())
      throw InvalidInput(input + ":" + std::to_string(number) + ": bad category '" + category + "'");
    fs::path p(path);
    if (!has_mesh_extension(path))  // most often: a mesh with an unknown extension read as a list
      throw InvalidInput(input + ":" + std::to_string(number) + ": '" + path +
                         "' is not a .obj/.ply/.off/.stl path (a list file names one mesh per line; meshes need one "
                         "of these extensions)");
    if (p.is_relative()) p = in.parent_path() / p;
    jobs.push_back({category, p.stem().string(), p.string()});
  }
  if (jobs.empty()) throw InvalidInput(input + ": the list names no meshes (or is not a mesh: unknown extension)");
  return jobs;
}

std::function<int()> setup_prep(CLI::App& app) {
  struct Opts {
    std::string input, out, shard, gt = "auto", sign = "auto", up = "y";
    double voxel = 2.4 / 256, band = 0.0, uniform_share = 0.0, sheet = PrepareSettings{}.sheet_voxels;
    long samples = 32768;
    int views = 24, jobs = 0;
    uint64_t seed = 0;
    bool overwrite = false, quiet = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("input", o->input,
                 "a mesh (.obj .ply .off .stl .gltf .glb), a folder (categories = sub-folders, shape id = file stem), or a list "
                 "file (one mesh path per line, optionally 'category<TAB>path')")
      ->required();
  app.add_option("-o,--out", o->out, "output dataset folder (<out>/<category>/<shape>/...)")->required();
  app.add_option("--voxel", o->voxel, "voxel size in object units (default 2.4/256 = DISN's 257^3 grid over [-1.2,1.2]^3)")
      ->check(positive())
      ->capture_default_str();
  app.add_option("--band", o->band,
                 "half-width of the stored narrow band in object units; 0 = 3 voxels (samples are exact and need no "
                 "wide band; 0.12 stores every |sdf - 0.003| <= 0.1 in the grid as DISN's dense grids do)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--sign", o->sign,
                 "inside/outside test: auto (pseudo-normals for closed one-part meshes, else winding numbers), "
                 "winding (generalized winding numbers always), flood (auto, plus the cavities the surface seals at "
                 "the voxel size, gaps under about 1.7 voxels, counted inside: DISN's polygon-soup convention)")
      ->check(CLI::IsMember({"auto", "winding", "flood"}))
      ->capture_default_str();
  app.add_option("--sheet", o->sheet,
                 "half-thickness, in voxels, given to open single-sided sheets (a sling seat, a leaf: faces with no "
                 "inside on either side) before the SDF, so that the iso-surface ground truth and the samples see a "
                 "solid slab instead of a shell thinner than a voxel; 0 = none; closed meshes are never changed")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--samples", o->samples, "training samples per shape, in four equal bins on d = sdf - 0.003")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--uniform-share", o->uniform_share,
                 "fraction of the samples drawn uniformly in [-1.2,1.2]^3 for far-field supervision")
      ->check(in_range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--views", o->views,
                 "rendered views per shape into <shape>/views/NN.png + NN.json (camera/views.h defaults: 137 px, "
                 "azimuth 0-360, elevation 25-30, distance 2.45-3.0; 0 = none)")
      ->check(non_negative())
      ->capture_default_str();
  app.add_option("--gt", o->gt, "ground truth gt.obj: auto (input if closed and one part, else iso-surface), input, iso")
      ->check(CLI::IsMember({"auto", "input", "iso"}))
      ->capture_default_str();
  app.add_option("-j,--jobs", o->jobs, "shapes prepared in parallel, each using the worker threads (0 = all cores)")
      ->check(non_negative());
  app.add_option("--shard", o->shard, "i/n: prepare only shapes whose index modulo n is i (sorted by category/shape)");
  app.add_option("--seed", o->seed, "sample seed (each shape derives its own stream from seed and category/shape)")
      ->capture_default_str();
  app.add_option("--up", o->up, "the meshes' up axis: y (ShapeNet's, sdfkit's), z (Blender's, most CAD tools') or x; "
                 "turned to +y before anything else")
      ->capture_default_str()
      ->check(CLI::IsMember({"y", "z", "x"}));
  app.add_flag("--overwrite", o->overwrite, "redo shapes that are already complete");
  app.add_flag("-q,--quiet", o->quiet, "print only the summary line");
  return [o] {
    ViewSetSettings view_settings;
    view_settings.views = std::max(1, o->views);
    validate_view_set_settings(view_settings);
    long shard_i = 0, shard_n = 1;
    if (!o->shard.empty()) {
      if (std::sscanf(o->shard.c_str(), "%ld/%ld", &shard_i, &shard_n) != 2 || shard_n < 1 || shard_i < 0 ||
          shard_i >= shard_n)
        throw InvalidInput("--shard '" + o->shard + "': expected i/n with 0 <= i < n");
    }
    PrepareSettings s;
    s.up = parse_up_axis(o->up);
    s.grid.voxel_size = o->voxel;
    s.grid.band = o->band;
    s.grid.sign = o->sign == "winding" ? SignMethod::kWindingNumber : SignMethod::kAuto;
    s.grid.seal = o->sign == "flood";
    s.sheet_voxels = o->sheet;
    s.samples.count = o->samples;
    s.samples.uniform_share = o->uniform_share;
    s.gt = o->gt == "input" ? GtSource::kInput : o->gt == "iso" ? GtSource::kIsoSurface : GtSource::kAuto;
    s.overwrite = o->overwrite;
    if (o->band > 0 && o->band < o->voxel)
      throw InvalidInput("--band " + std::to_string(o->band) + ": must be 0 (3 voxels) or at least one voxel (" +
                         std::to_string(o->voxel) + ")");

    std::vector<ShapeJob> all = gather(o->input);
    std::sort(all.begin(), all.end(), [](const ShapeJob& a, const ShapeJob& b) {
      return std::tie(a.category, a.shape, a.path) < std::tie(b.category, b.shape, b.path);
    });
    // Ids are checked over the whole input before sharding, so that every shard agrees on which file owns an id.
    std::map<std::pair<std::string, std::string>, std::string> owner;
    for (auto& j : all) {
      const std::string id = j.category + "/" + j.shape;
      std::string why = bad_id_part(j.category);
      const std::string own = "' cannot be a folder of its own in the output (";
      if (!why.empty())
        why = "category '" + j.category + own + why + ")";
      else if (!(why = bad_id_part(j.shape)).empty())
        why = "shape id '" + j.shape + own + why + ")";
      if (!why.empty()) {
        j.status = "failed";
        j.reason = j.path + ": " + why;
        continue;
      }
      const auto [it, fresh] = owner.emplace(std::make_pair(j.category, j.shape), j.path);
      if (!fresh) {
        j.status = "failed";
        j.reason = j.path + ": duplicate shape id '" + id + "', already taken by " + it->second;
      }
    }
    std::vector<ShapeJob> jobs;
    for (size_t i = 0; i < all.size(); ++i)
      if (static_cast<long>(i % static_cast<size_t>(shard_n)) == shard_i) jobs.push_back(all[i]);

    const auto t0 = std::chrono::steady_clock::now();
    ProgressBar bar("prep", static_cast<long>(jobs.size()));
    const int threads = o->jobs > 0 ? o->jobs : tbb::this_task_arena::max_concurrency();
    tbb::task_arena arena(std::max(1, threads));
    arena.execute([&] {
      tbb::parallel_for(size_t(0), jobs.size(), [&](size_t i) {
        ShapeJob& j = jobs[i];
        if (j.status == "failed") {
          bar.print_line(stderr, "sdfkit: error: " + j.reason);
          bar.tick();
          return;
        }
        PrepareSettings mine = s;
        const std::string key = j.category + "/" + j.shape;
        mine.samples.seed = Rng::derived(o->seed, std::stoull(fnv1a_hex(key), nullptr, 16)).next();
        const std::string dir = (fs::path(o->out) / j.category / j.shape).string();
        bool owned = false;  // this run holds the shape folder's lock
        try {
          // One writer per shape folder: a second `prep` into the same output (another shard scheme, a user
          // starting it twice) leaves a shape that is being prepared to its owner and reports it.
          const FolderLock lock(dir);
          if (!lock.locked())
            throw IoError(dir + ": another sdfkit prep is preparing this shape; run again when it has finished");
          owned = true;
          const PrepareStatus st = prepare_shape(j.path, dir, mine);
          if (o->views > 0) {
            // Views of the normalised input (colours kept), each NN.json written last: render what is missing.
            const fs::path vdir = fs::path(dir) / "views";
            bool complete = true;
            for (int k = 0; k < o->views && complete; ++k)
              complete = fs::is_regular_file(vdir / (view_name(k, o->views) + ".json"));
            if (!complete || o->overwrite || st.frame_changed) {
              const Normalization norm = normalization_from_json(read_json(ShapeFiles(dir).norm));
              // Colours from vertex colours, else the materials' textures (one sampler per shape: its cache of
              // decoded images lives as long as the shape) or diffuse colours.
              MeshReport textures;
              const Mesh coloured = to_y_up(read_mesh(j.path, &textures, image_texture_sampler()), mine.up);
              for (const std::string& t : textures.missing_textures)
                bar.print_line(stderr, "sdfkit: warning: " + j.path + ": texture " + t +
                                           " cannot be read; its part gets the material colour in the views");
              render_view_set(apply_normalization(coloured, norm), vdir.string(), view_settings,
                              mine.samples.seed);
            }
          }
          j.status = "ok";
          j.skipped = st.skipped;
          if (!o->quiet && !st.skipped) {
            char line[512];
            std::snprintf(line, sizeof line, "%s: %ld voxels, %.1f MB grid, %ld samples, gt %s, %.2f s", key.c_str(),
                          st.active_voxels, st.grid_bytes / 1e6,
                          st.samples.bin_counts[0] + st.samples.bin_counts[1] + st.samples.bin_counts[2] +
                              st.samples.bin_counts[3] + st.samples.uniform_count,
                          st.gt_source.c_str(), st.seconds);
            std::string text = line;
            if (st.sheet_faces > 0)
              text += ", " + std::to_string(st.sheet_faces) + " open sheet faces thickened";
            if (!st.redone.empty()) {
              text += " (prepared again: its norm.json had another";
              for (size_t k = 0; k < st.redone.size(); ++k) text += (k ? ", " : " ") + st.redone[k];
              text += ")";
            }
            bar.print_line(stdout, text);
          }
        } catch (const std::exception& e) {
          j.status = "failed";
          j.reason = e.what();
          bar.print_line(stderr, std::string("sdfkit: error: ") + e.what());
          // No half shape stays behind (a full disk, a crash of the mesher): what this run wrote for it goes.
          std::error_code ec;
          if (owned && !shape_is_complete(dir)) fs::remove_all(dir, ec);
        }
        bar.tick();
      }, tbb::simple_partitioner());
    });
    bar.finish();

    long ok = 0, skipped = 0, failed = 0;
    Json shapes = Json::array();
    for (const auto& j : jobs) {
      ok += j.status == "ok" && !j.skipped;
      skipped += j.skipped;
      failed += j.status == "failed";
      Json e = {{"category", j.category}, {"shape", j.shape}, {"source", j.path}, {"status", j.status}};
      if (!j.reason.empty()) e["reason"] = j.reason;
      shapes.push_back(e);
    }
    Json manifest = {{"tool", "sdfkit prep"},
                     {"version", SDFKIT_VERSION},
                     {"input", o->input},
                     {"shard", {shard_i, shard_n}},
                     {"settings",
                      {{"voxel_size", o->voxel},
                       {"band", o->band},
                       {"samples", o->samples},
                       {"sample_offset", s.samples.offset},
                       {"sample_bins", s.samples.edges},
                       {"uniform_share", o->uniform_share},
                       {"views", o->views},
                       {"gt", o->gt},
                       {"gt_iso", s.gt_iso},
                       {"sign", o->sign},
                       {"sheet", o->sheet},
                       {"seed", o->seed}}},
                     {"counts", {{"shapes", jobs.size()}, {"ok", ok + skipped}, {"failed", failed}}},
                     {"shapes", shapes}};
    const std::string name =
        shard_n == 1 ? "manifest.json" : "manifest." + std::to_string(shard_i) + "of" + std::to_string(shard_n) + ".json";
    write_json((fs::path(o->out) / name).string(), manifest);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("prep: %ld prepared, %ld already complete, %ld failed of %zu shapes in %.1f s -> %s\n", ok, skipped,
                failed, jobs.size(), secs, (fs::path(o->out) / name).string().c_str());
    if (failed == 0) return int(kOk);
    return jobs.size() == 1 ? int(kUserError) : int(kPartialFailure);
  };
}

SDFKIT_REGISTER_COMMAND("prep", "prepare a dataset: sparse SDF grid (.vdb), DISN samples (.npy), ground-truth mesh",
                        setup_prep);

}  // namespace
}  // namespace sdfkit::app
