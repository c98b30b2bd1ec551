// Reconstructor's extraction of a binary-variant model: its field (-logit / sdf_scale) is no distance, so the adaptive
// extraction's distance bound misjudges cells; following the surface from the cells kept gives the dense mesh.
#include "recon/recon.h"

#include "core/error.h"
#include "core/primitives.h"
#include "train/dataset.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

SdfNetConfig small_config(SdfVariant variant) {
  SdfNetConfig c;
  c.variant = variant;
  c.encoder_channels = {8, 16};
  c.extra_convs = 0;
  c.global_features = 16;
  c.point_mlp = {8};
  c.decoder = {16, 8};
  return c;
}

/// Grid points of the recon box at `res` per axis.
Points box_grid(int res, double half) {
  Points p(static_cast<Eigen::Index>(res) * res * res, 3);
  Eigen::Index i = 0;
  for (int z = 0; z < res; ++z)
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x, ++i)
        p.row(i) = Vec3(x, y, z) * (2 * half / (res - 1)) - Vec3::Constant(half);
  return p;
}

double median(Eigen::VectorXd v) {
  std::nth_element(v.data(), v.data() + v.size() / 2, v.data() + v.size());
  return v[v.size() / 2];
}

/// A grey disc on white, 3 x 137 x 137 channels-first.
Eigen::VectorXf disc_input() {
  const int s = kNetImageSize;
  Eigen::VectorXf in = Eigen::VectorXf::Ones(3L * s * s);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x)
        if (std::hypot(x - 68.0, y - 68.0) < 35.0) in[(static_cast<Eigen::Index>(c) * s + y) * s + x] = 0.4f + 0.1f * c;
  return in;
}

/// An untrained binary network whose field over the recon box has an inside and an outside: the last layer (stream
/// 2's output layer) scaled 100 times so that the field varies by more than the cells' size, then its bias (the last
/// parameter) shifted so that the field's median over the box is 0. The shift must move every value alike
/// (checked), else it was no bias.
std::unique_ptr<SdfNet> binary_with_surface(const Eigen::VectorXf& input, const Camera& camera, double box_half) {
  auto binary = std::make_unique<SdfNet>(small_config(SdfVariant::kBinary));
  binary->init(7);
  auto& store = binary->params();
  for (size_t i = store.offset(store.layers().size() - 1); i < store.size(); ++i) store.values[i] *= 100.f;
  const Points grid = box_grid(9, box_half);
  const SdfNet::ShapeCode code = binary->encode(input.data(), camera);
  Eigen::VectorXd before, after;
  binary->field(code, grid, before);
  const double m = median(before);
  store.values[store.size() - 1] += static_cast<float>(m * binary->config().sdf_scale);
  binary->field(binary->encode(input.data(), camera), grid, after);
  REQUIRE(((after - before).array() + m).abs().maxCoeff() < 1e-4);
  REQUIRE((after.array() < 0).count() > 0);
  REQUIRE((after.array() > 0).count() > 0);
  return binary;
}

/// The view and settings every case here reconstructs with: 33^3, no preview.
Camera test_camera() { return look_at(30.0, 20.0, 2.7, kNetImageSize, kNetImageSize); }
ReconSettings small_settings(bool dense) {
  ReconSettings s;
  s.resolution = 33;
  s.preview = false;
  s.dense = dense;
  return s;
}

}  // namespace

TEST_CASE("Reconstructor: a binary-variant model extracted adaptively with surface following gives the dense mesh") {
  const Camera camera = test_camera();
  const Eigen::VectorXf input = disc_input();
  ReconSettings s = small_settings(false);
  auto binary = binary_with_surface(input, camera, s.box_half);

  const Reconstructor rb(std::move(binary), nullptr);
  const ReconResult b = rb.run_input(input, &camera, s, "binary");
  CHECK_FALSE(b.dense);
  CHECK(b.evaluations < 33L * 33 * 33);
  CHECK(rb.extraction_safety(s) == default_extraction_safety(SdfVariant::kBinary));
  ReconSettings d = s;
  d.dense = true;
  const ReconResult bd = rb.run_input(input, &camera, d, "binary dense");
  CHECK(bd.dense);
  CHECK(bd.evaluations == 33L * 33 * 33);
  REQUIRE(bd.mesh.num_vertices() > 100);
  REQUIRE(bd.mesh.num_vertices() == b.mesh.num_vertices());
  // The network's values may differ in the last bits with the batch a point is evaluated in.
  CHECK((bd.mesh.V - b.mesh.V).cwiseAbs().maxCoeff() < 1e-5);
  CHECK(bd.mesh.F == b.mesh.F);
  // Without surface following the distance bound drops cells the surface runs through.
  ReconSettings p = s;
  p.follow_surface = false;
  p.safety = 1;
  const ReconResult bp = rb.run_input(input, &camera, p, "binary pruned");
  CHECK(bp.mesh.num_faces() < b.mesh.num_faces());
  p.follow_surface = true;
  const ReconResult bf = rb.run_input(input, &camera, p, "binary followed");
  CHECK(bf.mesh.F == b.mesh.F);
}

