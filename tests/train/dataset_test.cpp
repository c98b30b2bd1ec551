#include "core/json.h"
#include "train/context.h"
#include "train/dataset.h"

#include "camera/camera.h"
#include "camera/image.h"
#include "camera/render.h"
#include "core/error.h"
#include "core/files.h"
#include "core/primitives.h"
#include "scratch.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <vector>

using namespace sdfkit;
namespace fs = std::filesystem;

namespace {

/// A tiny prepared dataset: 3 shapes (2 categories), 2 or 3 views each, samples whose sdf column encodes the row.
fs::path make_fake_dataset(const std::string& name) {
  const fs::path root = test::scratch_dir(name);
  fs::remove_all(root);
  const std::vector<std::pair<std::string, int>> shapes = {{"chair/a", 2}, {"chair/b", 3}, {"lamp/c", 2}};
  int s = 0;
  for (const auto& [id, views] : shapes) {
    const fs::path dir = root / id;
    MatrixXfR samples(100, 4);
    for (int r = 0; r < 100; ++r) samples.row(r) << 0.01f * r, -0.01f * r, float(s), float(1000 * s + r);
    write_npy((dir / "samples.npy").string(), samples);
    for (int v = 0; v < views; ++v) {
      char nn[16];
      std::snprintf(nn, sizeof nn, "%02d", v);
      write_camera((dir / "views" / (std::string(nn) + ".json")).string(), look_at(30.0 * v + 10 * s, 20, 2.0));
      Image img(137, 137, 4, 0.f);  // transparent, with one opaque red square
      for (int y = 40; y < 60; ++y)
        for (int x = 40 + v; x < 60 + v; ++x) {
          img.at(x, y, 0) = 1.f;
          img.at(x, y, 3) = 1.f;
        }
      write_image((dir / "views" / (std::string(nn) + ".png")).string(), img);
    }
    ++s;
  }
  write_text_atomic((root / "train.lst").string(), "chair/b\n# comment\n\nlamp/c\n");
  return root;
}

}  // namespace

TEST_CASE("dataset lists shapes from a split or from the folder, counts views, reads cameras") {
  const fs::path root = make_fake_dataset("dataset_list");
  DatasetSettings all;
  all.root = root.string();
  Dataset d(all);
  REQUIRE(d.size() == 3);
  CHECK(d.shape(0).id == "chair/a");
  CHECK(d.shape(1).num_views == 3);
  CHECK(d.shape(2).category == "lamp");
  const Camera c = d.camera(1, 2);
  const Camera expect = look_at(30.0 * 2 + 10, 20, 2.0);
  CHECK((c.R - expect.R).norm() < 1e-9);
  CHECK((c.t - expect.t).norm() < 1e-9);
  CHECK(d.samples(2)(5, 3) == 2005.f);

  DatasetSettings split = all;
  split.split = "train";
  Dataset t(split);
  REQUIRE(t.size() == 2);
  CHECK(t.shape(0).id == "chair/b");
  split.categories = {"lamp"};
  CHECK(Dataset(split).size() == 1);

  // A repeated line is a repeated entry (the shape comes up that much more often: train_models' stage 5 lists every
  // table three times), with the same samples.
  write_text_atomic((root / "twice.lst").string(), "chair/b\nlamp/c\nchair/b\n");
  split.categories.clear();
  split.split = (root / "twice.lst").string();
  const Dataset twice(split);
  REQUIRE(twice.size() == 3);
  CHECK(twice.shape(0).id == "chair/b");
  CHECK(twice.shape(2).id == "chair/b");
  CHECK(twice.samples(2) == twice.samples(0));

  // A listed shape without samples is an error naming it.
  write_text_atomic((root / "bad.lst").string(), "chair/zzz\n");
  split.categories.clear();
  split.split = (root / "bad.lst").string();
  CHECK_THROWS_AS(Dataset{split}, IoError);
  split.split = "nosuchsplit";
  CHECK_THROWS_AS(Dataset{split}, IoError);
  fs::remove_all(root);
}

TEST_CASE("network_image composites alpha on the background and resamples any size to 137") {
  Image transparent(50, 80, 4, 0.f);
  Eigen::VectorXf v = network_image(transparent);
  REQUIRE(v.size() == 3 * 137 * 137);
  CHECK((v.array() == kNetBackground).all());

  // Same-size input passes through exactly (channels-first layout).
  Image rgb(137, 137, 3, 0.f);
  for (int y = 0; y < 137; ++y)
    for (int x = 0; x < 137; ++x)
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = static_cast<float>((x + 2 * y + 3 * c) % 17) / 16.f;
  v = network_image(rgb);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < 137; y += 7)
      for (int x = 0; x < 137; x += 5) CHECK(v[(c * 137 + y) * 137 + x] == doctest::Approx(rgb.at(x, y, c)));

  // Downsampling a 2x image of a constant and of a half-split image: averages are preserved.
  Image big(274, 274, 1, 0.25f);
  for (int y = 0; y < 274; ++y)
    for (int x = 137; x < 274; ++x) big.at(x, y) = 0.75f;
  v = network_image(big);
  CHECK(v[0] == doctest::Approx(0.25f));
  CHECK(v[136] == doctest::Approx(0.75f));
  CHECK(v.mean() == doctest::Approx(0.5f).epsilon(1e-4));

  CHECK_THROWS_AS(network_image(Image{}), InvalidInput);
}

