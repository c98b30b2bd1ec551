// CLI-level tests of `sdfkit recon` with the shipped models and examples (data/models, data/examples).
#include "camera/camera.h"
#include "camera/image.h"
#include "cli_run.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "metrics/protocols.h"
#include "sdf/orientation.h"
#include "train/sdf_train.h"

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <utility>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

const std::string kSource = SDFKIT_SOURCE_DIR;

using Run = test::CliRun;

Run run(const std::string& args) { return test::run_sdfkit(args); }

double iou_of(const std::string& pred, const std::string& gt) {
  ProtocolSettings ps;
  ps.with_emd = false;
  return evaluate(read_mesh(pred), read_mesh(gt), ps).get("iou").value_or(0.0) / 100.0;
}

bool have_models() {
  return fs::exists(kSource + "/data/models/sdf.ckpt") && fs::exists(kSource + "/data/models/pose.ckpt");
}

}  // namespace

// Issue 8: recon of a shipped example reaches IoU > 0.5 against its GT with the shipped models (a check of the
// model, not only of the code path). Measured with the shipped models (data/models/sdf.md, pose.md) on car_0021, a
// test-split shape, at 65^3: 0.874 with the true camera, 0.875 with the estimated one. Both cameras are asserted
// above 0.5.
TEST_CASE("recon of a shipped example with the shipped models: IoU > 0.5 with the true camera, closed mesh") {
  REQUIRE_MESSAGE(have_models(), "the shipped models data/models/sdf.ckpt and pose.ckpt are missing");
  const fs::path dir = test::scratch_dir("recon_cli") / "example";
  fs::remove_all(dir);
  const std::string img = kSource + "/data/examples/car_0021.png";
  const std::string gt = kSource + "/data/examples/gt/car_0021.ply";
  const std::string est = (dir / "est.obj").string(), cam = (dir / "cam.obj").string();
  Run r = run("recon " + img + " -o " + est + " --res 65 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(fs::exists((dir / "est.preview.png").string()));
  const Json j = Json::parse(r.out);
  CHECK(j["camera_source"] == "estimated");
  CHECK(j["pose_model"] == "main");  // a render framed like the training renders: not reframed, the main pose model
  CHECK(j["sdf_model"] == "main");   // and the main SDF model
  CHECK_FALSE(j["framing"]["reframed"].get<bool>());
  CHECK(j["evaluations"].get<long>() > 0);
  CHECK(j["seconds"]["total"].get<double>() > 0);
  // The pose model's flip check: off, no turn; on, the estimate is the 6D head's camera turned by the reported
  // angle about the vertical axis.
  const Run off = run("recon " + img + " -o " + (dir / "est_off.obj").string() + " --res 65 --json --flip-check 0");
  REQUIRE_MESSAGE(off.code == 0, off.err);
  const Json j_off = Json::parse(off.out);
  CHECK(j_off["flip_turn_deg"].get<double>() == 0.0);
  const Camera turned = turn_about_vertical(camera_from_json(j_off["camera"]), j["flip_turn_deg"].get<double>());
  CHECK((turned.R - camera_from_json(j["camera"]).R).norm() < 1e-6);
  CHECK((turned.t - camera_from_json(j["camera"]).t).norm() < 1e-6);
  r = run("recon " + img + " -o " + cam + " --res 65 --cam " + kSource + "/data/examples/car_0021.json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Mesh m = read_mesh(est);
  CHECK(is_closed_oriented(m));
  const double iou_est = iou_of(est, gt), iou_cam = iou_of(cam, gt);
  MESSAGE("IoU estimated camera " << iou_est << ", true camera " << iou_cam);
  CHECK(iou_cam > 0.5);
  // "At least as good", up to 0.02 of IoU: the two runs differ only by the camera.
  CHECK(iou_cam >= iou_est - 0.02);
  CHECK(iou_est > 0.5);  // issue 8's goal
}

TEST_CASE("recon --missing and --occlude: no missing pixel changes nothing, missing ones change the mesh") {
  REQUIRE_MESSAGE(have_models(), "the shipped models data/models/sdf.ckpt and pose.ckpt are missing");
  const fs::path dir = test::scratch_dir("recon_cli") / "missing";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string img = kSource + "/data/examples/car_0021.png";
  const std::string cam = " --cam " + kSource + "/data/examples/car_0021.json --res 33 --no-preview";
  const std::string none_mask = (dir / "none.png").string(), left_mask = (dir / "left.png").string();
  Image m(137, 137, 1, 0.f);
  write_image(none_mask, m);
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 68; ++x) m.at(x, y) = 1.f;
  write_image(left_mask, m);
  const std::string plain = (dir / "plain.obj").string(), none = (dir / "none.obj").string();
  const std::string left = (dir / "left.obj").string(), occluded = (dir / "occluded.obj").string();
  for (const auto& [out, extra] : std::vector<std::pair<std::string, std::string>>{
           {plain, ""}, {none, " --missing " + none_mask}, {left, " --missing " + left_mask},
           {occluded, " --occlude left"}}) {
    const Run r = run("recon " + img + " -o " + out + cam + extra);
    REQUIRE_MESSAGE(r.code == 0, r.err);
  }
  // An all-zero mask leaves the network input as it was: the same mesh, byte for byte.
  CHECK(read_file(none) == read_file(plain));
  CHECK(read_file(left) != read_file(plain));
  CHECK(read_file(occluded) != read_file(plain));
  // Refusals: both flags, a mask of another size, --occlude on an image without alpha.
  Run r = run("recon " + img + " -o " + (dir / "x.obj").string() + cam + " --missing " + left_mask + " --occlude half");
  CHECK(r.code == 1);
  CHECK(r.err.find("not both") != std::string::npos);
  Image small(40, 30, 1, 0.f);
  write_image((dir / "small.png").string(), small);
  r = run("recon " + img + " -o " + (dir / "x.obj").string() + cam + " --missing " + (dir / "small.png").string());
  CHECK(r.code == 1);
  CHECK(r.err.find("missing-data mask is 40 x 30") != std::string::npos);
  Image rgb(137, 137, 3, 1.f);
  for (int y = 40; y < 90; ++y)
    for (int x = 40; x < 100; ++x) rgb.at(x, y, 0) = 0.2f;
  write_image((dir / "rgb.png").string(), rgb);
  r = run("recon " + (dir / "rgb.png").string() + " -o " + (dir / "x.obj").string() + cam + " --occlude half");
  CHECK(r.code == 1);
  CHECK(r.err.find("alpha channel") != std::string::npos);
}

TEST_CASE("recon refuses corrupt, empty and background-only images with one clear line and exit 1") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string png = read_file(kSource + "/data/examples/chair_0004.png");
  write_text_atomic((dir / "corrupt.png").string(), png.substr(0, png.size() / 2));
  write_text_atomic((dir / "empty.png").string(), "");
  write_image((dir / "background.png").string(), Image(137, 137, 4, 0.f));  // fully transparent
  for (const char* name : {"corrupt.png", "empty.png", "background.png"}) {
    CAPTURE(name);
    const Run r = run("recon " + (dir / name).string() + " -o " + (dir / "out.obj").string() + " --res 33 --cam " +
                      kSource + "/data/examples/chair_0004.json");
    CHECK(r.code == 1);
    CHECK(r.err.find(name) != std::string::npos);
    // Exactly one error line from sdfkit (libpng itself may print its own "libpng error:" line first).
    size_t lines = 0;
    for (size_t at = r.err.find("sdfkit: error:"); at != std::string::npos; at = r.err.find("sdfkit: error:", at + 1))
      ++lines;
    CHECK(lines == 1);
    const size_t start = r.err.find("sdfkit: error:");
    CHECK(r.err.find('\n', start) == r.err.size() - 1);
    CHECK(!fs::exists(dir / "out.obj"));
  }
  // In a batch, the bad image does not stop the good one: exit 2, the good mesh is written.
  fs::copy_file(kSource + "/data/examples/chair_0004.png", dir / "good.png");
  fs::copy_file(kSource + "/data/examples/chair_0004.json", dir / "good.json");
  fs::remove(dir / "corrupt.png");
  fs::remove(dir / "empty.png");
  const Run r = run("recon " + dir.string() + " -o " + (dir / "out").string() + " --res 33 --cam sidecar --no-preview");
  CHECK(r.code == 2);
  CHECK(fs::exists(dir / "out" / "good.obj"));
  CHECK(!fs::exists(dir / "out" / "background.obj"));
}

