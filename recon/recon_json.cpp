#include "recon/recon_json.h"

#include "core/error.h"
#include "core/json.h"

namespace sdfkit {

Json segmenter_scan_json(const SegmenterScan& scan) {
  if (scan.candidates == 0) return nullptr;
  return {{"candidates", scan.candidates}, {"chosen", scan.chosen}, {"agreement", scan.agreement}};
}

Json recon_result_json(const ReconResult& r, const ReconSettings& settings, const ReconOutputPaths& paths,
                       int image_width, int image_height) {
  Json j = {{"input", paths.input}};
  j["mesh"] = paths.mesh;
  if (settings.preview) {
    j["preview"] = paths.preview;
    j["mask"] = paths.mask;
  }
  const FramedInput& fr = r.framing;
  j["framing"] = {{"mask_source", fr.mask_source},
                  {"reframed", fr.reframed},
                  {"fit_rounds", r.framing_fits},
                  {"segmenter_zooms", fr.segmenter_zooms},
                  {"segmenter_scan", segmenter_scan_json(fr.segmenter_scan)},
                  {"crop", {{"x", fr.x0}, {"y", fr.y0}, {"side", fr.side}}},
                  {"object_box", {fr.object_box.x, fr.object_box.y, fr.object_box.w, fr.object_box.h}},
                  {"extent", fr.extent},
                  {"image_size", {image_width, image_height}}};
  j["warnings"] = fr.warnings;
  j["camera"] = camera_to_json(r.input_camera);
  j["network_camera"] = camera_to_json(r.camera);
  j["camera_source"] = r.camera_estimated ? "estimated" : "given";
  if (r.camera_estimated) {
    j["flip_turn_deg"] = r.flip_turn_deg;
    j["pose_tta"] = r.pose_mirror_tta ? "mirror" : "none";
    j["pose_zoom_tta"] = r.pose_zoom_tta;
    j["pose_model"] = r.photo_pose ? "photo" : "main";
  }
  j["sdf_model"] = r.photo_model ? "photo" : "main";
  if (!r.refinements.empty()) {
    Json rounds = Json::array();
    for (const CameraRefineResult& rr : r.refinements)
      rounds.push_back({{"iou_before", rr.iou_before},
                        {"iou_after", rr.iou_after},
                        {"rotation_deg", {rr.rotation_deg.x(), rr.rotation_deg.y(), rr.rotation_deg.z()}},
                        {"distance_ratio", rr.distance_ratio},
                        {"sweep_azimuth_deg", rr.sweep_azimuth_deg},
                        {"evaluations", rr.evaluations},
                        {"seconds", rr.seconds}});
    j["camera_refinement"] = {
        {"initial_camera", camera_to_json(camera_in_input(r.initial_camera, fr, image_width, image_height))},
        {"rounds", rounds}};
  }
  if (!r.view_cameras.empty()) {
    require(paths.views.size() == r.view_cameras.size(), "recon_result_json: one image name per view");
    Json views = Json::array();
    for (size_t i = 0; i < r.view_cameras.size(); ++i) {
      Json v = {{"input", paths.views[i]},
                {"camera", camera_to_json(r.view_input_cameras[i])},
                {"network_camera", camera_to_json(r.view_cameras[i])},
                {"camera_source", r.view_estimated[i] ? "estimated" : "given"}};
      if (r.view_estimated[i]) v["pose_model"] = r.view_photo_pose[i] ? "photo" : "main";
      v["sdf_model"] = r.view_photo_model[i] ? "photo" : "main";
      views.push_back(std::move(v));
    }
    j["views"] = views;
  }
  j["evaluations"] = r.evaluations;
  j["vertices"] = r.mesh.num_vertices();
  j["faces"] = r.mesh.num_faces();
  j["components_removed"] = r.components_removed;
  j["resolution"] = settings.resolution;
  j["extraction"] = r.dense ? "dense" : "adaptive";
  if (r.threshold > 0) j["threshold"] = r.threshold;
  j["mirror_tta"] = r.mirror_tta;
  const ReconTimings& t = r.timings;
  j["seconds"] = {{"prepare", t.prepare}, {"pose", t.pose},       {"encode", t.encode},
                  {"field", t.field},     {"extract", t.extract}, {"cleanup", t.cleanup},
                  {"refine", t.refine},   {"preview", t.preview}, {"total", t.total}};
  return j;
}

}  // namespace sdfkit