TEST_CASE("batches are deterministic per step, thread-count independent, and cover each epoch once") {
  const fs::path root = make_fake_dataset("dataset_batch");
  DatasetSettings ds;
  ds.root = root.string();
  Dataset d(ds);
  BatchSettings bs;
  bs.batch_size = 7;  // 7 pairs per epoch (2 + 3 + 2 views)
  bs.points_per_shape = 30;
  bs.seed = 42;
  BatchSampler sampler(d, bs);
  REQUIRE(sampler.items_per_epoch() == 7);

  const SdfBatch a = sampler.batch(3);
  SdfBatch b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = sampler.batch(3);
  }
  CHECK((a.images.array() == b.images.array()).all());
  CHECK((a.points.array() == b.points.array()).all());
  CHECK((a.sdf.array() == b.sdf.array()).all());
  CHECK(a.shape_index == b.shape_index);

  // One batch = one epoch here: every (shape, view) pair exactly once.
  std::set<std::pair<int, int>> seen;
  for (int i = 0; i < a.size(); ++i) seen.insert({a.shape_index[i], a.view_index[i]});
  CHECK(seen.size() == 7);
  // Different steps differ in order or points.
  const SdfBatch c = sampler.batch(4);
  CHECK(!((c.sdf.array() == a.sdf.array()).all()));

  // Points belong to their item's shape, without repetition; camera and image are of the item's view.
  for (int i = 0; i < a.size(); ++i) {
    std::set<float> rows;
    for (int k = 0; k < 30; ++k) {
      const float sdf = a.sdf[i * 30 + k];
      CHECK(static_cast<int>(sdf) / 1000 == a.shape_index[i]);
      CHECK(a.points(i * 30 + k, 2) == float(a.shape_index[i]));
      rows.insert(sdf);
    }
    CHECK(rows.size() == 30);
    const Camera expect = d.camera(a.shape_index[i], a.view_index[i]);
    CHECK((a.cameras[i].R - expect.R).norm() == 0.0);
    // The red square starts at column 40 + view: pixel (40 + view, 50) is red, (39 + view, 50) is background.
    const int v = a.view_index[i];
    const auto px = [&](int c, int y, int x) { return a.images(i, (c * 137 + y) * 137 + x); };
    CHECK(px(1, 50, 40 + v) == doctest::Approx(0.f));
    CHECK(px(1, 50, 39 + v) == doctest::Approx(1.f));
  }
  fs::remove_all(root);
}

TEST_CASE("draw_samples draws distinct rows, and with replacement only beyond the file size") {
  MatrixXfR s(10, 4);
  for (int r = 0; r < 10; ++r) s.row(r) << float(r), 0, 0, float(r);
  PointsF p;
  Eigen::VectorXf d;
  draw_samples(s, 10, 7, p, d);
  std::set<float> u(d.data(), d.data() + d.size());
  CHECK(u.size() == 10);
  draw_samples(s, 25, 7, p, d);
  CHECK(d.size() == 25);
  CHECK((p.col(0).array() == d.array()).all());
  CHECK_THROWS_AS(draw_samples(s, 0, 7, p, d), InvalidInput);
}

namespace {

/// B images of side S on white: a coloured square (colour depends on the image) with a half-covered (alpha 0.5)
/// border column, composited as network_image does.
MatrixXfR augment_test_images(int B, int S) {
  MatrixXfR im = MatrixXfR::Ones(B, 3 * S * S);
  for (int b = 0; b < B; ++b)
    for (int c = 0; c < 3; ++c) {
      const float colour = 0.1f + 0.2f * static_cast<float>((b + c) % 4);
      for (int y = 5; y < 15; ++y) {
        for (int x = 6; x < 16; ++x) im(b, (c * S + y) * S + x) = colour;
        im(b, (c * S + y) * S + 5) = 0.5f * colour + 0.5f;  // edge: alpha 0.5 over white
      }
    }
  return im;
}

}  // namespace

TEST_CASE("augment_images: seeded, thread-independent, identity when off, rejects bad settings") {
  const MatrixXfR src = augment_test_images(5, 21);
  ImageAugmentSettings a;
  MatrixXfR x = src;
  augment_images(x, a, 7, 0);
  CHECK((x.array() == src.array()).all());

  a.colour = 0.5;
  a.channel_swap = 0.5;
  a.noise = 0.03;
  MatrixXfR p = src, q = src, r = src;
  augment_images(p, a, 7, 100);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    augment_images(q, a, 7, 100);
  }
  augment_images(r, a, 7, 105);
  CHECK((p.array() == q.array()).all());
  CHECK(!((p.array() == r.array()).all()));
  CHECK(!((p.array() == src.array()).all()));
  CHECK(p.minCoeff() >= 0.f);
  CHECK(p.maxCoeff() <= 1.f);
  // Image b depends only on (seed, stream + b): the last image of stream 100 is the first of stream 104.
  MatrixXfR one_image = src.bottomRows(1);
  augment_images(one_image, a, 7, 104);
  MatrixXfR last = p.bottomRows(1);
  CHECK((one_image.array() == last.array()).all());

  ImageAugmentSettings bad;
  bad.colour = 1.0;
  CHECK_THROWS_AS(augment_images(x, bad, 1, 0), InvalidInput);
  bad = {};
  bad.channel_swap = 1.5;
  CHECK_THROWS_AS(augment_images(x, bad, 1, 0), InvalidInput);
  bad = {};
  bad.noise = -0.1;
  CHECK_THROWS_AS(augment_images(x, bad, 1, 0), InvalidInput);
  MatrixXfR not_square = MatrixXfR::Ones(1, 3 * 20);
  a.noise = 0;
  CHECK_THROWS_AS(augment_images(not_square, a, 1, 0), InvalidInput);
}