// Issue 7: test-time camera refinement (recon --refine-camera). A small sweep keeps the case fast; the JSON reports
// the initial camera and the silhouette IoU before/after; the mesh is closed (determinism: tests/recon).
TEST_CASE("recon --refine-camera: reported, closed, refused without an object") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "refine";
  fs::remove_all(dir);
  const std::string img = kSource + "/data/examples/car_0021.png";
  const std::string flags = " --res 33 --no-preview --json --refine-camera --refine-res 17 --refine-sweep 30 "
                            "--refine-sweep-step 15";
  const std::string a = (dir / "a.obj").string();
  Run r = run("recon " + img + " -o " + a + flags);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  REQUIRE(j.contains("camera_refinement"));
  const Json& round = j["camera_refinement"]["rounds"].at(0);
  CHECK(j["camera_refinement"]["rounds"].size() == 1);
  CHECK(round["evaluations"].get<int>() == 5);  // the estimate and 4 turns (-30, -15, 15, 30)
  CHECK(round["iou_after"].get<double>() >= round["iou_before"].get<double>());
  CHECK(round["iou_before"].get<double>() > 0.5);  // the shipped example's mesh roughly fits its own alpha
  const double sweep = round["sweep_azimuth_deg"].get<double>();
  CHECK((sweep == 0 || std::abs(sweep) == 15 || std::abs(sweep) == 30));
  const Camera initial = camera_from_json(j["camera_refinement"]["initial_camera"]);
  const Camera final_cam = camera_from_json(j["camera"]);
  // The refined camera is the initial one turned by the sweep about the object's vertical axis (no local search).
  const LookAtParams li = look_at_params(initial), lf = look_at_params(final_cam);
  double daz = std::fmod(lf.azimuth_deg - li.azimuth_deg + 540.0, 360.0) - 180.0;
  CHECK(std::abs(std::abs(daz) - std::abs(sweep)) < 1e-6);
  CHECK(camera_center(final_cam).norm() == doctest::Approx(camera_center(initial).norm()));
  CHECK(j["seconds"]["refine"].get<double>() > 0);
  CHECK(is_closed_oriented(read_mesh(a)));

  // A mask without any object pixel: refused (the background check of the input comes first), nothing written.
  write_image((dir / "black_mask.png").string(), Image(137, 137, 1, 0.f));
  r = run("recon " + img + " -o " + (dir / "c.obj").string() + flags + " --mask " + (dir / "black_mask.png").string());
  CHECK(r.code == 1);
  CHECK(r.err.find("background") != std::string::npos);
  CHECK(!fs::exists(dir / "c.obj"));
}

