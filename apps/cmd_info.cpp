// `sdfkit info MESH...`: what a mesh file holds and what validation found, as text or JSON.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "sdf/orientation.h"

#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_info(CLI::App& app) {
  struct Opts {
    std::vector<std::string> meshes;
    std::string up = "y";
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("meshes", o->meshes, "mesh files (.obj .ply .off .stl .gltf .glb)")->required();
  app.add_option("--up", o->up, "the files' up axis: y (sdfkit's, ShapeNet's), z or x; the box is given y-up")
      ->capture_default_str()
      ->check(CLI::IsMember({"y", "z", "x"}));
  app.add_flag("--json", o->json, "print a JSON array on stdout with one object per file");
  return [o] {
    int failed = 0;
    Json all = Json::array();
    for (const auto& path : o->meshes) {
      try {
        MeshReport r;
        const Mesh m = to_y_up(read_mesh(path, &r), parse_up_axis(o->up));
        // What prep's validation finds (sdf/prepare.h): is the surface closed and consistently oriented as
        // given, into how many parts it falls, and what orienting it changes.
        const bool closed_as_given = is_closed_oriented(m);
        OrientationReport orient;
        orient_consistently(m, &orient);
        Box3 box;
        for (Eigen::Index i = 0; i < m.V.rows(); ++i) box.extend(m.V.row(i).transpose());
        Json j = {{"file", path},
                  {"vertices", m.num_vertices()},
                  {"faces", m.num_faces()},
                  {"input_faces", r.input_faces},
                  {"degenerate_faces_removed", r.degenerate_faces},
                  {"duplicate_faces_removed", r.duplicate_faces},
                  {"unreferenced_vertices", r.unreferenced_vertices},
                  {"has_colors", m.has_colors()},
                  {"up", o->up},
                  {"validation",
                   {{"closed_and_oriented", closed_as_given},
                    {"closed_after_orienting", orient.closed},
                    {"components", orient.components},
                    {"closed_components", orient.closed_components},
                    {"inside_out_components", orient.inverted_components},
                    {"faces_to_flip", orient.flipped_faces},
                    {"degenerate_faces", r.degenerate_faces},
                    {"duplicate_faces", r.duplicate_faces}}},
                  {"bbox_min", {box.lo.x(), box.lo.y(), box.lo.z()}},
                  {"bbox_max", {box.hi.x(), box.hi.y(), box.hi.z()}}};
        if (o->json)
          all.push_back(j);
        else
          std::cout << path << ": " << m.num_vertices() << " vertices, " << m.num_faces() << " faces ("
                    << r.degenerate_faces << " degenerate and " << r.duplicate_faces
                    << " duplicate faces removed), bbox [" << box.lo.transpose() << "] - [" << box.hi.transpose()
                    << "]\n  validation: " << (closed_as_given ? "closed and consistently oriented"
                                                  : orient.closed ? "closed once " + std::to_string(orient.flipped_faces) +
                                                                        " faces are flipped"
                                                                  : std::string("open (boundary or non-manifold edges)"))
                    << "; " << orient.components << (orient.components == 1 ? " part" : " parts") << " ("
                    << orient.closed_components << " closed, " << orient.inverted_components << " inside out)\n";
      } catch (const Error& e) {
        ++failed;
        std::cerr << "sdfkit: error: " << e.what() << '\n';
        if (o->json) all.push_back({{"file", path}, {"error", e.what()}});
      }
    }
    if (o->json) std::cout << all.dump(2) << '\n';
    if (failed == 0) return int(kOk);
    return failed == static_cast<int>(o->meshes.size()) && o->meshes.size() == 1 ? int(kUserError)
                                                                                  : int(kPartialFailure);
  };
}

SDFKIT_REGISTER_COMMAND("info", "print what a mesh file holds and what validation finds", setup_info);

}  // namespace
}  // namespace sdfkit::app