TEST_CASE("augment_images colour/swap does not move the object: white background kept, edges recoloured alike") {
  const int B = 40, S = 21, P = S * S;
  const MatrixXfR src = augment_test_images(B, S);
  ImageAugmentSettings a;
  a.colour = 0.6;
  a.channel_swap = 1.0;
  MatrixXfR x = src;
  augment_images(x, a, 3, 0);
  int changed = 0;
  for (int b = 0; b < B; ++b) {
    for (int i = 0; i < P; ++i) {
      const bool bg_before = src(b, i) == 1.f && src(b, P + i) == 1.f && src(b, 2 * P + i) == 1.f;
      const bool bg_after = x(b, i) == 1.f && x(b, P + i) == 1.f && x(b, 2 * P + i) == 1.f;
      CHECK(bg_before == bg_after);  // same silhouette, background exactly white
    }
    for (int c = 0; c < 3; ++c) {
      // Every interior pixel of a channel has the same new value; the alpha-0.5 edge carries half of its ink,
      // exactly as a render of the recoloured object (unless the interior was clamped to 0).
      const float inside = x(b, (c * S + 10) * S + 10);
      for (int y = 5; y < 15; ++y)
        for (int xx = 6; xx < 16; ++xx) CHECK(x(b, (c * S + y) * S + xx) == inside);
      if (inside > 0.f) CHECK(1.f - x(b, (c * S + 10) * S + 5) == doctest::Approx(0.5f * (1.f - inside)).epsilon(1e-5));
      if (inside != src(b, (c * S + 10) * S + 10)) ++changed;
    }
  }
  CHECK(changed > B);  // colours really change
}

TEST_CASE("augment_images noise has the requested standard deviation and zero mean") {
  const int S = 64;
  MatrixXfR x = MatrixXfR::Constant(4, 3 * S * S, 0.5f);
  ImageAugmentSettings a;
  a.noise = 0.05;
  augment_images(x, a, 11, 0);
  const double mean = x.cast<double>().mean();
  const double sd = std::sqrt((x.cast<double>().array() - 0.5).square().mean());
  CHECK(mean == doctest::Approx(0.5).epsilon(2e-3));
  CHECK(sd == doctest::Approx(0.05).epsilon(0.03));
}

namespace {

/// S x S white image with a centred dark square of side 2 h (pixels [c - h, c + h) in both axes, c = S / 2).
Eigen::VectorXf centred_square(int S, int h) {
  Eigen::VectorXf im = Eigen::VectorXf::Ones(3L * S * S);
  const int c = S / 2;
  for (int ch = 0; ch < 3; ++ch)
    for (int y = c - h; y < c + h; ++y)
      for (int x = c - h; x < c + h; ++x) im[(static_cast<Eigen::Index>(ch) * S + y) * S + x] = 0.2f;
  return im;
}

}  // namespace

TEST_CASE("zoom_image: a centred square grows and shrinks by the factor, white outside, limit keeps it inside") {
  const int S = 40, c = 20;
  const Eigen::VectorXf sq = centred_square(S, 5);  // pixels 15..24
  // x2: pixels whose centre maps inside the square (|x + 0.5 - 20| / 2 < 5, i.e. 10..29) are dark.
  const Eigen::VectorXf big = zoom_image(sq, S, 2.0);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const float v = big[y * S + x];
      const double r = std::max(std::abs(x + 0.5 - c), std::abs(y + 0.5 - c));
      if (r < 9) CHECK(v == doctest::Approx(0.2f));
      if (r > 10.5) CHECK(v == doctest::Approx(1.0f));
    }
  // x0.5: the square halves (pixels 18..21 dark), ink is conserved up to the 2 x 2 sampling of the edge.
  const Eigen::VectorXf small = zoom_image(sq, S, 0.5);
  CHECK(small[c * S + c] == doctest::Approx(0.2f));
  CHECK(small[c * S + c + 4] == doctest::Approx(1.0f));
  CHECK(small[5 * S + 5] == doctest::Approx(1.0f));
  const double ink = (1.0 - sq.head(S * S).array()).sum(), ink_small = (1.0 - small.head(S * S).array()).sum();
  CHECK(ink_small == doctest::Approx(ink / 4).epsilon(0.02));
  // The limit: the object's far pixel edge is 5 px from the centre, so (20 - 1) / 5.
  CHECK(max_zoom_inside(sq, S) == doctest::Approx(19.0 / 5.0));
  CHECK(std::isinf(max_zoom_inside(Eigen::VectorXf::Ones(3 * S * S), S)));
  CHECK_THROWS_AS(zoom_image(sq, S, 0.0), InvalidInput);
}

TEST_CASE("magnified_coordinate: k times the offset from the centre, unmagnified_coordinate undoes it") {
  for (const double k : {0.5, 0.8, 1.0, 1.25, 2.0})
    for (const double p : {0.0, 31.5, 68.5, 100.25}) {
      const double c = 68.5, m = magnified_coordinate(p, c, k);
      CHECK(m - c == doctest::Approx(k * (p - c)));
      CHECK(unmagnified_coordinate(m, c, k) == doctest::Approx(p));
    }
  CHECK(magnified_coordinate(68.5, 68.5, 1.7) == doctest::Approx(68.5));  // the centre stays
}