TEST_CASE("recon of a folder where two images share a stem: the second fails as an item, the first's mesh stays") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "stems";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  // x.png (a chair) and x.tif (a car) both map to out/x.obj; x.json is the sidecar camera of both.
  fs::copy_file(kSource + "/data/examples/chair_0004.png", dir / "in" / "x.png");
  write_image((dir / "in" / "x.tif").string(), read_image(kSource + "/data/examples/car_0021.png"));
  fs::copy_file(kSource + "/data/examples/chair_0004.json", dir / "in" / "x.json");
  const Run r = run("recon " + (dir / "in").string() + " -o " + (dir / "out").string() +
                    " --res 33 --cam sidecar --no-preview");
  CHECK(r.code == 2);
  CHECK(r.err.find((dir / "in" / "x.tif").string() + ": its output " + (dir / "out" / "x.obj").string() +
                   " is also the output of " + (dir / "in" / "x.png").string()) != std::string::npos);
  // out/x.obj is the chair's reconstruction, byte for byte the one of the chair alone (not overwritten by the car).
  const Run alone = run("recon " + (dir / "in" / "x.png").string() + " -o " + (dir / "alone.obj").string() +
                        " --res 33 --cam sidecar --no-preview");
  REQUIRE(alone.code == 0);
  CHECK(read_file((dir / "out" / "x.obj").string()) == read_file((dir / "alone.obj").string()));
}

