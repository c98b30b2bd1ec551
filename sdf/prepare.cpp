#include "sdf/prepare.h"

#include "core/error.h"
#include "core/json.h"
#include "sdf/mesh_queries.h"
#include "sdf/normalize.h"
#include "sdf/orientation.h"
#include "sdf/sheets.h"
#include "sdf/sparse_sdf_vdb.h"

#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace sdfkit {
namespace fs = std::filesystem;

namespace {

const char* gt_name(GtSource g) {
  switch (g) {
    case GtSource::kAuto: return "auto";
    case GtSource::kInput: return "input";
    case GtSource::kIsoSurface: return "iso";
  }
  return "auto";
}

/// Iso-surface of the grid at `iso` (OpenVDB's dual-contouring-free marching: volumeToMesh, no adaptivity),
/// quads split into triangles, oriented outward (positive volume).
Mesh iso_surface(const SparseSdf& sdf, double iso) {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*vdb_grid(sdf), points, tris, quads, iso, 0.0, /*relaxDisorientedTriangles=*/true);
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t i = 0; i < points.size(); ++i)
    m.V.row(static_cast<Eigen::Index>(i)) << points[i].x(), points[i].y(), points[i].z();
  m.F.resize(static_cast<Eigen::Index>(tris.size() + 2 * quads.size()), 3);
  Eigen::Index r = 0;
  for (const auto& t : tris) m.F.row(r++) << int32_t(t[0]), int32_t(t[1]), int32_t(t[2]);
  for (const auto& q : quads) {
    m.F.row(r++) << int32_t(q[0]), int32_t(q[1]), int32_t(q[2]);
    m.F.row(r++) << int32_t(q[0]), int32_t(q[2]), int32_t(q[3]);
  }
  double vol = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    vol += m.V.row(m.F(f, 0)).dot(m.V.row(m.F(f, 1)).cross(m.V.row(m.F(f, 2))));
  if (vol < 0) m.F.col(1).swap(m.F.col(2));
  return m;
}

}  // namespace

ShapeFiles::ShapeFiles(const std::string& shape_dir)
    : norm((fs::path(shape_dir) / "norm.json").string()),
      sdf((fs::path(shape_dir) / "sdf.vdb").string()),
      samples((fs::path(shape_dir) / "samples.npy").string()),
      gt((fs::path(shape_dir) / "gt.obj").string()),
      symmetries((fs::path(shape_dir) / "symmetries.json").string()) {}

bool shape_is_complete(const std::string& shape_dir) {
  const ShapeFiles files(shape_dir);
  return fs::is_regular_file(files.norm) && fs::is_regular_file(files.sdf) && fs::is_regular_file(files.samples) &&
         fs::is_regular_file(files.gt);
}

PreparedSource prepared_source(const std::string& shape_dir) {
  const std::string norm_path = ShapeFiles(shape_dir).norm;
  const Json j = read_json(norm_path);
  if (!j.is_object() || !j.contains("source") || !j["source"].is_string() || j["source"].get<std::string>().empty())
    throw IoError(norm_path + ": records no source mesh (\"source\")");
  PreparedSource src;
  src.path = j["source"].get<std::string>();
  if (j.contains("up")) {
    if (!j["up"].is_string()) throw IoError(norm_path + ": \"up\" is not a string");
    try {
      src.up = parse_up_axis(j["up"].get<std::string>());
    } catch (const InvalidInput& e) {
      throw IoError(norm_path + ": " + e.what());
    }
  }
  try {
    src.norm = normalization_from_json(j);
  } catch (const InvalidInput& e) {
    std::string m = e.what();
    if (m.rfind("norm.json: ", 0) == 0) m = m.substr(11);
    throw IoError(norm_path + ": " + m);
  }
  std::error_code ec;
  // A relative source was recorded from the folder prep ran in (e.g. a benchmark's root, "meshes/..."): found from
  // the current folder, else from the nearest folder above the shape that holds it.
  if (!fs::is_regular_file(src.path, ec) && fs::path(src.path).is_relative()) {
    for (fs::path up = fs::absolute(shape_dir, ec).lexically_normal(); !up.empty(); up = up.parent_path()) {
      const fs::path candidate = up / src.path;
      if (fs::is_regular_file(candidate, ec)) {
        src.path = candidate.string();
        break;
      }
      if (up == up.root_path()) break;
    }
  }
  if (!fs::is_regular_file(src.path, ec))
    throw IoError(src.path + ": the source mesh that " + norm_path + " records does not exist");
  return src;
}