TEST_CASE("Reconstructor: a binary model's occupancy threshold moves its surface, an SDF model's is its 0 level") {
  const Camera camera = test_camera();
  const Eigen::VectorXf input = disc_input();
  ReconSettings s = small_settings(true);
  const Reconstructor rb(binary_with_surface(input, camera, s.box_half), nullptr);
  CHECK(rb.occupancy_threshold(s) == 0.5);
  CHECK(rb.surface_level(s) == 0.0);
  s.threshold = 0.2;
  // field = -logit / sdf_scale, so p > 0.2 <=> field < log(4) / sdf_scale.
  CHECK(rb.surface_level(s) == doctest::Approx(std::log(4.0) / rb.sdf().config().sdf_scale).epsilon(1e-12));
  double last_volume = 1e9;
  for (const double tau : {0.2, 0.5, 0.8}) {
    s.threshold = tau;
    const ReconResult r = rb.run_input(input, &camera, s, "binary");
    CHECK(r.threshold == tau);
    const double v = signed_volume(r.mesh);
    INFO("threshold " << tau << ": volume " << v);
    CHECK(v > 0);
    CHECK(v < last_volume);  // a higher threshold keeps fewer points inside
    last_volume = v;
  }
  for (const double bad : {-0.1, 1.0, 1.5, std::nan("")}) {
    s.threshold = bad;
    CHECK_THROWS_AS((void)rb.surface_level(s), InvalidInput);
  }
  auto sdf = std::make_unique<SdfNet>(small_config(SdfVariant::kTwoStream));
  sdf->init(3);
  const Reconstructor rs(std::move(sdf), nullptr);
  s.threshold = 0.3;  // not read: an SDF model's surface is its 0 level
  CHECK(rs.occupancy_threshold(s) == 0.0);
  CHECK(rs.surface_level(s) == 0.0);
}

TEST_CASE("Reconstructor: mirror test-time augmentation is exactly equivariant to mirroring the input") {
  const Camera camera = test_camera();
  // An input without left-right symmetry: the disc with a dark square on its left.
  Eigen::VectorXf input = disc_input();
  for (int c = 0; c < 3; ++c)
    for (int y = 50; y < 70; ++y)
      for (int x = 38; x < 55; ++x) input[(static_cast<Eigen::Index>(c) * kNetImageSize + y) * kNetImageSize + x] = 0.1f;
  ReconSettings s = small_settings(true);
  s.mirror_tta = true;
  const Reconstructor rb(binary_with_surface(input, camera, s.box_half), nullptr);

  const Eigen::VectorXf flipped = flip_network_input(input, kNetImageSize);
  CHECK(flip_network_input(flipped, kNetImageSize) == input);
  CHECK(flipped[(2L * kNetImageSize + 60) * kNetImageSize + 40] == input[(2L * kNetImageSize + 60) * kNetImageSize + 96]);
  CHECK_THROWS_AS((void)flip_network_input(input.head(100), kNetImageSize), InvalidInput);

  const ReconResult a = rb.run_input(input, &camera, s, "image");
  const Camera mirrored = mirror_camera(camera);
  const ReconResult b = rb.run_input(flipped, &mirrored, s, "flipped image");
  CHECK(a.mirror_tta);
  REQUIRE(a.mesh.num_vertices() > 100);
  REQUIRE(a.mesh.num_vertices() == b.mesh.num_vertices());
  // The mirrored input's mesh is the mesh mirrored across x = 0 (the same vertices with x negated, in another order).
  auto sorted = [](Points V, bool mirror) {
    if (mirror) V.col(0) = -V.col(0);
    std::vector<std::array<double, 3>> rows(static_cast<size_t>(V.rows()));
    for (Eigen::Index i = 0; i < V.rows(); ++i) rows[static_cast<size_t>(i)] = {V(i, 0), V(i, 1), V(i, 2)};
    std::sort(rows.begin(), rows.end());
    return rows;
  };
  const auto va = sorted(a.mesh.V, false), vb = sorted(b.mesh.V, true);
  double worst = 0;
  for (size_t i = 0; i < va.size(); ++i)
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(va[i][k] - vb[i][k]));
  CHECK(worst < 1e-5);  // the network's values may differ in the last bits with the batch a point is evaluated in
  // Without the augmentation the two inputs give different shapes: the augmentation did the work.
  s.mirror_tta = false;
  const ReconResult c = rb.run_input(input, &camera, s, "image, no augmentation");
  CHECK_FALSE(c.mirror_tta);
  CHECK(std::abs(signed_volume(c.mesh) - signed_volume(a.mesh)) > 1e-4);
}