TEST_CASE("zoom_images: seeded and thread-independent, camera distance divided by the applied zoom") {
  const int S = 21, B = 12;
  MatrixXfR src(B, 3 * S * S);
  for (int b = 0; b < B; ++b) src.row(b) = centred_square(S, 1 + b % 4).transpose();
  std::vector<Camera> cams0;
  for (int b = 0; b < B; ++b) cams0.push_back(look_at(30.0 * b, 25, 2.5 + 0.01 * b, S, S));
  ZoomAugmentSettings z;
  z.prob = 0.6;
  z.min = 0.7;
  z.max = 1.6;
  MatrixXfR p = src, q = src;
  std::vector<Camera> cp = cams0, cq = cams0;
  std::vector<double> kp, kq;
  zoom_images(p, cp, z, 5, 40, &kp);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    zoom_images(q, cq, z, 5, 40, &kq);
  }
  CHECK((p.array() == q.array()).all());
  CHECK(kp == kq);
  int zoomed = 0;
  for (int b = 0; b < B; ++b) {
    const double k = kp[static_cast<size_t>(b)];
    CHECK(cp[b].t.z() == doctest::Approx(cams0[b].t.z() / k));
    CHECK((cp[b].R - cams0[b].R).norm() == 0.0);
    if (k == 1.0) {
      CHECK((p.row(b).array() == src.row(b).array()).all());
      continue;
    }
    ++zoomed;
    CHECK(k >= 0.7 - 1e-12);
    CHECK(k <= std::min(1.6, max_zoom_inside(src.row(b).transpose(), S)) + 1e-12);
    CHECK((p.row(b).transpose() - zoom_image(src.row(b).transpose(), S, k)).norm() == 0.0);
  }
  CHECK(zoomed > 0);
  CHECK(zoomed < B);
  // Off: nothing changes; bad settings and a camera count mismatch are refused.
  ZoomAugmentSettings off;
  MatrixXfR x = src;
  std::vector<Camera> cx = cams0;
  zoom_images(x, cx, off, 5, 0);
  CHECK((x.array() == src.array()).all());
  ZoomAugmentSettings bad = z;
  bad.min = 2;
  CHECK_THROWS_AS(zoom_images(x, cx, bad, 1, 0), InvalidInput);
  cx.pop_back();
  CHECK_THROWS_AS(zoom_images(x, cx, z, 1, 0), InvalidInput);
}

namespace {

/// A render of `mesh` through `cam` as a network row: 3 x S x S channels-first, composited on white.
Eigen::VectorXf render_row(const Mesh& mesh, const Camera& cam) {
  const Image im = render(mesh, cam).rgba;
  const int S = im.width;
  Eigen::VectorXf row(3L * S * S);
  for (int ch = 0; ch < 3; ++ch)
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const float a = im.at(x, y, 3);
        row[(static_cast<Eigen::Index>(ch) * S + y) * S + x] = a * im.at(x, y, ch) + (1 - a);
      }
  return row;
}

}  // namespace

TEST_CASE("zoom_images, focal mode: the zoomed image is the render through the zoomed intrinsics") {
  const int S = 64;
  const Mesh box = make_box(Vec3(-0.45, -0.3, -0.2), Vec3(0.35, 0.4, 0.3));
  // An off-centre principal point shows that c' = k c0 + (1 - k) c, not c0.
  Camera cam = look_at(35, 20, 2.6, S, S);
  cam.K(0, 2) += 1.5;
  cam.K(1, 2) -= 2.0;
  MatrixXfR img(1, 3 * S * S);
  img.row(0) = render_row(box, cam).transpose();
  const MatrixXfR before = img;
  std::vector<Camera> cams = {cam};
  ZoomAugmentSettings z;
  z.prob = 1;
  z.min = z.max = 1.3;
  z.camera = ZoomAugmentSettings::CameraFollow::kFocal;
  std::vector<double> applied;
  zoom_images(img, cams, z, 3, 0, &applied);
  const double k = applied[0];
  REQUIRE(k == doctest::Approx(1.3));
  // Closed form: every point projects to c + k (q - c); R and t are untouched.
  Points X(3, 3);
  X << 0.1, 0.2, -0.3, -0.4, 0.0, 0.25, 0.3, -0.2, 0.1;
  const Pixels q = project_points(cam, X), q2 = project_points(cams[0], X);
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 2; ++a) CHECK(q2(i, a) == doctest::Approx(0.5 * S + k * (q(i, a) - 0.5 * S)).epsilon(1e-12));
  CHECK((cams[0].R - cam.R).norm() == 0.0);
  CHECK((cams[0].t - cam.t).norm() == 0.0);
  // Independent check: rendering through the zoomed camera gives the zoomed image, up to resampling at the edges;
  // the unzoomed render is far from it.
  const Eigen::VectorXf truth = render_row(box, cams[0]);
  const double err = (img.row(0).transpose() - truth).cwiseAbs().mean();
  const double unzoomed = (before.row(0).transpose() - truth).cwiseAbs().mean();
  CHECK(err < 0.15 * unzoomed);
  // The distance mode changes t.z and leaves K as DISN's.
  std::vector<Camera> cd = {cam};
  MatrixXfR img2 = before;
  z.camera = ZoomAugmentSettings::CameraFollow::kDistance;
  zoom_images(img2, cd, z, 3, 0);
  CHECK((cd[0].K - cam.K).norm() == 0.0);
  CHECK(cd[0].t.z() == doctest::Approx(cam.t.z() / k));
  CHECK(z.to_json().dump() == R"({"max":1.3,"min":1.3,"prob":1.0})");
  z.camera = ZoomAugmentSettings::CameraFollow::kFocal;
  CHECK(z.to_json().at("camera") == "focal");
}