// Issue 19: an object pasted off-centre on a plain coloured background in a non-square image without alpha is
// found, cropped to the training framing and reconstructed (measured: IoU 64.9 against 64.1 for the render on white,
// estimated camera, 65^3; the plane fills 0.70 of its render, near the renders' median 0.67, so the crop restores
// its scale); the camera refers to the input image; the mask used is
// written beside the preview; the mesh format follows -o's extension.
TEST_CASE("recon of a non-square photo-like image: plain background found, reframed, camera of the input image") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "framing";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Image car = read_image(kSource + "/data/examples/plane_0010.png");  // object size 0.70 of the image
  REQUIRE(car.channels == 4);
  Image comp(300, 180, 3);
  const float bg[3] = {0.15f, 0.3f, 0.75f};
  for (int y = 0; y < comp.height; ++y)
    for (int x = 0; x < comp.width; ++x)
      for (int c = 0; c < 3; ++c) comp.at(x, y, c) = bg[c];
  const int ox = 150, oy = 30;  // off-centre
  for (int y = 0; y < car.height; ++y)
    for (int x = 0; x < car.width; ++x) {
      const float a = car.at(x, y, 3);
      for (int c = 0; c < 3; ++c) comp.at(ox + x, oy + y, c) = a * car.at(x, y, c) + (1 - a) * bg[c];
    }
  const std::string in = (dir / "comp.png").string(), out = (dir / "comp.stl").string();
  write_image(in, comp);
  const Run r = run("recon " + in + " -o " + out + " --res 65 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  CHECK(j["framing"]["mask_source"] == "plain-background");
  CHECK(j["framing"]["reframed"].get<bool>());
  CHECK(j["framing"]["fit_rounds"] == 1);  // the default --framing-fit
  CHECK(j["pose_model"] == "photo");       // a reframed image: the photo pose model (data/models/pose_photo.ckpt)
  CHECK(j["warnings"].empty());
  const Camera cam = camera_from_json(j["camera"]), net = camera_from_json(j["network_camera"]);
  CHECK(cam.width == 300);
  CHECK(cam.height == 180);
  CHECK(net.width == 137);
  // The object's centre (the object frame's origin) projects near the render's centre in the input image.
  const Eigen::Vector2d o = project(cam, Vec3::Zero());
  CHECK(std::abs(o.x() - (ox + 68.5)) < 12);
  CHECK(std::abs(o.y() - (oy + 68.5)) < 12);
  const Image mask = read_image((dir / "comp.mask.png").string());
  CHECK(mask.width == 300);
  CHECK(mask.height == 180);
  const Mesh m = read_mesh(out);
  CHECK(m.num_faces() > 100);
  const double iou = iou_of(out, kSource + "/data/examples/gt/plane_0010.ply");
  MESSAGE("IoU of the plane on blue, off-centre, 300 x 180: " << iou);
  CHECK(iou > 0.5);
  // --framing-fit 0: the box-centred crop as it is.
  const Run r0 = run("recon " + in + " -o " + (dir / "comp_0.stl").string() + " --res 33 --json --framing-fit 0");
  REQUIRE_MESSAGE(r0.code == 0, r0.err);
  const Json j0 = Json::parse(r0.out);
  CHECK(j0["framing"]["fit_rounds"] == 0);
  const Camera net0 = camera_from_json(j0["network_camera"]);
  // With --pose-distances the estimated camera keeps its view of the origin and lies at a render distance (on the
  // same crop: without fitting, which reads the camera).
  const Run rd = run("recon " + in + " -o " + (dir / "comp_d.stl").string() +
                     " --res 33 --json --framing-fit 0 --pose-distances 2.6,2.6");
  REQUIRE_MESSAGE(rd.code == 0, rd.err);
  const Json jd = Json::parse(rd.out);
  const Camera netd = camera_from_json(jd["network_camera"]);
  CHECK(netd.t.norm() == doctest::Approx(2.6).epsilon(1e-9));
  CHECK((project(netd, Vec3::Zero()) - project(net0, Vec3::Zero())).norm() < 1e-6);
  CHECK(netd.K(0, 0) / net0.K(0, 0) == doctest::Approx(2.6 / net0.t.norm()).epsilon(1e-9));
  // Where the fitting round cuts the crop (--framing-fit-centre). auto with the shipped photo pose model, which has a
  // centre head, is camera: the crop is centred where the first reading (the box-centred crop's, which --framing-fit 0
  // reports) shows the origin, at the size a unit sphere has in a render at the nearest render distance.
  const Camera input0 = camera_from_json(j0["camera"]);
  const Run rc = run("recon " + in + " -o " + (dir / "comp_c.obj").string() + " --res 33 --json --no-preview");
  const Run rc2 = run("recon " + in + " -o " + (dir / "comp_c2.obj").string() +
                      " --res 33 --json --no-preview --framing-fit-centre camera");
  REQUIRE_MESSAGE(rc.code == 0, rc.err);
  REQUIRE_MESSAGE(rc2.code == 0, rc2.err);
  CHECK(read_file((dir / "comp_c.obj").string()) == read_file((dir / "comp_c2.obj").string()));
  const Json jc = Json::parse(rc.out);
  const Json& crop = jc["framing"]["crop"];
  const double side = crop["side"].get<double>();
  const Eigen::Vector2d origin0 = project(input0, Vec3::Zero());
  CHECK(crop["x"].get<double>() + 0.5 * side == doctest::Approx(origin0.x()).epsilon(1e-9));
  CHECK(crop["y"].get<double>() + 0.5 * side == doctest::Approx(origin0.y()).epsilon(1e-9));
  const double d0 = input0.t.norm();
  CHECK(side == doctest::Approx(137 * input0.K(0, 0) * std::clamp(d0, 2.45, 3.0) / (kDisnFocal * d0)).epsilon(1e-9));
  // shape: the crop follows a coarse mesh reconstructed through that reading instead.
  const Run rs = run("recon " + in + " -o " + (dir / "comp_s.obj").string() +
                     " --res 33 --json --no-preview --framing-fit-centre shape");
  REQUIRE_MESSAGE(rs.code == 0, rs.err);
  CHECK(std::abs(Json::parse(rs.out)["framing"]["crop"]["x"].get<double>() - crop["x"].get<double>()) > 0.1);
  // The main pose model has no centre head (its cameras show the origin at the image centre): auto is shape.
  const std::string main_pose = " --res 33 --json --no-preview --photo-pose-model none";
  const Run ra = run("recon " + in + " -o " + (dir / "comp_ma.obj").string() + main_pose);
  const Run rb = run("recon " + in + " -o " + (dir / "comp_mb.obj").string() + main_pose + " --framing-fit-centre shape");
  REQUIRE_MESSAGE(ra.code == 0, ra.err);
  REQUIRE_MESSAGE(rb.code == 0, rb.err);
  CHECK(read_file((dir / "comp_ma.obj").string()) == read_file((dir / "comp_mb.obj").string()));
  CHECK(run("recon " + in + " -o " + (dir / "comp_bad.stl").string() + " --framing-fit-centre middle").code != 0);

  // With the true camera (the example's view moved to the pasted place) one fitting round finds the pasted render's
  // square exactly: the network camera is the example's camera again.
  Camera truth = read_camera(kSource + "/data/examples/plane_0010.json");
  const Camera example = truth;
  truth.K(0, 2) += ox;
  truth.K(1, 2) += oy;
  truth.width = 300;
  truth.height = 180;
  const std::string cam_path = (dir / "truth.json").string();
  write_json(cam_path, camera_to_json(truth));
  const Run rt = run("recon " + in + " -o " + (dir / "comp_t.stl").string() + " --res 33 --json --cam " + cam_path);
  REQUIRE_MESSAGE(rt.code == 0, rt.err);
  const Json jt = Json::parse(rt.out);
  CHECK(jt["framing"]["fit_rounds"] == 1);
  CHECK(jt["framing"]["crop"]["x"].get<double>() == doctest::Approx(ox).epsilon(1e-9));
  CHECK(jt["framing"]["crop"]["side"].get<double>() == doctest::Approx(137).epsilon(1e-9));
  CHECK((camera_from_json(jt["network_camera"]).K - example.K).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(run("recon " + in + " -o " + (dir / "comp_bad.stl").string() + " --framing-fit -1").code != 0);
  // --photo-pose-model none, or a pose model of one's own: the main pose model reads the reframed image too.
  for (const std::string& flag :
       {std::string("--photo-pose-model none"), "--pose-model " + kSource + "/data/models/pose.ckpt"}) {
    CAPTURE(flag);
    const Run rm = run("recon " + in + " -o " + (dir / "comp_m.stl").string() + " --res 33 --json " + flag);
    REQUIRE_MESSAGE(rm.code == 0, rm.err);
    CHECK(Json::parse(rm.out)["pose_model"] == "main");
  }
  // The photo SDF model (data/models/sdf_photo.ckpt) reconstructs a reframed image; --photo-model none the main one,
  // and the main model named as the photo model gives the same mesh byte for byte as none does.
  CHECK(j["sdf_model"] == "photo");
  const std::string m_none = (dir / "comp_sn.obj").string(), m_same = (dir / "comp_ss.obj").string(),
                    m_def = (dir / "comp_sd.obj").string();
  const Run rs0 = run("recon " + in + " -o " + m_none + " --res 33 --json --no-preview --photo-model none");
  const Run rs1 = run("recon " + in + " -o " + m_same + " --res 33 --json --no-preview --photo-model " + kSource +
                      "/data/models/sdf.ckpt");
  const Run rs2 = run("recon " + in + " -o " + m_def + " --res 33 --json --no-preview");
  REQUIRE_MESSAGE(rs0.code == 0, rs0.err);
  REQUIRE_MESSAGE(rs1.code == 0, rs1.err);
  REQUIRE_MESSAGE(rs2.code == 0, rs2.err);
  CHECK(Json::parse(rs0.out)["sdf_model"] == "main");
  CHECK(Json::parse(rs1.out)["sdf_model"] == "photo");
  CHECK(read_file(m_none) == read_file(m_same));
  CHECK(read_file(m_none) != read_file(m_def));  // the shipped photo model is another network
  // A model of another kind (the RGB-only two-stream model), a missing file, --framing none: refused, named.
  const Run rs3 = run("recon " + in + " -o " + m_none + " --photo-model " + kSource + "/data/models/sdf_rgb.ckpt");
  CHECK(rs3.code == 1);
  CHECK(rs3.err.find("sdf_rgb.ckpt: the photo SDF model is") != std::string::npos);
  const Run rs4 = run("recon " + in + " -o " + m_none + " --photo-model " + (dir / "missing.ckpt").string());
  CHECK(rs4.code == 1);
  CHECK(rs4.err.find("missing.ckpt") != std::string::npos);
  const Run rs5 = run("recon " + in + " -o " + m_none + " --framing none --photo-model " + kSource +
                      "/data/models/sdf.ckpt");
  CHECK(rs5.code == 1);
  CHECK(rs5.err.find("--photo-model") != std::string::npos);
  const Run rg = run("recon " + in + " -o " + (dir / "comp_g.stl").string() + " --cam " + cam_path +
                     " --photo-pose-model none");
  CHECK(rg.code == 1);
  CHECK(rg.err.find("--photo-pose-model applies with --cam est") != std::string::npos);
  const Run rkg = run("recon " + in + " -o " + (dir / "comp_kg.stl").string() + " --cam " + cam_path +
                      " --framing-fit-centre camera");
  CHECK(rkg.code == 1);
  CHECK(rkg.err.find("--framing-fit-centre applies with --cam est") != std::string::npos);
  const Run rn = run("recon " + in + " -o " + (dir / "comp_bad.stl").string() + " --framing none --framing-fit 1");
  CHECK(rn.code == 1);
  CHECK(rn.err.find("--framing-fit") != std::string::npos);
}

TEST_CASE("recon with an object-channel photo model: it reads the unmasked crop, and only as the photo model") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "context";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // The shipped photo SDF model's weights declared as an object-channel model: the same network, another input.
  const auto photo = load_sdf_model(kSource + "/data/models/sdf_photo.ckpt");
  SdfNetConfig config = photo->config();
  config.mask_channel = SdfNetConfig::MaskChannel::kObject;
  SdfNet ctx(config);
  std::copy(photo->params().values.begin(), photo->params().values.end(), ctx.params().values.begin());
  const std::string ctx_path = (dir / "ctx.ckpt").string();
  save_sdf_model(ctx_path, ctx);
  // The plane example off-centre on a photo-like image whose background is a plain colour with stripes.
  const Image plane = read_image(kSource + "/data/examples/plane_0010.png");
  Image comp(300, 180, 3);
  for (int y = 0; y < comp.height; ++y)
    for (int x = 0; x < comp.width; ++x) {
      const float stripe = (x / 6) % 2 ? 0.1f : 0.f;
      const float bg[3] = {0.15f + stripe, 0.3f, 0.75f - stripe};
      const bool in_plane = x >= 150 && y >= 30 && x < 150 + plane.width && y < 30 + plane.height;
      const float a = in_plane ? plane.at(x - 150, y - 30, 3) : 0.f;
      for (int c = 0; c < 3; ++c) comp.at(x, y, c) = a * (in_plane ? plane.at(x - 150, y - 30, c) : 0.f) + (1 - a) * bg[c];
    }
  const std::string in = (dir / "comp.png").string();
  write_image(in, comp);
  const std::string m_ctx = (dir / "ctx.obj").string(), m_def = (dir / "def.obj").string();
  const Run rc = run("recon " + in + " -o " + m_ctx + " --res 33 --json --no-preview --photo-model " +
                     ctx_path);
  const Run rd = run("recon " + in + " -o " + m_def + " --res 33 --json --no-preview");
  REQUIRE_MESSAGE(rc.code == 0, rc.err);
  REQUIRE_MESSAGE(rd.code == 0, rd.err);
  const Json jc = Json::parse(rc.out), jd = Json::parse(rd.out);
  CHECK(jc["sdf_model"] == "photo");
  CHECK(jc["framing"]["reframed"].get<bool>());
  CHECK(jc["network_camera"] == jd["network_camera"]);  // the pose network reads the same composite
  CHECK(read_file(m_ctx) != read_file(m_def));         // the SDF network reads the stripes and the object's mask
  CHECK(read_mesh(m_ctx).num_faces() > 0);
  // As the main model it is refused, named: only the crops recon makes carry its channels.
  const Run rm = run("recon " + in + " -o " + m_ctx + " --model " + ctx_path);
  CHECK(rm.code == 1);
  CHECK(rm.err.find("unmasked") != std::string::npos);
}