namespace {

/// A network input (3 x 137 x 137, channels first) as a 137 x 137 RGB image.
Image input_image(const Eigen::VectorXf& input) {
  const int s = kNetImageSize;
  Image im(s, s, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x) im.at(x, y, c) = input[(static_cast<Eigen::Index>(c) * s + y) * s + x];
  return im;
}

}  // namespace

TEST_CASE("Reconstructor: a multi-view reconstruction extracts the mean of the views' fields") {
  const Camera cam_a = test_camera(), cam_b = look_at(100.0, 25.0, 2.6, kNetImageSize, kNetImageSize);
  const Eigen::VectorXf input_a = disc_input();
  Eigen::VectorXf input_b = input_a;  // the second view: the disc with a dark bar across it
  for (int c = 0; c < 3; ++c)
    for (int y = 60; y < 76; ++y)
      for (int x = 30; x < 107; ++x) input_b[(static_cast<Eigen::Index>(c) * kNetImageSize + y) * kNetImageSize + x] = 0.1f;
  ReconSettings s = small_settings(true);
  s.framing.reframe = Reframing::kNone;  // 137 px images on white: the network image is the image itself
  s.framing.segment = Segmentation::kNone;
  const Reconstructor rb(binary_with_surface(input_a, cam_a, s.box_half), nullptr);
  const Image a = input_image(input_a), b = input_image(input_b);

  // One view: the single-view reconstruction, bit for bit.
  const ReconResult one = rb.run(a, nullptr, &cam_a, s, "a");
  const ReconResult single = rb.run_views({a}, {&cam_a}, s, {"a"});
  REQUIRE(one.mesh.num_vertices() > 100);
  CHECK(single.mesh.V == one.mesh.V);
  CHECK(single.mesh.F == one.mesh.F);
  REQUIRE(single.view_cameras.size() == 1);
  CHECK(single.view_cameras[0].K == one.camera.K);
  // The same view twice: the mean of two equal fields is that field.
  const ReconResult twice = rb.run_views({a, a}, {&cam_a, &cam_a}, s, {"a", "a again"});
  CHECK(twice.mesh.V == one.mesh.V);
  CHECK(twice.mesh.F == one.mesh.F);

  // Two views: the fused mesh lies on the 0 level of the mean field, not on either view's.
  const ReconResult fused = rb.run_views({a, b}, {&cam_a, &cam_b}, s, {"a", "b"});
  const ReconResult swapped = rb.run_views({b, a}, {&cam_b, &cam_a}, s, {"b", "a"});
  REQUIRE(fused.mesh.num_vertices() > 100);
  CHECK(fused.mesh.V == swapped.mesh.V);  // the mean does not depend on the views' order
  CHECK(fused.view_cameras.size() == 2);
  CHECK_FALSE(fused.view_estimated[0]);
  Eigen::VectorXd fa, fb;
  const SdfNet& net = rb.sdf();
  const Eigen::VectorXf na = network_image(a), nb = network_image(b);
  net.field(net.encode(na.data(), fused.view_cameras[0]), fused.mesh.V, fa);
  net.field(net.encode(nb.data(), fused.view_cameras[1]), fused.mesh.V, fb);
  const double mean_level = median((0.5 * (fa + fb)).cwiseAbs());
  const double a_level = median(fa.cwiseAbs()), b_level = median(fb.cwiseAbs());
  // The scale of "on the level set" for this rough field at 33^3: view a's own mesh, on view a's field (marching
  // cubes interpolates linearly between grid values of a field that is far from linear across a cell).
  Eigen::VectorXd own;
  net.field(net.encode(na.data(), fused.view_cameras[0]), one.mesh.V, own);
  const double own_level = median(own.cwiseAbs());
  INFO("median |field| at the fused vertices: mean " << mean_level << ", view a " << a_level << ", view b " << b_level
       << "; view a's field at its own mesh " << own_level);
  CHECK(mean_level < 1.5 * own_level);
  CHECK(mean_level < 0.5 * a_level);
  CHECK(mean_level < 0.5 * b_level);

  // Camera refinement aligns one view: refused.
  ReconSettings r = s;
  r.refine_rounds = 1;
  CHECK_THROWS_AS((void)rb.run_views({a, b}, {&cam_a, &cam_b}, r, {"a", "b"}), InvalidInput);
  // Without a pose network every view needs a camera.
  CHECK_THROWS_AS((void)rb.run_views({a, b}, {&cam_a, nullptr}, s, {"a", "b"}), InvalidInput);
}