TEST_CASE("ink_box: the object's pixel edges, empty for a white image, and the zoom limit agrees with it") {
  const int S = 40;
  Eigen::VectorXf img = Eigen::VectorXf::Ones(3 * S * S);
  CHECK(ink_box(img, S).empty);
  img[2 * S * S + 7 * S + 30] = 0.9f;  // blue channel only, pixel (30, 7)
  img[12 * S + 4] = 0.5f;              // red channel, pixel (4, 12)
  img[S * S + 20 * S + 10] = 0.96f;    // within the ink threshold: background
  const InkBox b = ink_box(img, S);
  REQUIRE(!b.empty);
  CHECK(b.x0 == 4);
  CHECK(b.x1 == 31);
  CHECK(b.y0 == 7);
  CHECK(b.y1 == 13);
  // Farthest edge from the centre 20: x0 = 4 (16 px), so (20 - 1) / 16.
  CHECK(max_zoom_inside(img, S) == doctest::Approx(19.0 / 16.0));
  CHECK_THROWS_AS(ink_box(img, S + 1), InvalidInput);
}

TEST_CASE("reframe_images: the object's box lands at the set size and place, the render through the new camera agrees") {
  const int S = 64;
  const Mesh box = make_box(Vec3(-0.45, -0.3, -0.2), Vec3(0.35, 0.4, 0.3));
  // A small object off the image centre: far camera, principal point moved.
  Camera cam = look_at(35, 20, 4.0, S, S);
  cam.K(0, 2) -= 9.0;
  cam.K(1, 2) += 6.0;
  MatrixXfR img(1, 3 * S * S);
  img.row(0) = render_row(box, cam).transpose();
  const MatrixXfR before = img;
  const InkBox b0 = ink_box(before.row(0).transpose(), S);
  REQUIRE(!b0.empty);
  std::vector<Camera> cams = {cam};
  ReframeAugmentSettings r;
  r.prob = 1;
  r.extent = 0.67;
  r.centre_dx = 0.05;
  r.centre_dy = 0.033;
  std::vector<double> applied;
  std::vector<char> reframed;
  reframe_images(img, cams, r, 3, 0, &applied, &reframed);
  REQUIRE(reframed[0] == 1);
  const double L0 = std::max(b0.x1 - b0.x0, b0.y1 - b0.y0);
  const double k = applied[0];
  CHECK(k == doctest::Approx(r.extent * S / L0).epsilon(1e-12));
  CHECK(k > 1.2);  // the object was small: the test magnifies
  // Closed form: every point projects to d + k (q - m), m the old box centre, d the set place; R, t untouched.
  const double mx = 0.5 * (b0.x0 + b0.x1), my = 0.5 * (b0.y0 + b0.y1);
  const double dx = (0.5 + r.centre_dx) * S, dy = (0.5 + r.centre_dy) * S;
  Points X(3, 3);
  X << 0.1, 0.2, -0.3, -0.4, 0.0, 0.25, 0.3, -0.2, 0.1;
  const Pixels q = project_points(cam, X), q2 = project_points(cams[0], X);
  for (int i = 0; i < 3; ++i) {
    CHECK(q2(i, 0) == doctest::Approx(dx + k * (q(i, 0) - mx)).epsilon(1e-12));
    CHECK(q2(i, 1) == doctest::Approx(dy + k * (q(i, 1) - my)).epsilon(1e-12));
  }
  CHECK((cams[0].R - cam.R).norm() == 0.0);
  CHECK((cams[0].t - cam.t).norm() == 0.0);
  // The new image's object box: longer side extent * S and centre d, to a pixel (edge pixels may fall either side).
  const InkBox b1 = ink_box(img.row(0).transpose(), S);
  CHECK(std::max(b1.x1 - b1.x0, b1.y1 - b1.y0) == doctest::Approx(r.extent * S).epsilon(2.0 / (r.extent * S)));
  CHECK(std::abs(0.5 * (b1.x0 + b1.x1) - dx) <= 1.0);
  CHECK(std::abs(0.5 * (b1.y0 + b1.y1) - dy) <= 1.0);
  // Independent check: the render through the new camera is the reframed image up to resampling at the edges.
  const Eigen::VectorXf truth = render_row(box, cams[0]);
  const double err = (img.row(0).transpose() - truth).cwiseAbs().mean();
  const double unframed = (before.row(0).transpose() - truth).cwiseAbs().mean();
  CHECK(err < 0.15 * unframed);
  // A camera on a finer pixel grid than the network image (width 2 S) moves its principal point in its own pixels.
  Camera fine = cam;
  fine.width = fine.height = 2 * S;
  fine.K(0, 0) *= 2;
  fine.K(1, 1) *= 2;
  fine.K(0, 2) *= 2;
  fine.K(1, 2) *= 2;
  std::vector<Camera> cf = {fine};
  MatrixXfR img2 = before;
  reframe_images(img2, cf, r, 3, 0);
  CHECK(cf[0].K(0, 2) == doctest::Approx(2 * cams[0].K(0, 2)).epsilon(1e-12));
  CHECK(cf[0].K(1, 2) == doctest::Approx(2 * cams[0].K(1, 2)).epsilon(1e-12));
  CHECK(r.to_json().dump() == R"({"centre_dx":0.05,"centre_dy":0.033,"extent":0.67,"prob":1.0})");
}