Mesh read_prepared_source(const PreparedSource& src, const TextureSampler& textures) {
  return apply_normalization(to_y_up(read_mesh(src.path, nullptr, textures), src.up), src.norm);
}

Mesh read_prepared_source(const std::string& shape_dir, const TextureSampler& textures) {
  return read_prepared_source(prepared_source(shape_dir), textures);
}

std::vector<RotationSymmetry> prepared_shape_symmetries(const std::string& shape_dir, double tol,
                                                        const std::function<void()>& before_search) {
  require(std::isfinite(tol) && tol > 0, "symmetries: the tolerance must be positive and finite");
  const ShapeFiles files(shape_dir);
  std::error_code ec;
  const auto bytes = fs::file_size(files.gt, ec);
  if (ec) throw IoError(files.gt + ": cannot read (" + ec.message() + ")");
  const auto mtime = fs::last_write_time(files.gt, ec);
  if (ec) throw IoError(files.gt + ": cannot read (" + ec.message() + ")");
  const auto stamp = static_cast<int64_t>(mtime.time_since_epoch().count());
  char key[32];  // the shortest decimal that reads back as tol: "0.01"
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(key, sizeof key, "%.*g", digits, tol);
    if (std::strtod(key, nullptr) == tol) break;
  }
  // The turns a matching cache records, as vertical_symmetries reports them.
  const auto from_turns = [](const std::vector<int>& turns) {
    std::vector<RotationSymmetry> out;
    for (const int degrees : {90, 180, 270}) {
      RotationSymmetry r;
      r.degrees = degrees;
      r.R = vertical_turn(degrees);
      r.symmetric = std::find(turns.begin(), turns.end(), degrees) != turns.end();
      out.push_back(r);
    }
    return out;
  };
  Json cache = Json::object();
  try {
    if (fs::exists(files.symmetries, ec)) {
      const Json j = read_json(files.symmetries);
      if (j.is_object() && j.value("gt_bytes", Json()) == Json(static_cast<uint64_t>(bytes)) &&
          j.value("gt_mtime", Json()) == Json(stamp) && j.contains("turns") && j["turns"].is_object()) {
        cache = j;
        if (cache["turns"].contains(key)) return from_turns(cache["turns"][key].get<std::vector<int>>());
      }
    }
  } catch (const std::exception&) {  // an unreadable cache is rebuilt
    cache = Json::object();
  }
  if (before_search) before_search();
  const Mesh gt = read_mesh(files.gt);  // errors name the file
  std::vector<RotationSymmetry> found;
  try {
    found = vertical_symmetries(gt, tol);
  } catch (const InvalidInput& e) {
    throw IoError(files.gt + ": " + e.what());
  }
  std::vector<int> turns;
  for (const RotationSymmetry& r : found)
    if (r.symmetric) turns.push_back(r.degrees);
  if (!cache.contains("turns")) cache = Json{{"gt_bytes", static_cast<uint64_t>(bytes)}, {"gt_mtime", stamp},
                                             {"turns", Json::object()}};
  cache["turns"][key] = turns;
  try {
    write_json(files.symmetries, cache);
  } catch (const std::exception&) {  // a read-only dataset: found again next time
  }
  return found;
}

