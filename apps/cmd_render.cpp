// `sdfkit render MESH -o DIR`: a DISN-like view set of one mesh (NN.png + NN.json, optional depth/normal maps
// and occlusion masks), the same files `sdfkit prep` writes into <shape>/views/.
#include "apps/command.h"
#include "camera/texture.h"
#include "camera/views.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "sdf/normalize.h"

#include <chrono>
#include <iostream>

namespace sdfkit::app {
namespace {

std::function<int()> setup_render(CLI::App& app) {
  struct Opts {
    std::string mesh, out, mesh_out;
    ViewSetSettings views;
    uint64_t seed = 0;
    bool no_normalize = false;
    std::string occlude = "none", up = "y";
    std::vector<double> elevation, distance, azimuth;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  app.add_option("mesh", o->mesh, "mesh file (.obj .ply .off .stl .gltf .glb)")->required();
  app.add_option("--up", o->up, "the mesh's up axis: y (ShapeNet's, sdfkit's), z (Blender's, most CAD tools') or x")
      ->capture_default_str()
      ->check(CLI::IsMember({"y", "z", "x"}));
  app.add_option("-o,--out", o->out, "output folder: NN.png (RGBA), NN.json (camera), norm.json")->required();
  app.add_option("--views", o->views.views, "number of views")->check(in_range(1, 10000))->capture_default_str();
  app.add_option("--size", o->views.size, "image side in pixels (intrinsics: DISN's f = 35/32 * size, c = size/2)")
      ->check(in_range(8, 8192))
      ->capture_default_str();
  app.add_option("--seed", o->seed, "seed of the random views (same seed -> byte-identical files)")
      ->capture_default_str();
  app.add_option("--azimuth", o->azimuth, "MIN MAX azimuth range in degrees (default 0 360)")->expected(2);
  app.add_option("--elevation", o->elevation, "MIN MAX elevation range in degrees (default 25 30, as DISN's renders)")
      ->expected(2);
  app.add_option("--distance", o->distance,
                 "MIN MAX camera distance in object-frame (unit sphere) units (default 2.45 3.0: the unit sphere "
                 "always fits in the image)")
      ->expected(2);
  app.add_flag("--depth", o->views.render.depth, "also write NN_depth.exr (z_cam, float, 0 = background)");
  app.add_flag("--normals", o->views.render.normals,
               "also write NN_normal.exr (camera-frame normals: x right, y down, z forward; 0 = background)");
  app.add_flag("--albedo", o->views.render.albedo, "also write NN_albedo.png (unlit colour, RGB 8-bit)");
  app.add_option("--occlude", o->occlude,
                 "remove the left/right half of the object, or random rectangles (rect), from NN.png and write "
                 "NN_mask.png (white = removed)")
      ->check(CLI::IsMember({"none", "left", "right", "rect"}))
      ->capture_default_str();
  app.add_option("--rects", o->views.occlusion.rectangles, "number of rectangles for --occlude rect")
      ->check(in_range(1, 100))
      ->capture_default_str();
  app.add_option("--supersampling", o->views.render.supersampling,
                 "s: s x s samples per pixel for anti-aliased silhouettes")
      ->check(in_range(1, 8))
      ->capture_default_str();
  app.add_flag("--no-normalize", o->no_normalize,
               "render the mesh as it is; by default it is first mapped to the unit sphere (centre = area-weighted "
               "centroid, farthest vertex at radius 1) and the mapping is saved as norm.json");
  app.add_option("--mesh-out", o->mesh_out,
                 "also write the mesh as rendered, in the views' object frame (.obj .ply .off .stl .glb; OBJ, PLY and GLB keep "
                 "its colours, textures sampled at the vertices): the ground truth "
                 "that `refine` results and `eval` compare against");
  app.add_flag("--json", o->json, "print a JSON summary on stdout");
  return [o] {
    ViewSetSettings st = o->views;
    if (o->azimuth.size() == 2) st.azimuth_min = o->azimuth[0], st.azimuth_max = o->azimuth[1];
    if (o->elevation.size() == 2) st.elevation_min = o->elevation[0], st.elevation_max = o->elevation[1];
    if (o->distance.size() == 2) st.distance_min = o->distance[0], st.distance_max = o->distance[1];
    st.occlusion.mode = parse_occlusion_mode(o->occlude);
    validate_view_set_settings(st);
    if (!o->mesh_out.empty()) {
      if (!is_mesh_out_path(o->mesh_out))
        throw InvalidInput("--mesh-out " + o->mesh_out + ": give a mesh path ending in .obj, .ply, .off, .stl or .glb");
    }

    const auto t0 = std::chrono::steady_clock::now();
    MeshReport report;
    Mesh mesh = to_y_up(read_mesh(o->mesh, &report, image_texture_sampler()), parse_up_axis(o->up));
    for (const std::string& t : report.missing_textures)
      std::cerr << "sdfkit: warning: " << o->mesh << ": texture " << t << " cannot be read; its part gets the material colour\n";
    Json summary = {{"mesh", o->mesh}, {"up", o->up}, {"out", o->out}, {"views", st.views}, {"faces", mesh.num_faces()},
                    {"seed", o->seed}, {"normalized", !o->no_normalize}};
    if (!o->no_normalize) {
      const Normalization norm = unit_sphere_normalization(mesh);
      mesh = apply_normalization(mesh, norm);
      Json nj = normalization_to_json(norm);
      nj["source"] = o->mesh;
      write_json(o->out + "/norm.json", nj);
      summary["norm"] = nj["norm"];
    }
    const auto cams = render_view_set(mesh, o->out, st, o->seed);
    if (!o->mesh_out.empty()) {
      write_mesh(o->mesh_out, mesh);
      summary["mesh_out"] = o->mesh_out;
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    summary["seconds"] = secs;
    if (o->json)
      std::cout << summary.dump(2) << '\n';
    else
      std::cout << "rendered " << cams.size() << " views of " << o->mesh << " (" << mesh.num_faces() << " faces) to "
                << o->out << " in " << secs << " s\n";
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("render", "render a seeded DISN-like view set of a mesh (PNG + camera JSON per view)",
                        setup_render);

}  // namespace
}  // namespace sdfkit::app