TEST_CASE("reframe_images: seeded, thread-independent, off and all-white images untouched, bad settings refused") {
  const int S = 21, B = 12;
  MatrixXfR src(B, 3 * S * S);
  for (int b = 0; b < B; ++b) src.row(b) = centred_square(S, 1 + b % 4).transpose();
  src.row(5).setOnes();
  std::vector<Camera> cams0;
  for (int b = 0; b < B; ++b) cams0.push_back(look_at(30.0 * b, 25, 2.5, S, S));
  ReframeAugmentSettings r;
  r.prob = 0.6;
  MatrixXfR p = src, q = src;
  std::vector<Camera> cp = cams0, cq = cams0;
  std::vector<double> kp, kq;
  std::vector<char> fp, fq;
  reframe_images(p, cp, r, 5, 40, &kp, &fp);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    reframe_images(q, cq, r, 5, 40, &kq, &fq);
  }
  CHECK((p.array() == q.array()).all());
  CHECK(kp == kq);
  CHECK(fp == fq);
  CHECK(fp[5] == 0);  // all white: nothing to frame
  int changed = 0;
  for (int b = 0; b < B; ++b) {
    if (!fp[static_cast<size_t>(b)]) {
      CHECK((p.row(b).array() == src.row(b).array()).all());
      CHECK((cp[b].K - cams0[b].K).norm() == 0.0);
      continue;
    }
    ++changed;
    CHECK((p.row(b).array() != src.row(b).array()).any());
  }
  CHECK(changed > 0);
  CHECK(changed < B - 1);
  // Another seed draws other coins; off changes nothing.
  std::vector<char> f2;
  MatrixXfR p2 = src;
  std::vector<Camera> c2 = cams0;
  reframe_images(p2, c2, r, 6, 40, nullptr, &f2);
  CHECK(f2 != fp);
  MatrixXfR x = src;
  std::vector<Camera> cx = cams0;
  reframe_images(x, cx, ReframeAugmentSettings{}, 5, 0);
  CHECK((x.array() == src.array()).all());
  for (const auto& [field, value] : std::vector<std::pair<int, double>>{{0, 1.5}, {1, 0.0}, {1, 1.2}, {2, 0.7}}) {
    ReframeAugmentSettings bad = r;
    (field == 0 ? bad.prob : field == 1 ? bad.extent : bad.centre_dx) = value;
    CHECK_THROWS_AS(reframe_images(x, cx, bad, 1, 0), InvalidInput);
  }
  cx.pop_back();
  CHECK_THROWS_AS(reframe_images(x, cx, r, 1, 0), InvalidInput);
}

TEST_CASE("occlusion augmentation: half removes one side of the object's box, white and masked, seeded") {
  const int S = 40;
  // A grey object spanning columns 10..29 and rows 12..27 on white.
  MatrixXfR images = MatrixXfR::Ones(4, 3 * S * S);
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c)
      for (int y = 12; y < 28; ++y)
        for (int x = 10; x < 30; ++x) images(b, (c * S + y) * S + x) = 0.3f + 0.1f * c;
  const MatrixXfR clean = images;
  OcclusionAugmentSettings st;
  st.kind = OcclusionAugmentSettings::Kind::kHalf;
  st.prob = 1.0;
  MatrixXfR masks, again = images, masks2;
  occlude_images(images, masks, st, 3, 10);
  occlude_images(again, masks2, st, 3, 10);
  CHECK(images == again);  // same (seed, stream): same bytes
  CHECK(masks == masks2);
  REQUIRE(masks.rows() == 4);
  REQUIRE(masks.cols() == S * S);
  int lefts = 0;
  for (int b = 0; b < 4; ++b) {
    // Split at the box's centre column (20): one side is entirely removed (all rows), the other kept.
    const bool left = masks(b, 15 * S + 12) > 0;
    lefts += left;
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const bool removed = masks(b, y * S + x) > 0;
        CHECK(removed == (left ? x < 20 : x >= 20));
        for (int c = 0; c < 3; ++c)
          CHECK(images(b, (c * S + y) * S + x) == (removed ? kNetBackground : clean(b, (c * S + y) * S + x)));
      }
  }
  CHECK(lefts > 0);  // both sides occur over 4 draws with this seed
  CHECK(lefts < 4);
  // Another stream draws other choices; probability 0 and kind none leave the images whole with empty masks.
  MatrixXfR other = clean;
  occlude_images(other, masks2, st, 3, 11);
  CHECK(masks2 != masks);
  st.prob = 0;
  other = clean;
  occlude_images(other, masks2, st, 3, 10);
  CHECK(other == clean);
  CHECK(masks2.isZero());
  st.prob = 1.5;
  CHECK_THROWS_AS(occlude_images(other, masks2, st, 3, 10), InvalidInput);
  // rect: removed pixels form one rectangle overlapping the object.
  st.prob = 1;
  st.kind = OcclusionAugmentSettings::Kind::kRect;
  other = clean;
  occlude_images(other, masks2, st, 5, 0);
  for (int b = 0; b < 4; ++b) {
    const double area = masks2.row(b).sum();
    CHECK(area >= 0.2 * 0.2 * S * S);
    CHECK(area <= 0.5 * 0.5 * S * S + 1);
  }
  CHECK(parse_occlusion_kind("mixed") == OcclusionAugmentSettings::Kind::kMixed);
  CHECK_THROWS_AS(parse_occlusion_kind("quarter"), InvalidInput);
}