std::vector<std::string> prepared_differences(const std::string& shape_dir, const PrepareSettings& s) {
  Json j;
  try {
    j = read_json(ShapeFiles(shape_dir).norm);
  } catch (const std::exception&) {
    return {"norm.json"};
  }
  std::vector<std::string> keys;
  const auto at = [&j](const char* group, const char* key) -> const Json* {
    if (!j.is_object() || !j.contains(group) || !j[group].is_object() || !j[group].contains(key)) return nullptr;
    return &j[group][key];
  };
  const auto close = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}); };
  const auto number = [&](const char* group, const char* key, double want) {
    const Json* v = at(group, key);
    if (!v || !v->is_number() || !close(v->get<double>(), want)) keys.push_back(std::string(group) + "." + key);
  };
  const std::string up = j.is_object() && j.contains("up") && j["up"].is_string() ? j["up"].get<std::string>() : "y";
  if (up != up_axis_name(s.up)) keys.emplace_back("up");
  number("grid", "voxel_size", s.grid.voxel_size);
  number("grid", "band", s.grid.band > 0 ? s.grid.band : 3 * s.grid.voxel_size);
  {
    const Json* v = at("grid", "sign");
    const std::string got = v && v->is_string() ? v->get<std::string>() : "";
    bool ok = false;
    switch (s.grid.sign) {
      case SignMethod::kAuto:  // either resolution; an explicit pseudo-normal request falls back to winding numbers
      case SignMethod::kPseudoNormal: ok = got == "pseudo_normal" || got == "winding_number"; break;
      case SignMethod::kWindingNumber: ok = got == "winding_number"; break;
      case SignMethod::kNone: ok = got == "none"; break;
    }
    if (!ok) keys.emplace_back("grid.sign");
    const Json* sealed = at("grid", "sealed");  // absent before sealing existed: not sealed
    if ((sealed && sealed->is_boolean() && sealed->get<bool>()) != s.grid.seal) keys.emplace_back("grid.sealed");
  }
  {
    // A closed mesh has no single-sided sheet: the setting changes nothing, and norm.json files from before it
    // existed stay valid for them.
    const Json* closed = at("mesh", "closed");
    if (!(closed && closed->is_boolean() && closed->get<bool>())) number("grid", "sheet", s.sheet_voxels);
  }
  number("samples", "count", static_cast<double>(s.samples.count));
  number("samples", "offset", s.samples.offset);
  {
    const Json* v = at("samples", "edges");
    bool ok = v && v->is_array() && v->size() == s.samples.edges.size();
    for (size_t i = 0; ok && i < s.samples.edges.size(); ++i)
      ok = (*v)[i].is_number() && close((*v)[i].get<double>(), s.samples.edges[i]);
    if (!ok) keys.emplace_back("samples.edges");
  }
  number("samples", "uniform",
         static_cast<double>(std::lround(static_cast<double>(s.samples.count) * s.samples.uniform_share)));
  {
    const Json* v = at("samples", "seed");
    if (!v || !v->is_number_unsigned() || v->get<uint64_t>() != s.samples.seed) keys.emplace_back("samples.seed");
  }
  {
    const Json* v = at("gt", "setting");
    if (!v || !v->is_string() || v->get<std::string>() != gt_name(s.gt)) keys.emplace_back("gt.setting");
    const Json* source = at("gt", "source");
    if (source && source->is_string() && source->get<std::string>() == "iso") number("gt", "iso", s.gt_iso);
  }
  return keys;
}

