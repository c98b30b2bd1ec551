// `sdfkit info MESH...`: what a mesh file holds and what validation found, as text or JSON.
#include "apps/command.h"
#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"

#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_info(CLI::App& app) {
  struct Opts {
    std::vector<std::string> meshes;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("meshes", o->meshes, "mesh files (.obj .ply .off .stl)")->required();
  app.add_flag("--json", o->json, "print one JSON object per file");
  return [o] {
    int failed = 0;
    Json all = Json::array();
    for (const auto& path : o->meshes) {
      try {
        MeshReport r;
        const Mesh m = read_mesh(path, &r);
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
                  {"bbox_min", {box.lo.x(), box.lo.y(), box.lo.z()}},
                  {"bbox_max", {box.hi.x(), box.hi.y(), box.hi.z()}}};
        if (o->json)
          all.push_back(j);
        else
          std::cout << path << ": " << m.num_vertices() << " vertices, " << m.num_faces() << " faces ("
                    << r.degenerate_faces << " degenerate and " << r.duplicate_faces
                    << " duplicate faces removed), bbox [" << box.lo.transpose() << "] - [" << box.hi.transpose()
                    << "]\n";
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