TEST_CASE("network_input appends the missing-data mask for an RGB + mask network, drops it for an RGB one") {
  const Eigen::VectorXf rgb = Eigen::VectorXf::LinSpaced(3 * 16, 0.f, 1.f);
  const Eigen::VectorXf mask = Eigen::VectorXf::Constant(16, 1.f);
  CHECK(network_input(rgb, &mask, 3) == rgb);
  const Eigen::VectorXf four = network_input(rgb, &mask, 4);
  REQUIRE(four.size() == 4 * 16);
  CHECK(four.head(48) == rgb);
  CHECK(four.tail(16) == mask);
  CHECK(network_input(rgb, nullptr, 4).tail(16).isZero());
  CHECK_THROWS_AS(network_input(rgb, &mask, 5), InvalidInput);
}

namespace {

/// Side of body_with_leg's images.
constexpr int kLegSide = 40;

/// Six 40 px images: a grey body (columns 10..29, rows 8..23) with a leg 2 px wide (columns 14-15) down to row 35,
/// on white.
MatrixXfR body_with_leg() {
  constexpr int S = kLegSide;
  MatrixXfR images = MatrixXfR::Ones(6, 3 * S * S);
  auto ink = [&](int b, int x, int y) {
    for (int c = 0; c < 3; ++c) images(b, (c * S + y) * S + x) = 0.3f + 0.1f * c;
  };
  for (int b = 0; b < 6; ++b) {
    for (int y = 8; y < 24; ++y)
      for (int x = 10; x < 30; ++x) ink(b, x, y);
    for (int y = 24; y < 36; ++y) ink(b, 14, y), ink(b, 15, y);
  }
  return images;
}

}  // namespace

TEST_CASE("mask-error augmentation: seeded per image, thin parts dropped to white, identity when off") {
  const int S = kLegSide;
  MatrixXfR images = body_with_leg();
  const MatrixXfR clean = images;
  MaskErrorAugmentSettings st;
  st.prob = 1;
  st.error.blob_prob = 0;
  st.error.thin_drop = 1;
  std::vector<char> applied;
  MatrixXfR again = images;
  mask_error_images(images, st, 4, 20, &applied);
  mask_error_images(again, st, 4, 20);
  CHECK(images == again);  // same (seed, stream): same bytes
  REQUIRE(applied.size() == 6);
  for (int b = 0; b < 6; ++b) {
    CHECK(applied[static_cast<size_t>(b)] == 1);
    for (int y = 28; y < 36; ++y)  // the leg below the body's reach of any disc: white
      for (int c = 0; c < 3; ++c) CHECK(images(b, (c * S + y) * S + 14) == kNetBackground);
    for (int c = 0; c < 3; ++c)  // the body's centre: untouched
      CHECK(images(b, (c * S + 16) * S + 20) == clean(b, (c * S + 16) * S + 20));
  }
  // Blobs: another stream and images differ; probability 0 leaves every image as it was.
  st.error.blob_prob = 1;
  MatrixXfR blobs = clean, blobs2 = clean;
  mask_error_images(blobs, st, 4, 20);
  mask_error_images(blobs2, st, 4, 21);
  CHECK(blobs != blobs2);
  st.prob = 0;
  MatrixXfR off = clean;
  mask_error_images(off, st, 4, 20, &applied);
  CHECK(off == clean);
  CHECK(std::count(applied.begin(), applied.end(), 1) == 0);
  st.prob = 2;
  CHECK_THROWS_AS(mask_error_images(off, st, 4, 20), InvalidInput);
  // The end cut is in the recorded settings only when on, so that the states of earlier runs still resume.
  MaskErrorAugmentSettings rec;
  rec.prob = 0.5;
  CHECK_FALSE(rec.to_json().contains("cut"));
  rec.error.cut_prob = 0.25;
  CHECK(rec.to_json()["cut"]["prob"].get<double>() == 0.25);
  // With the cut (and nothing else) every image loses ink, at least 5% of the box's depth at one end, and gains none.
  st.prob = 1;
  st.error.blob_prob = 0;
  st.error.thin_drop = 0;
  st.error.edge_prob = 0;
  st.error.cut_prob = 1;
  MatrixXfR cut = clean;
  mask_error_images(cut, st, 4, 20);
  for (int b = 0; b < 6; ++b) {
    CAPTURE(b);
    long lost = 0, gained = 0;
    for (int i = 0; i < S * S; ++i) {
      lost += clean(b, i) != kNetBackground && cut(b, i) == kNetBackground;
      gained += clean(b, i) == kNetBackground && cut(b, i) != kNetBackground;
    }
    CHECK(lost >= 2);  // the leg's foot (2 px wide), or more
    CHECK(gained == 0);
  }
}

TEST_CASE("ink_mask: 1 on the non-white pixels, 0 on the white ones") {
  const int S = kLegSide;
  const MatrixXfR images = body_with_leg();
  const Eigen::VectorXf m = ink_mask(images.row(0).transpose());
  REQUIRE(m.size() == S * S);
  CHECK(m.sum() == doctest::Approx(20 * 16 + 2 * 12));
  CHECK(m[16 * S + 20] == 1.f);
  CHECK(m[2 * S + 2] == 0.f);
  CHECK(m[30 * S + 14] == 1.f);
}

