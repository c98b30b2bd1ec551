#include "camera/soft_raster.h"

#include "camera/render.h"
#include "camera/silhouette.h"
#include "core/error.h"
#include "core/primitives.h"
#include "core/random.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace sdfkit;

namespace {

/// An icosphere with its vertices pushed in and out (seeded), and random vertex colours.
Mesh bumpy_sphere(int levels, uint64_t seed) {
  Mesh m = make_icosphere(Vec3(0.05, -0.02, 0.03), 0.8, levels);
  Rng rng(seed);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) m.V.row(i) *= 1.0 + 0.15 * rng.uniform(-1, 1);
  return m;
}

Points random_colours(Eigen::Index n, uint64_t seed) {
  Rng rng(seed);
  Points C(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) C(i, c) = rng.uniform(0.1, 0.9);
  return C;
}

/// A fixed random linear loss on the images: sum of w_alpha * alpha + sum of w_rgb * rgb.
struct LinearLoss {
  Image wa, wc;
  LinearLoss(int W, int H, uint64_t seed) : wa(W, H, 1), wc(W, H, 3) {
    Rng rng(seed);
    for (float& v : wa.data) v = static_cast<float>(rng.uniform(-1, 1));
    for (float& v : wc.data) v = static_cast<float>(rng.uniform(-1, 1));
  }
  double operator()(const SoftImages& im) const {
    double l = 0;
    for (size_t k = 0; k < im.alpha.data.size(); ++k) l += double(wa.data[k]) * im.alpha.data[k];
    for (size_t k = 0; k < im.rgb.data.size(); ++k) l += double(wc.data[k]) * im.rgb.data[k];
    return l;
  }
};

/// Images kept in double for finite differences: the float images round at 1e-7, too coarse for h = 1e-5.
double loss_in_double(const SoftRasterizer& r, const Points& V, const Points& C, const Camera& cam,
                      const LinearLoss& L) {
  SoftRasterCache cache;
  (void)r.render(V, C, cam, &cache);
  // Recompute alpha and rgb in double from the cache (the same formulas as render()).
  const SoftRasterSettings& s = r.settings();
  double l = 0;
  const int W = cam.width, H = cam.height;
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < W; ++j) {
      const size_t k = static_cast<size_t>(i) * W + j;
      double transmit = 1, den = cache.background_weight[k];
      Eigen::Vector3d num = den * s.background;
      for (int64_t q = cache.offsets[k]; q < cache.offsets[k + 1]; ++q) {
        const auto& f = cache.fragments[static_cast<size_t>(q)];
        transmit *= 1 - f.p;
        num += f.weight * fragment_colour(cache, C, r.faces(), f);
        den += f.weight;
      }
      l += L.wa.at(j, i) * (1 - transmit);
      for (int c = 0; c < 3; ++c) l += L.wc.at(j, i, c) * num[c] / den;
    }
  return l;
}

}  // namespace

TEST_CASE("soft raster: gradients to positions and colours match central differences, unlit and lit") {
  for (const bool lit : {false, true}) {
    CAPTURE(lit);
    const Mesh m = bumpy_sphere(1, 7);
    const Points C = random_colours(m.V.rows(), 8);
    Camera cam = look_at(30, 25, 2.6, 40, 40);
    SoftRasterSettings s;
    s.sigma = 2.0;     // wide edges: many fragments carry gradient
    s.gamma = 0.05;    // soft depth blending: occluded faces carry gradient too
    s.z_near = 1.0;
    s.z_far = 5.0;
    s.cutoff = 1e-9;
    s.lit = lit;
    s.shininess = 3;  // a broad highlight: many faces carry a specular gradient
    const SoftRasterizer r(m.F, s);
    const LinearLoss L(cam.width, cam.height, 9);
    SoftRasterCache cache;
    (void)r.render(m.V, C, cam, &cache);
    Points dV, dC;
    r.backward(cache, L.wa, L.wc, dV, dC);
    const double h = 1e-6;
    int checked = 0;
    double worst = 0;
    for (Eigen::Index v = 0; v < m.V.rows(); ++v)
      for (int a = 0; a < 3; ++a) {
        Points Vp = m.V, Vm = m.V;
        Vp(v, a) += h;
        Vm(v, a) -= h;
        const double fd = (loss_in_double(r, Vp, C, cam, L) - loss_in_double(r, Vm, C, cam, L)) / (2 * h);
        worst = std::max(worst, std::abs(fd - dV(v, a)) / std::max(1.0, std::abs(fd)));
        ++checked;
        Points Cp = C, Cm = C;
        Cp(v, a) += h;
        Cm(v, a) -= h;
        const double fdc = (loss_in_double(r, m.V, Cp, cam, L) - loss_in_double(r, m.V, Cm, cam, L)) / (2 * h);
        CHECK(dC(v, a) == doctest::Approx(fdc).epsilon(1e-5).scale(1.0));
      }
    CHECK(checked == 3 * m.V.rows());
    CHECK(worst < 1e-4);
    CHECK(dV.norm() > 1.0);  // the check is not vacuous
    // The colour term kept off the positions: dV is the alpha term's alone, dC the whole colour gradient.
    Points dV_alpha, dC_none, dV_split, dC_split;
    r.backward(cache, L.wa, Image(), dV_alpha, dC_none);
    r.backward(cache, L.wa, L.wc, dV_split, dC_split, false);
    CHECK((dV_split.array() == dV_alpha.array()).all());
    CHECK((dC_split.array() == dC.array()).all());
    CHECK((dV_split - dV).norm() > 1e-3 * dV.norm());
    CHECK(dC_none.norm() == 0);
  }
}