TEST_CASE("recon outputs: the format follows -o, a folder only for a folder input, flags that do not apply fail") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "outputs";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  const std::string img = kSource + "/data/examples/chair_0004.png";
  const std::string cam = " --cam " + kSource + "/data/examples/chair_0004.json --res 33 --no-preview";
  for (const char* ext : {"obj", "ply", "off", "stl"}) {
    CAPTURE(ext);
    const std::string out = (dir / (std::string("chair.") + ext)).string();
    const Run r = run("recon " + img + " -o " + out + cam);
    REQUIRE_MESSAGE(r.code == 0, r.err);
    CHECK(fs::is_regular_file(out));
    CHECK(read_mesh(out).num_faces() > 50);
  }
  fs::copy_file(img, dir / "in" / "a.png");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"recon " + img + " -o " + (dir / "noext").string() + cam, "give a mesh path"},
      {"recon " + img + " -o " + (dir / "x.xyz").string() + cam, "give a mesh path"},
      {"recon " + (dir / "in").string() + " -o " + (dir / "many.obj").string() + cam, "give a folder"},
      {"recon " + img + " -o " + (dir / "f.obj").string() + " --format ply" + cam, "--format applies"},
      {"recon " + img + " -o " + (dir / "j.obj").string() + " --jobs 0" + cam, "must be > 0 (got 0)"},
      {"recon " + img + " -o " + (dir / "k.obj").string() + " --flip-check 2" + cam, "applies with --cam est"},
      {"recon " + img + " -o " + (dir / "k2.obj").string() + " --pose-distances 2.45,3" + cam, "applies with --cam est"},
      {"recon " + img + " -o " + (dir / "k4.obj").string() + " --pose-tta none" + cam, "applies with --cam est"},
      {"recon " + img + " -o " + (dir / "k5.obj").string() + " --pose-tta both --res 33", "--pose-tta"},
      {"recon " + img + " -o " + (dir / "k6.obj").string() + " --pose-zoom-tta 0.9" + cam, "applies with --cam est"},
      {"recon " + img + " -o " + (dir / "k7.obj").string() + " --pose-zoom-tta 0.9,1 --res 33",
       "--pose-zoom-tta wants magnifications in [0.5, 2] other than 1"},
      {"recon " + img + " -o " + (dir / "k8.obj").string() + " --pose-zoom-tta 3 --res 33", "--pose-zoom-tta wants"},
      {"recon " + img + " -o " + (dir / "k9.obj").string() + " --pose-zoom-tta 0.9, --res 33", "--pose-zoom-tta wants"},
      {"recon " + img + " -o " + (dir / "k3.obj").string() + " --pose-distances 3,2 --res 33", "0 < MIN <= MAX"},
      {"recon " + img + " -o " + (dir / "l.obj").string() + " --refine-res 17" + cam, "applies with --refine-camera"},
      {"recon " + img + " -o " + (dir / "m.obj").string() + " --dense --safety 3" + cam, "--safety applies"},
      {"recon " + img + " -o " + (dir / "t.obj").string() + " --threshold 1.2" + cam, "outside (0, 1)"},
      {"recon " + img + " -o " + (dir / "t2.obj").string() + " --threshold 0.4 --model " + kSource +
           "/data/models/sdf_rgb.ckpt" + cam,
       "--threshold applies to a binary-variant model"},
  };
  for (const auto& item : bad) {
    const auto& cmd = item.first;
    const auto& message = item.second;
    CAPTURE(cmd);
    const Run r = run(cmd);
    CHECK(r.code == 1);
    CHECK(r.err.find(message) != std::string::npos);
  }
  CHECK(!fs::exists(dir / "t.obj"));
  // The JSON says what ran: the shipped (binary) model's threshold and the mirror augmentation.
  const Run tta = run("recon " + img + " -o " + (dir / "tta.obj").string() + " --threshold 0.4 --mirror-tta --json" + cam);
  REQUIRE_MESSAGE(tta.code == 0, tta.err);
  const Json jt = Json::parse(tta.out);
  CHECK(jt.at("threshold").get<double>() == 0.4);
  CHECK(jt.at("mirror_tta").get<bool>());
  CHECK(!fs::exists(dir / "noext"));
  CHECK(!fs::exists(dir / "many.obj"));
  // A folder input writes <stem>.<--format> into the -o folder.
  const Run r = run("recon " + (dir / "in").string() + " -o " + (dir / "outdir").string() + " --format stl" + cam);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(fs::is_regular_file(dir / "outdir" / "a.stl"));
}