namespace {
/// The status a shape starts with: skipped when it is complete with `settings` (and not overwritten), else the
/// settings its complete files were made with otherwise (none for a new or overwritten shape).
PrepareStatus initial_status(const std::string& shape_dir, const PrepareSettings& settings) {
  PrepareStatus st;
  st.shape_dir = shape_dir;
  if (!settings.overwrite && shape_is_complete(shape_dir)) {
    st.redone = prepared_differences(shape_dir, settings);
    st.skipped = st.redone.empty();
    st.frame_changed = std::find(st.redone.begin(), st.redone.end(), "up") != st.redone.end();
  }
  return st;
}

/// Prepares the shape whose status initial_status gave (not skipped).
PrepareStatus prepare_impl(const Mesh& input, const std::string& source, const std::string& hash,
                           const MeshReport* read_report, PrepareStatus st, const PrepareSettings& settings,
                           const ProgressFn& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string shape_dir = st.shape_dir;
  const ShapeFiles files(shape_dir);
  auto report = [&](double f) {
    if (progress && !progress(f)) throw Error(source + ": cancelled");
  };
  auto clock = std::chrono::steady_clock::now();
  auto lap = [&clock](double& out) {
    const auto now = std::chrono::steady_clock::now();
    out += std::chrono::duration<double>(now - clock).count();
    clock = now;
  };
  const Mesh mesh = validate_mesh(input, source, &st.mesh);
  if (read_report) st.mesh = *read_report;  // the reader already cleaned: keep its counts
  const Normalization norm = unit_sphere_normalization(mesh);
  OrientationReport orep;
  const Mesh object = orient_consistently(apply_normalization(mesh, norm), &orep);
  st.flipped_faces = orep.flipped_faces;
  st.closed_input = orep.closed && orep.components == 1;
  lap(st.seconds_mesh);
  report(0.1);

  // One sign method for the grid and the samples (pseudo-normals for closed one-part meshes, else winding).
  // The query structures (BVH, pseudo-normals or winding numbers) are built once for the grid and the samples.
  // Open single-sided sheets, and whatever inside is thinner than a voxel next to a face of a part with a rim, get a
  // thickness for everything made from the SDF (grid, samples, iso-surface gt): probed one voxel off each face.
  const double h = settings.grid.voxel_size;
  SheetReport sheets;
  const Mesh solid = settings.sheet_voxels > 0
                         ? thicken_open_sheets(object, settings.sheet_voxels * h, h, &sheets,
                                               settings.grid.winding_beta)
                         : object;
  st.sheet_faces = sheets.sheet_faces;
  const MeshQueries queries(solid, settings.grid.sign, h, settings.grid.winding_beta);
  const SignMethod sign = queries.sign();
  st.sign = sign;
  const SparseSdf sdf = SparseSdf::from_mesh(queries, settings.grid, &st.grid,
                                             [&](double f) { return !progress || progress(0.1 + 0.6 * f); });
  st.active_voxels = sdf.active_voxel_count();
  st.grid_bytes = sdf.memory_bytes();
  lap(st.seconds_mesh);  // sign-method choice counted with the mesh work; the grid's own stages are in st.grid
  st.seconds_mesh -= st.grid.seconds_setup + st.grid.seconds_topology + st.grid.seconds_exact + st.grid.seconds_sign;
  report(0.7);
  const MatrixXfR samples = disn_samples(queries, sdf, settings.samples, &st.samples);
  lap(st.seconds_samples);
  report(0.85);
  const bool use_input = settings.gt == GtSource::kInput || (settings.gt == GtSource::kAuto && st.closed_input);
  st.gt_source = use_input ? "input" : "iso";
  Mesh gt = use_input ? object : iso_surface(sdf, settings.gt_iso);
  gt.colors.resize(0, 3);
  if (gt.F.rows() == 0) throw InvalidInput(source + ": the iso-surface of the SDF is empty (no inside anywhere)");
  lap(st.seconds_gt);
  report(0.95);

  // A previous, possibly different, result must not look complete while the new files are written.
  std::error_code ec;
  fs::remove(files.norm, ec);
  fs::create_directories(shape_dir);
  sdf.write(files.sdf);
  write_npy(files.samples, samples);
  write_mesh(files.gt, gt);
  Json j = normalization_to_json(norm);
  j["source"] = source;
  j["up"] = up_axis_name(settings.up);  // the source file's up axis, turned to +y before normalising
  if (!hash.empty()) j["source_hash"] = hash;
  j["frame"] = "object = (source - norm[0:3]) / norm[3]";
  j["mesh"] = {{"vertices", mesh.num_vertices()},
               {"faces", mesh.num_faces()},
               {"input_faces", st.mesh.input_faces},
               {"degenerate_faces_removed", st.mesh.degenerate_faces},
               {"duplicate_faces_removed", st.mesh.duplicate_faces},
               {"flipped_faces", orep.flipped_faces},
               {"parts", orep.components},
               {"closed_parts", orep.closed_components},
               {"closed", orep.closed}};
  j["grid"] = {{"voxel_size", sdf.voxel_size()},
               {"background", sdf.background()},
               {"active_voxels", st.active_voxels},
               {"band", settings.grid.band > 0 ? settings.grid.band : 3 * settings.grid.voxel_size},
               {"sign", sign_method_name(sign)},
               {"sealed", settings.grid.seal},
               {"sheet", settings.sheet_voxels},
               {"sheet_faces", st.sheet_faces}};
  j["samples"] = {{"count", samples.rows()},
                  {"offset", settings.samples.offset},
                  {"edges", settings.samples.edges},
                  {"bin_counts", st.samples.bin_counts},
                  {"bin_quota", st.samples.bin_quota},
                  {"uniform", st.samples.uniform_count},
                  {"redistributed", st.samples.redistributed},
                  {"seed", settings.samples.seed}};
  j["gt"] = {{"source", st.gt_source}, {"iso", use_input ? 0.0 : settings.gt_iso}, {"setting", gt_name(settings.gt)}};
  write_json(files.norm, j);
  lap(st.seconds_files);
  report(1.0);
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}
}  // namespace

PrepareStatus prepare_shape(const std::string& mesh_path, const std::string& shape_dir,
                            const PrepareSettings& settings, const ProgressFn& progress) {
  PrepareStatus st = initial_status(shape_dir, settings);
  if (st.skipped) return st;  // before reading the mesh
  MeshReport report;
  const Mesh mesh = to_y_up(read_mesh(mesh_path, &report), settings.up);
  return prepare_impl(mesh, mesh_path, fnv1a_hex(read_file(mesh_path)), &report, std::move(st), settings, progress);
}

PrepareStatus prepare_mesh(const Mesh& input, const std::string& source, const std::string& shape_dir,
                           const PrepareSettings& settings, const ProgressFn& progress) {
  PrepareStatus st = initial_status(shape_dir, settings);
  if (st.skipped) return st;
  return prepare_impl(input, source, "", nullptr, std::move(st), settings, progress);
}

}  // namespace sdfkit
