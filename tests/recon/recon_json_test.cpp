#include "recon/recon_json.h"

#include "camera/camera.h"
#include "core/json.h"
#include "core/primitives.h"
#include "train/dataset.h"

#include <doctest/doctest.h>

#include <string>

using namespace sdfkit;

namespace {

/// A result as Reconstructor::run returns it for a 400 x 300 image: estimated camera, one refinement round.
ReconResult made_result() {
  ReconResult r;
  r.mesh = make_box(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5));
  r.framing.mask_source = "plain-background";
  r.framing.x0 = 50;
  r.framing.y0 = 20;
  r.framing.side = 274;
  r.framing.reframed = true;
  r.framing.object_box = {80, 60, 200, 180};
  r.framing.extent = 0.73;
  r.framing.warnings = {"the object touches the image border"};
  r.initial_camera = look_at(30, 20, 2.5, kNetImageSize, kNetImageSize);
  r.camera = look_at(40, 22, 2.4, kNetImageSize, kNetImageSize);
  r.input_camera = camera_in_input(r.camera, r.framing, 400, 300);
  r.camera_estimated = true;
  r.pose_mirror_tta = true;
  r.photo_pose = true;
  r.photo_model = true;
  r.framing_fits = 1;
  r.flip_turn_deg = 180;
  CameraRefineResult round;
  round.iou_before = 0.5;
  round.iou_after = 0.75;
  round.rotation_deg = Vec3(1, 2, 3);
  round.distance_ratio = 0.96;
  round.sweep_azimuth_deg = 10;
  round.evaluations = 13;
  round.seconds = 1.5;
  r.refinements = {round};
  r.evaluations = 12345;
  r.components_removed = 2;
  r.timings.field = 0.25;
  r.timings.total = 1.75;
  return r;
}

void check_same_camera(const Camera& a, const Camera& b) {
  CHECK(a.width == b.width);
  CHECK(a.height == b.height);
  CHECK((a.K - b.K).cwiseAbs().maxCoeff() < 1e-12);
  CHECK((a.R - b.R).cwiseAbs().maxCoeff() < 1e-12);
  CHECK((a.t - b.t).cwiseAbs().maxCoeff() < 1e-12);
}

}  // namespace

TEST_CASE("recon_result_json: every key of the recon record, cameras that read back with camera_from_json") {
  ReconResult r = made_result();
  r.threshold = 0.4;  // a binary model's
  r.mirror_tta = true;
  r.pose_zoom_tta = {0.9, 1.1};
  ReconSettings s;
  s.resolution = 65;
  const Json j = recon_result_json(r, s, {"in.png", "out/in.obj", "out/in.preview.png", "out/in.mask.png", {}}, 400, 300);
  for (const char* key : {"input", "mesh", "preview", "mask", "framing", "warnings", "camera", "network_camera",
                          "camera_source", "flip_turn_deg", "pose_tta", "pose_zoom_tta", "pose_model", "sdf_model", "camera_refinement",
                          "evaluations",
                          "vertices", "faces", "components_removed", "resolution", "extraction", "threshold",
                          "mirror_tta", "seconds"})
    CHECK_MESSAGE(j.contains(key), key);
  CHECK(j.size() == 24);
  CHECK(j["threshold"] == 0.4);
  CHECK(j["mirror_tta"] == true);
  CHECK(j["input"] == "in.png");
  CHECK(j["mesh"] == "out/in.obj");
  CHECK(j["preview"] == "out/in.preview.png");
  CHECK(j["mask"] == "out/in.mask.png");
  CHECK(j["framing"]["mask_source"] == "plain-background");
  CHECK(j["framing"]["reframed"] == true);
  CHECK(j["framing"]["crop"] == Json({{"x", 50.0}, {"y", 20.0}, {"side", 274.0}}));
  CHECK(j["framing"]["object_box"] == Json({80, 60, 200, 180}));
  CHECK(j["framing"]["extent"] == 0.73);
  CHECK(j["framing"]["image_size"] == Json({400, 300}));
  CHECK(j["warnings"] == Json({"the object touches the image border"}));
  CHECK(j["camera_source"] == "estimated");
  CHECK(j["flip_turn_deg"] == 180.0);
  CHECK(j["pose_tta"] == "mirror");
  CHECK(j["pose_zoom_tta"] == Json({0.9, 1.1}));
  CHECK(j["pose_model"] == "photo");
  CHECK(j["sdf_model"] == "photo");
  CHECK(j["framing"]["fit_rounds"] == 1);
  CHECK(j["evaluations"] == 12345);
  CHECK(j["vertices"] == r.mesh.num_vertices());
  CHECK(j["faces"] == r.mesh.num_faces());
  CHECK(j["components_removed"] == 2);
  CHECK(j["resolution"] == 65);
  CHECK(j["extraction"] == "adaptive");
  CHECK(j["seconds"]["field"] == 0.25);
  CHECK(j["seconds"]["total"] == 1.75);
  CHECK(j["seconds"].size() == 9);

  check_same_camera(camera_from_json(j["camera"]), r.input_camera);
  check_same_camera(camera_from_json(j["network_camera"]), r.camera);
  const Json& refinement = j["camera_refinement"];
  check_same_camera(camera_from_json(refinement["initial_camera"]),
                    camera_in_input(r.initial_camera, r.framing, 400, 300));
  CHECK(camera_from_json(refinement["initial_camera"]).width == 400);
  REQUIRE(refinement["rounds"].size() == 1);
  const Json& round = refinement["rounds"][0];
  CHECK(round["iou_before"] == 0.5);
  CHECK(round["iou_after"] == 0.75);
  CHECK(round["rotation_deg"] == Json({1.0, 2.0, 3.0}));
  CHECK(round["distance_ratio"] == 0.96);
  CHECK(round["sweep_azimuth_deg"] == 10.0);
  CHECK(round["evaluations"] == 13);
  CHECK(round["seconds"] == 1.5);
}

TEST_CASE("recon_result_json: a given camera, no refinement, no preview and the dense extraction leave keys out") {
  ReconResult r = made_result();
  r.camera_estimated = false;
  r.refinements.clear();
  ReconSettings s;
  s.preview = false;
  r.dense = true;  // the result says which extraction ran
  r.threshold = 0;  // an SDF model: no occupancy threshold
  const Json j = recon_result_json(r, s, {"in.png", "in.obj", "unused.preview.png", "unused.mask.png", {}}, 400, 300);
  CHECK(j["camera_source"] == "given");
  CHECK(j["extraction"] == "dense");
  CHECK(j["mirror_tta"] == false);
  for (const char* key : {"preview", "mask", "flip_turn_deg", "pose_tta", "pose_zoom_tta", "pose_model",
                          "camera_refinement", "threshold"})
    CHECK_MESSAGE(!j.contains(key), key);
  CHECK(j["sdf_model"] == "photo");
  CHECK(j.size() == 16);
}