// Issue 79: an output folder that cannot be made used to cost a whole batch of reconstructions, then one "cannot
// open for writing" per image and exit 2, without the reason. A folder under a regular file cannot be created
// even by root (the tests may run as root, which permissions would not stop).
TEST_CASE("recon into an output folder that cannot be created fails at once with the reason, exit 1") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "unwritable";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  const std::string img = kSource + "/data/examples/chair_0004.png";
  fs::copy_file(img, dir / "in" / "a.png");
  fs::copy_file(img, dir / "in" / "b.png");
  write_text_atomic((dir / "notes.txt").string(), "a file, not a folder\n");
  const std::string batch = (dir / "notes.txt" / "batch").string();
  const std::string cam = " --cam " + kSource + "/data/examples/chair_0004.json --res 33 --no-preview";
  Run r = run("recon " + (dir / "in").string() + " -o " + batch + cam);
  CHECK(r.code == 1);
  CHECK(r.err.find(batch) != std::string::npos);
  CHECK(r.err.find("Not a directory") != std::string::npos);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line, not one per image
  CHECK(r.out.find("a.png") == std::string::npos);          // nothing was reconstructed
  // One image into a mesh path whose folder cannot be made: the same, before the reconstruction.
  const std::string mesh = (dir / "notes.txt" / "sub" / "a.obj").string();
  r = run("recon " + img + " -o " + mesh + cam);
  CHECK(r.code == 1);
  CHECK(r.err.find("Not a directory") != std::string::npos);
  // A folder that does not exist yet is made.
  r = run("recon " + (dir / "in").string() + " -o " + (dir / "new" / "batch").string() + cam);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(fs::is_regular_file(dir / "new" / "batch" / "a.obj"));
}