TEST_CASE("context augmentation: the mask channel is the object's, backgrounds replace only the white pixels") {
  const int S = kLegSide;
  const MatrixXfR clean = body_with_leg();
  const Eigen::VectorXf object = ink_mask(clean.row(0).transpose());
  ContextAugmentSettings st;
  // Off: images untouched, every mask the exact object mask.
  {
    MatrixXfR images = clean, masks;
    std::vector<char> drawn;
    context_images(images, masks, st, nullptr, 3, 10, &drawn);
    CHECK(images == clean);
    REQUIRE(masks.rows() == 6);
    REQUIRE(masks.cols() == S * S);
    for (int b = 0; b < 6; ++b) CHECK(masks.row(b) == object.transpose());
    CHECK(std::count(drawn.begin(), drawn.end(), 1) == 0);
  }
  // Every background drawn (procedural, no photographs): the object's pixels and the mask stay; some white pixels
  // change in every image; seeded per (seed, stream + b), whatever the thread count.
  st.prob = 1;
  MatrixXfR images = clean, masks;
  std::vector<char> drawn;
  context_images(images, masks, st, nullptr, 3, 10, &drawn);
  CHECK(std::count(drawn.begin(), drawn.end(), 1) == 6);
  for (int b = 0; b < 6; ++b) {
    CHECK(masks.row(b) == object.transpose());
    long changed = 0;
    for (int i = 0; i < S * S; ++i)
      for (int c = 0; c < 3; ++c) {
        const float before = clean(b, c * S * S + i), after = images(b, c * S * S + i);
        if (object[i] > 0) CHECK(after == before);
        changed += after != before;
        CHECK(after >= 0.f);
        CHECK(after <= 1.f);
      }
    CHECK(changed > 0);
  }
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    MatrixXfR again = clean, masks_again;
    context_images(again, masks_again, st, nullptr, 3, 10);
    CHECK(again == images);
    CHECK(masks_again == masks);
  }
  // Image b of stream 10 is image b - 1 of stream 11.
  MatrixXfR shifted = clean, masks_shifted;
  context_images(shifted, masks_shifted, st, nullptr, 3, 11);
  for (int b = 1; b < 6; ++b) CHECK(shifted.row(b - 1) == images.row(b));
  CHECK(shifted.row(0) != images.row(0));
  // Out-of-range settings and rows that are not square images are refused.
  st.prob = 1.5;
  CHECK_THROWS_AS(context_images(images, masks, st, nullptr, 3, 10), InvalidInput);
  st.prob = 1;
  MatrixXfR odd = MatrixXfR::Ones(2, 3 * 40 * 39);
  CHECK_THROWS_AS(context_images(odd, masks, st, nullptr, 3, 10), InvalidInput);
}

TEST_CASE("context augmentation: a mask error changes the mask channel only, the pixels keep the whole object") {
  const int S = kLegSide;
  const MatrixXfR clean = body_with_leg();
  const Eigen::VectorXf object = ink_mask(clean.row(0).transpose());
  ContextAugmentSettings st;
  st.mask_error = 1;
  st.error.thin_drop = 1;
  st.error.blob_prob = 0;
  st.error.edge_prob = 0;
  MatrixXfR images = clean, masks;
  context_images(images, masks, st, nullptr, 5, 0);
  CHECK(images == clean);  // no background drawn: the RGB is the white render
  for (int b = 0; b < 6; ++b) {
    for (int i = 0; i < S * S; ++i) CHECK((masks(b, i) == 0.f || masks(b, i) == 1.f));
    for (int y = 28; y < 36; ++y) {  // the leg, below the body's reach: out of the mask, still in the pixels
      CHECK(masks(b, y * S + 14) == 0.f);
      CHECK(images(b, y * S + 14) == clean(b, y * S + 14));
      CHECK(object[y * S + 14] == 1.f);
    }
    CHECK(masks(b, 16 * S + 20) == 1.f);  // the body's centre stays object
  }
  // With blobs the mask also takes in pixels outside the object.
  st.error.blob_prob = 1;
  MatrixXfR with_blobs = clean, blob_masks;
  context_images(with_blobs, blob_masks, st, nullptr, 5, 0);
  long taken_in = 0;
  for (int b = 0; b < 6; ++b)
    for (int i = 0; i < S * S; ++i) taken_in += blob_masks(b, i) > 0 && object[i] == 0;
  CHECK(taken_in > 0);
  CHECK(with_blobs == clean);
}

TEST_CASE("keep_band: pixels within the band's disc of the mask stay, the rest become the background") {
  const int S = 15, n = S * S;
  Eigen::VectorXf mask = Eigen::VectorXf::Zero(n);
  mask[7 * S + 7] = 1.f;   // one pixel: the disc of radius 2 about it has 13 pixels
  mask[0] = 0.4f;          // under 0.5: not object
  Eigen::VectorXf image = Eigen::VectorXf::Constant(2 * n, 0.25f);
  Eigen::VectorXf same = image;
  keep_band(same, 2, mask, 0, 1.f);
  CHECK(same == image);  // band 0: the whole image
  keep_band(image, 2, mask, 2, 1.f);
  int kept = 0;
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const bool in = (x - 7) * (x - 7) + (y - 7) * (y - 7) <= 4;
      for (int c = 0; c < 2; ++c) CHECK(image[c * n + y * S + x] == (in ? 0.25f : 1.f));
      kept += in;
    }
  CHECK(kept == 13);
  CHECK_THROWS_AS(keep_band(image, 3, mask, 2, 1.f), InvalidInput);
}