TEST_CASE("soft raster: lit, the sharp limit is camera/render's flat Lambert + Blinn-Phong shading") {
  const Mesh m = bumpy_sphere(2, 4);
  const Camera cam = look_at(40, 30, 2.7, 56, 56);
  RenderSettings rs;
  rs.supersampling = 1;  // the pixel centre's face, as the sharp soft render
  const RenderResult ref = render(m, cam, rs);
  SoftRasterSettings s;
  s.sigma = 1e-7;
  s.gamma = 1e-6;
  s.z_near = 0;
  s.z_far = 10;
  s.lit = true;
  const Points C = Points::Zero(m.V.rows(), 3).rowwise() + rs.default_color.cast<double>().transpose();
  const SoftImages im = SoftRasterizer(m.F, s).render(m.V, C, cam);
  SoftRasterSettings unlit = s;
  unlit.lit = false;
  const SoftImages flat = SoftRasterizer(m.F, unlit).render(m.V, C, cam);
  int inside = 0, agree = 0, shaded = 0;
  for (int i = 0; i < cam.height; ++i)
    for (int j = 0; j < cam.width; ++j) {
      if (ref.rgba.at(j, i, 3) < 1 || im.alpha.at(j, i) < 0.999) continue;
      ++inside;
      bool same = true;
      for (int c = 0; c < 3; ++c) same = same && std::abs(im.rgb.at(j, i, c) - ref.rgba.at(j, i, c)) < 2e-3;
      agree += same;
      shaded += std::abs(flat.rgb.at(j, i, 0) - im.rgb.at(j, i, 0)) > 0.02;
    }
  CHECK(inside > 1000);
  CHECK(agree >= 0.99 * inside);  // pixel centres within 1e-3 px of an edge may pick the neighbouring face
  CHECK(shaded > 0.5 * inside);   // and the shading is not the albedo
}