// Issue 19 (real inputs): phones and the web give HEIC and WebP. A single input file is one image whatever its
// extension (OpenImageIO decides); a folder contributes the image formats this OpenImageIO reads.
TEST_CASE("recon inputs: WebP and HEIC files, in a folder or alone, and a single file of any extension") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "formats";
  fs::remove_all(dir);
  fs::create_directories(dir / "in");
  const std::string img = kSource + "/data/examples/chair_0004.png";
  const std::string cam = " --cam " + kSource + "/data/examples/chair_0004.json --res 33 --no-preview";
  // write_image writes neither format: OpenImageIO's writers, from 8-bit pixels with 64 bytes to spare at the
  // end (OpenImageIO 2.4's HEIF writer copies each row rounded up to libheif's 16-byte stride; AddressSanitizer
  // reports the read past a buffer of the exact size).
  const Image chair = read_image(img);
  REQUIRE(chair.channels == 4);
  std::vector<unsigned char> bytes(chair.data.size() + 64, 0);
  for (size_t i = 0; i < chair.data.size(); ++i)
    bytes[i] = static_cast<unsigned char>(std::lround(std::clamp(chair.data[i], 0.0f, 1.0f) * 255.0f));
  for (const char* name : {"a.webp", "b.heic"}) {
    const std::string path = (dir / "in" / name).string();
    auto out = OIIO::ImageOutput::create(path);
    REQUIRE(out);
    OIIO::ImageSpec spec(chair.width, chair.height, 4, OIIO::TypeDesc::UINT8);
    spec.alpha_channel = 3;
    REQUIRE(out->open(path, spec));
    REQUIRE(out->write_image(OIIO::TypeDesc::UINT8, bytes.data()));
    REQUIRE(out->close());
  }
  fs::copy_file(img, dir / "in" / "c.png");
  write_text_atomic((dir / "in" / "notes.txt").string(), "not an image\n");
  // The folder: the three images, not the text file.
  Run r = run("recon " + (dir / "in").string() + " -o " + (dir / "out").string() + cam + " --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  REQUIRE(j.size() == 3);
  for (const Json& item : j) {
    CAPTURE(item.dump());
    CHECK(item.at("framing").at("image_size") == Json::array({137, 137}));
    CHECK(item.at("framing").at("mask_source") == "alpha");  // both formats keep the render's alpha
  }
  for (const char* stem : {"a", "b", "c"})
    CHECK(read_mesh((dir / "out" / (std::string(stem) + ".obj")).string()).num_faces() > 50);
  // Alone, each is one image: -o names its mesh.
  r = run("recon " + (dir / "in" / "b.heic").string() + " -o " + (dir / "heic.obj").string() + cam);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(read_mesh((dir / "heic.obj").string()).num_faces() > 50);
  fs::copy_file(img, dir / "chair.image");
  r = run("recon " + (dir / "chair.image").string() + " -o " + (dir / "any.obj").string() + cam);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  CHECK(fs::is_regular_file(dir / "any.obj"));
  // A file that is no image is refused by name; a folder without images lists what it looks for.
  write_text_atomic((dir / "notes.xyz").string(), "not an image\n");
  r = run("recon " + (dir / "notes.xyz").string() + " -o " + (dir / "x.obj").string() + cam);
  CHECK(r.code != 0);
  CHECK(r.err.find("notes.xyz") != std::string::npos);
  CHECK(r.err.find("cannot read image") != std::string::npos);
  CHECK(!fs::exists(dir / "x.obj"));
  fs::create_directories(dir / "empty");
  fs::copy_file(dir / "notes.xyz", dir / "empty" / "notes.xyz");
  r = run("recon " + (dir / "empty").string() + " -o " + (dir / "out2").string() + cam);
  CHECK(r.code == 1);
  CHECK(r.err.find("holds no images (png, jpg, jpeg, exr, tif, tiff, bmp, webp, heic") != std::string::npos);
}