TEST_CASE("Reconstructor: fitting the framing with a given camera recovers the render's crop and camera") {
  // The disc "render" (test_camera) pasted 1.5 times larger, off-centre, on a transparent 320 x 240 canvas; the
  // canvas's camera is the render's scaled and moved alike. recon crops around the disc's box; one fitting round
  // moves the crop to the pasted render's square, where the network camera is the render's camera again.
  const Camera cam = test_camera();
  const double a = 1.5, ox = 40, oy = 25;
  Image canvas(320, 240, 4, 0.f);
  for (int y = 0; y < canvas.height; ++y)
    for (int x = 0; x < canvas.width; ++x) {
      const double u = (x + 0.5 - ox) / a, v = (y + 0.5 - oy) / a;  // the render's continuous pixel
      if (std::hypot(u - 68.5, v - 68.5) < 35.0) {
        for (int c = 0; c < 3; ++c) canvas.at(x, y, c) = 0.4f + 0.1f * static_cast<float>(c);
        canvas.at(x, y, 3) = 1.f;
      }
    }
  Camera canvas_cam = cam;
  Eigen::Matrix3d A;
  A << a, 0, ox, 0, a, oy, 0, 0, 1;
  canvas_cam.K = A * cam.K;
  canvas_cam.width = canvas.width;
  canvas_cam.height = canvas.height;
  ReconSettings s = small_settings(true);
  s.framing_fit_rounds = 0;
  const Eigen::VectorXf disc = disc_input();
  const Reconstructor rb(binary_with_surface(disc, cam, s.box_half), nullptr);

  const ReconResult plain = rb.run(canvas, nullptr, &canvas_cam, s, "canvas");
  REQUIRE(plain.framing.reframed);
  CHECK(plain.framing_fits == 0);
  CHECK(std::abs(plain.camera.K(1, 2) - cam.K(1, 2)) > 1.0);  // the box-centred crop moved the principal point

  s.framing_fit_rounds = 3;  // with a given camera one round is exact: the rest are not run
  const ReconResult fitted = rb.run(canvas, nullptr, &canvas_cam, s, "canvas");
  CHECK(fitted.framing_fits == 1);
  CHECK(fitted.framing.x0 == doctest::Approx(ox).epsilon(1e-9));
  CHECK(fitted.framing.y0 == doctest::Approx(oy).epsilon(1e-9));
  CHECK(fitted.framing.side == doctest::Approx(137 * a).epsilon(1e-9));
  CHECK((fitted.camera.K - cam.K).cwiseAbs().maxCoeff() < 1e-9);
  CHECK((fitted.input_camera.K - canvas_cam.K).cwiseAbs().maxCoeff() < 1e-9);
  // The network saw the render again, up to the resampled edge (and the box-centred crop did not).
  const auto differing = [&](const ReconResult& r) {
    const Eigen::VectorXf seen = network_image(r.framing.image);
    return ((seen - disc).array().abs() > 0.2f).count();
  };
  const long disc_px = (disc.head(kNetImageSize * kNetImageSize).array() < 0.5f).count();
  INFO("network pixels off the render: fitted " << differing(fitted) << ", box-centred " << differing(plain)
                                                << "; the disc covers " << disc_px);
  CHECK(differing(fitted) < 0.03 * 3 * disc_px);
  CHECK(differing(plain) > 0.3 * 3 * disc_px);

  // Several views (--fuse): each view's crop is fitted alike.
  const ReconResult fused = rb.run_views({canvas, canvas}, {&canvas_cam, &canvas_cam}, s, {"a", "b"});
  CHECK(fused.framing_fits == 1);
  CHECK(fused.framing.side == doctest::Approx(137 * a).epsilon(1e-9));
  for (const Camera& c : fused.view_cameras) CHECK((c.K - cam.K).cwiseAbs().maxCoeff() < 1e-9);

  s.framing_fit_rounds = -1;
  CHECK_THROWS_AS((void)rb.run(canvas, nullptr, &canvas_cam, s, "canvas"), InvalidInput);
}