TEST_CASE("soft raster: the sharp limit is the pixel-centre silhouette, the nearest face gives the colour") {
  // Two boxes, the red one in front of the green one from this camera.
  Mesh a = make_box(Vec3(-0.3, -0.3, -0.3), Vec3(0.3, 0.3, 0.3));
  const Mesh b = make_box(Vec3(-0.6, -0.15, -0.9), Vec3(0.1, 0.25, -0.5));
  const Camera cam = look_at(0, 20, 2.5, 48, 48);  // camera on +z: a (z up to 0.3) is nearer than b
  Mesh both;
  both.V.resize(a.V.rows() + b.V.rows(), 3);
  both.V << a.V, b.V;
  both.F.resize(a.F.rows() + b.F.rows(), 3);
  both.F << a.F, (b.F.array() + static_cast<int32_t>(a.V.rows())).matrix();
  Points C(both.V.rows(), 3);
  for (Eigen::Index i = 0; i < C.rows(); ++i) C.row(i) = i < a.V.rows() ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  SoftRasterSettings s;
  s.sigma = 1e-7;
  s.gamma = 1e-6;
  s.z_near = 0;
  s.z_far = 10;
  const SoftImages im = SoftRasterizer(both.F, s).render(both.V, C, cam);
  const Image sharp = render_silhouette(both, cam, 1);
  const Image sharp_a = render_silhouette(a, cam, 1);
  int differ = 0, covered = 0, red = 0;
  for (int i = 0; i < cam.height; ++i)
    for (int j = 0; j < cam.width; ++j) {
      const bool in = sharp.at(j, i) > 0.5;
      covered += in;
      differ += in != (im.alpha.at(j, i) > 0.5);
      if (sharp_a.at(j, i) > 0.5 && im.alpha.at(j, i) > 0.999) {
        CHECK(im.rgb.at(j, i, 0) == doctest::Approx(1.0).epsilon(1e-6));
        CHECK(im.rgb.at(j, i, 1) == doctest::Approx(0.0).epsilon(1e-6).scale(1));
        ++red;
      }
      if (!in) CHECK(im.rgb.at(j, i, 2) == doctest::Approx(1.0).epsilon(1e-3));  // white background
    }
  CHECK(covered > 200);
  CHECK(red > 100);
  CHECK(differ == 0);
}

TEST_CASE("soft raster: the same bytes for any thread count, faces touch only their neighbourhood") {
  const Mesh m = bumpy_sphere(3, 2);
  const Points C = random_colours(m.V.rows(), 3);
  const Camera cam = look_at(70, 30, 2.7, 64, 64);
  const SoftRasterizer r(m.F);
  SoftRasterCache c1, c2;
  const SoftImages a = r.render(m.V, C, cam, &c1);
  Points dV1, dC1, dV2, dC2;
  const LinearLoss L(64, 64, 4);
  r.backward(c1, L.wa, L.wc, dV1, dC1);
  SoftImages b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = r.render(m.V, C, cam, &c2);
    r.backward(c2, L.wa, L.wc, dV2, dC2);
  }
  CHECK(a.alpha.data == b.alpha.data);
  CHECK(a.rgb.data == b.rgb.data);
  CHECK((dV1.array() == dV2.array()).all());
  CHECK((dC1.array() == dC2.array()).all());
  // Faces meet only the pixels near their projection: a dozen fragments per pixel, not the 1280 faces.
  const double per_pixel = double(c1.fragments.size()) / (64.0 * 64.0);
  CHECK(per_pixel < 0.02 * double(m.F.rows()));
  CHECK(per_pixel > 0.5);
  for (const auto& f : c1.fragments) CHECK(f.p >= r.settings().cutoff * 0.999);
}

TEST_CASE("soft raster: bad settings and inputs are refused") {
  const Mesh m = make_icosphere(Vec3::Zero(), 1, 1);
  SoftRasterSettings s;
  s.sigma = 0;
  CHECK_THROWS_AS(SoftRasterizer(m.F, s), InvalidInput);
  s = {};
  s.cutoff = 0.7;
  CHECK_THROWS_AS(SoftRasterizer(m.F, s), InvalidInput);
  s = {};
  s.shininess = 0.5;
  CHECK_THROWS_WITH_AS(SoftRasterizer(m.F, s), "soft raster: ambient and specular must be >= 0 and shininess >= 1",
                       InvalidInput);
  s = {};
  s.lights[1].direction.setZero();
  CHECK_THROWS_WITH_AS(SoftRasterizer(m.F, s),
                       "soft raster: lights need a non-zero finite direction and a non-negative intensity",
                       InvalidInput);
  const SoftRasterizer r(m.F);
  const Camera cam = look_at(0, 0, 3, 16, 16);
  CHECK_THROWS_AS((void)r.render(m.V.topRows(3), Points::Zero(3, 3), cam), InvalidInput);
  CHECK_THROWS_AS((void)r.render(m.V, Points::Zero(2, 3), cam), InvalidInput);
  Points bad = m.V;
  bad(0, 0) = std::nan("");
  CHECK_THROWS_AS((void)r.render(bad, Points::Zero(m.V.rows(), 3), cam), InvalidInput);
  SoftRasterCache c;
  (void)r.render(m.V, Points::Zero(m.V.rows(), 3), cam, &c);
  Points dV, dC;
  CHECK_THROWS_AS(r.backward(c, Image(8, 8, 1), Image(), dV, dC), InvalidInput);
}