// Multi-view reconstruction (`recon --fuse`): four rendered views of an example's ground truth with their cameras
// give one closed mesh close to it; the flags that do not apply are refused.
TEST_CASE("recon --fuse: views of one object with their cameras give one mesh, inapplicable flags refused") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "fuse";
  fs::remove_all(dir);
  const std::string views = (dir / "views").string(), gt = (dir / "gt.ply").string();
  Run r = run("render " + kSource + "/data/examples/gt/car_0021.ply -o " + views + " --views 4 --seed 3 --mesh-out " + gt);
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const std::string fused = (dir / "fused.obj").string(), one = (dir / "one.obj").string();
  r = run("recon " + views + " -o " + fused + " --fuse --cam sidecar --res 33 --json");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json j = Json::parse(r.out);
  REQUIRE(j.at("views").size() == 4);
  for (const Json& v : j.at("views")) {
    CHECK(v.at("camera_source") == "given");
    CHECK_FALSE(v.contains("pose_model"));
  }
  // Estimated: each view by the main pose model (renders framed like the training renders are not reframed).
  r = run("recon " + views + " -o " + (dir / "fused_est.obj").string() + " --fuse --res 33 --json --no-preview");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const Json est = Json::parse(r.out);  // named: a range-for over a temporary's member would read freed memory
  for (const Json& v : est.at("views")) {
    CHECK(v.at("camera_source") == "estimated");
    CHECK(v.at("pose_model") == "main");
    CHECK(v.at("sdf_model") == "main");
  }
  CHECK(j.at("views")[1].at("input").get<std::string>().find("01.png") != std::string::npos);
  CHECK(fs::exists(dir / "fused.preview.png"));
  CHECK(is_closed_oriented(read_mesh(fused)));
  r = run("recon " + views + "/00.png -o " + one + " --cam sidecar --res 33 --no-preview");
  REQUIRE_MESSAGE(r.code == 0, r.err);
  const double iou_fused = iou_of(fused, gt), iou_one = iou_of(one, gt);
  MESSAGE("IoU: view 00 alone " << iou_one << ", four views fused " << iou_fused);
  CHECK(iou_fused > 0.5);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"recon " + views + "/00.png -o " + (dir / "a.obj").string() + " --fuse --cam sidecar", "two or more views"},
      {"recon " + views + " -o " + (dir / "outdir").string() + " --fuse --cam sidecar", "writes one mesh"},
      {"recon " + views + " -o " + (dir / "b.obj").string() + " --fuse --cam " + views + "/00.json", "its own camera"},
      {"recon " + views + " -o " + (dir / "c.obj").string() + " --fuse --cam sidecar --jobs 2", "--jobs does not apply"},
      {"recon " + views + " -o " + (dir / "d.obj").string() + " --fuse --cam sidecar --refine-camera",
       "--refine-camera does not apply"},
      {"recon " + views + " -o " + (dir / "e.obj").string() + " --fuse --cam sidecar --format ply", "--format applies"},
  };
  for (const auto& item : bad) {
    const std::string& cmd = item.first;  // not a structured binding: clang 14 cannot capture one (CAPTURE)
    const std::string& message = item.second;
    CAPTURE(cmd);
    const Run b = run(cmd);
    CHECK(b.code == 1);
    CHECK(b.err.find(message) != std::string::npos);
  }
  CHECK(!fs::exists(dir / "outdir"));
}

// Issue 19: an installed sdfkit finds its models next to itself; SDFKIT_MODEL_DIR overrides that; no model folder
// at all is a one-line error that says what to do.
TEST_CASE("cmake --install: the installed sdfkit finds the shipped models, SDFKIT_MODEL_DIR overrides them") {
  REQUIRE(have_models());
  const fs::path dir = test::scratch_dir("recon_cli") / "install";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path build = fs::path(SDFKIT_EXE).parent_path().parent_path();
  const int rc = std::system(("cmake --install " + build.string() + " --prefix " + (dir / "prefix").string() +
                              " > " + (dir / "install.log").string() + " 2>&1").c_str());
  REQUIRE(rc == 0);
  const fs::path exe = dir / "prefix" / "bin" / "sdfkit";
  REQUIRE(fs::exists(exe));
  CHECK(fs::is_regular_file(dir / "prefix" / "share" / "sdfkit" / "models" / "sdf.ckpt"));
  CHECK(fs::is_regular_file(dir / "prefix" / "share" / "sdfkit" / "models" / "pose.ckpt"));
  for (const char* f : {"sdf_photo.ckpt", "pose_photo.ckpt", "seg.ckpt", "sdf_photo.md"})
    CHECK_MESSAGE(fs::is_regular_file(dir / "prefix" / "share" / "sdfkit" / "models" / f), f);
  const std::string img = kSource + "/data/examples/chair_0004.png";
  auto run_exe = [&](const std::string& env, const std::string& args) {
    const std::string out = (dir / "out.txt").string(), err = (dir / "err.txt").string();
    const int status = std::system((env + " " + exe.string() + " " + args + " > " + out + " 2> " + err).c_str());
    test::CliRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = read_file(out);
    r.err = read_file(err);
    return r;
  };
  test::CliRun r = run_exe("env -u SDFKIT_MODEL_DIR", "recon " + img + " -o " + (dir / "a.obj").string() + " --res 33 --no-preview");
  CHECK_MESSAGE(r.code == 0, r.err);
  CHECK(fs::exists(dir / "a.obj"));
  // A model folder without models: the error names the missing file.
  fs::create_directories(dir / "empty");
  r = run_exe("SDFKIT_MODEL_DIR=" + (dir / "empty").string(), "recon " + img + " -o " + (dir / "b.obj").string() + " --res 33");
  CHECK(r.code == 1);
  CHECK(r.err.find((dir / "empty" / "sdf.ckpt").string()) != std::string::npos);
  // No model folder at all (an executable copied elsewhere, no SDFKIT_MODEL_DIR): say what to do.
  fs::create_directories(dir / "loose");
  fs::copy_file(exe, dir / "loose" / "sdfkit");
  const std::string out = (dir / "out.txt").string(), err = (dir / "err.txt").string();
  const int status = std::system(("env -u SDFKIT_MODEL_DIR " + (dir / "loose" / "sdfkit").string() + " recon " + img +
                                  " -o " + (dir / "c.obj").string() + " > " + out + " 2> " + err).c_str());
  CHECK(WEXITSTATUS(status) == 1);
  CHECK(read_file(err).find("SDFKIT_MODEL_DIR") != std::string::npos);
}
