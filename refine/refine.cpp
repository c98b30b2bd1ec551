#include "refine/refine.h"

#include "camera/silhouette.h"
#include "core/error.h"
#include "core/mesh_io.h"
#include "core/primitives.h"
#include "core/random.h"
#include "nets/layers.h"
#include "refine/regularisers.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numeric>

namespace fs = std::filesystem;

namespace sdfkit {

namespace {

/// An RGB image as a 1 x 3 x H x W tensor.
Tensor chw_of(const Image& rgb) {
  Tensor t({1, 3, rgb.height, rgb.width});
  const int64_t plane = int64_t(rgb.width) * rgb.height;
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x)
      for (int c = 0; c < 3; ++c) t[c * plane + int64_t(y) * rgb.width + x] = rgb.at(x, y, c);
  return t;
}

/// RGB images of one size as N x 3 x H x W.
void stack_chw(const std::vector<Image>& images, Tensor& out) {
  std::vector<Tensor> one;
  std::vector<const Tensor*> ptrs;
  for (const Image& im : images) one.push_back(chw_of(im));
  for (const Tensor& t : one) ptrs.push_back(&t);
  concat(ptrs, 0, out);
}

}  // namespace

std::vector<TargetView> read_target_views(const std::string& dir, const Eigen::Vector3d& background,
                                          const std::vector<std::string>& only) {
  if (!fs::is_directory(dir)) throw IoError(dir + ": not a folder of views (NN.png + NN.json)");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    const fs::path& p = e.path();
    if (p.extension() != ".json" || p.filename() == "norm.json") continue;
    if (!fs::exists(fs::path(dir) / (p.stem().string() + ".png"))) continue;
    names.push_back(p.stem().string());
  }
  std::sort(names.begin(), names.end());
  if (!only.empty()) {
    for (const std::string& n : only)
      if (!std::binary_search(names.begin(), names.end(), n))
        throw IoError(dir + ": no view '" + n + "' (" + n + ".json with " + n + ".png)");
    names = only;
  }
  if (names.empty()) throw IoError(dir + ": no views (NN.json with NN.png beside it)");
  std::vector<TargetView> out;
  for (const std::string& n : names) {
    const std::string png = (fs::path(dir) / (n + ".png")).string();
    TargetView v;
    v.name = n;
    v.camera = read_camera((fs::path(dir) / (n + ".json")).string());
    const Image im = read_image(png);
    if (im.channels != 4)
      throw IoError(png + ": " + std::to_string(im.channels) +
                    " channels; refine needs RGBA views (the alpha is the silhouette)");
    if (im.width != v.camera.width || im.height != v.camera.height)
      throw IoError(png + ": " + std::to_string(im.width) + " x " + std::to_string(im.height) +
                    " pixels, its camera says " + std::to_string(v.camera.width) + " x " +
                    std::to_string(v.camera.height));
    v.alpha = Image(im.width, im.height, 1);
    v.rgb = Image(im.width, im.height, 3);
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) {
        const float a = im.at(x, y, 3);
        v.alpha.at(x, y) = a;
        for (int c = 0; c < 3; ++c)
          v.rgb.at(x, y, c) = a * im.at(x, y, c) + (1 - a) * static_cast<float>(background[c]);
      }
    out.push_back(std::move(v));
  }
  return out;
}

RefineSettings paper_loss(RefineSettings s) {
  s.exact_silhouette = 0;
  s.w_edge = 1;
  s.w_laplacian = 1;
  s.rgb_moves_vertices = true;
  return s;
}

bool colour_moves_vertices(const RefineSettings& s) { return s.rgb_moves_vertices || s.w_adversarial > 0; }

long exact_silhouette_from(const RefineSettings& s) { return s.exact_after >= 0 ? s.exact_after : s.iters * 3 / 4; }

long lit_from(const RefineSettings& s) {
  if (!s.lit) return -1;
  return s.exact_silhouette > 0 ? exact_silhouette_from(s) : 0;
}

void validate_refine_settings(const RefineSettings& s) {
  require(s.iters >= 0, "refine: --iters must be >= 0");
  require(s.views_per_step >= 1, "refine: --views-per-step must be at least 1");
  require(std::isfinite(s.lr) && s.lr > 0, "refine: the learning rate must be positive");
  require(std::isfinite(s.momentum) && s.momentum >= 0 && s.momentum < 1, "refine: momentum must be in [0, 1)");
  for (const double w : {s.w_silhouette, s.w_rgb, s.w_edge, s.w_normal, s.w_laplacian})
    require(std::isfinite(w) && w >= 0, "refine: loss weights must be finite and non-negative");
  require(s.log_every >= 1, "refine: log_every must be at least 1");
  require(std::isfinite(s.w_adversarial) && s.w_adversarial >= 0, "refine: the adversarial weight must be >= 0");
  require(s.critic.size >= 16, "refine: the critic's input must be at least 16 px");
  require(s.exact_silhouette >= 0 && s.exact_silhouette <= 8, "refine: the exact silhouette's supersampling must be in 0..8");
  require(s.exact_after >= -1, "refine: the soft steps before the exact silhouette must be >= 0 (or -1: three quarters)");
  require(!s.lit || s.w_rgb > 0, "refine: shading (lit) needs the RGB term (w_rgb > 0)");
  require(!s.raster.lit, "refine: ask for shading with RefineSettings::lit (refine schedules it), not raster.lit");
  validate_soft_raster_settings(s.raster);
}

Mesh subdivide_midpoints(const Mesh& mesh, const Points& colours, Points* finer_colours) {
  require(colours.rows() == 0 || colours.rows() == mesh.V.rows(), "subdivide: one colour per vertex, or none");
  std::map<std::pair<int32_t, int32_t>, int32_t> mid;
  std::vector<Vec3> V;
  std::vector<Vec3> C;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    V.push_back(mesh.V.row(i).transpose());
    if (colours.rows()) C.push_back(colours.row(i).transpose());
  }
  const auto midpoint = [&](int32_t a, int32_t b) {
    const auto key = std::minmax(a, b);
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const auto id = static_cast<int32_t>(V.size());
    V.push_back(0.5 * (V[static_cast<size_t>(a)] + V[static_cast<size_t>(b)]));
    if (colours.rows()) C.push_back(0.5 * (C[static_cast<size_t>(a)] + C[static_cast<size_t>(b)]));
    mid.emplace(key, id);
    return id;
  };
  Mesh out;
  out.F.resize(4 * mesh.F.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int32_t a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2);
    const int32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.F.row(4 * f) << a, ab, ca;
    out.F.row(4 * f + 1) << ab, b, bc;
    out.F.row(4 * f + 2) << ca, bc, c;
    out.F.row(4 * f + 3) << ab, bc, ca;
  }
  out.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) out.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  if (finer_colours) {
    finer_colours->resize(static_cast<Eigen::Index>(C.size()), 3);
    for (size_t i = 0; i < C.size(); ++i) finer_colours->row(static_cast<Eigen::Index>(i)) = C[i].transpose();
  }
  return out;
}

Mesh refine_sphere(int levels, double radius) {
  Mesh m = make_icosphere(Vec3::Zero(), radius, levels);
  m.colors = Colors::Constant(m.V.rows(), 3, 0.5f);
  return m;
}

SoftImages render_for_view(const Mesh& mesh, const TargetView& view, const SoftRasterSettings& raster) {
  Points C = mesh.has_colors() ? Points(mesh.colors.cast<double>()) : Points(Points::Constant(mesh.V.rows(), 3, 0.5));
  return SoftRasterizer(mesh.F, raster).render(mesh.V, C, view.camera);
}

RefineResult refine_mesh(const std::vector<TargetView>& views, const Mesh& init, const RefineSettings& s,
                         const std::function<void(const RefineRow&)>& on_row) {
  validate_refine_settings(s);
  require(!views.empty(), "refine: no target views");
  const Mesh start = validate_mesh(init, "refine: initial mesh");
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&t0] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  SoftRasterSettings raster = s.raster;
  const bool adversarial = s.w_adversarial > 0;
  raster.colour = s.w_rgb > 0 || adversarial;
  SoftRasterSettings lit_raster = raster;
  lit_raster.lit = true;
  Faces F = start.F;
  // The unlit rasteriser of the steps before shading starts, and the shaded one of the steps after (lit only).
  auto rasterizer = std::make_unique<SoftRasterizer>(F, raster);
  auto shaded = s.lit ? std::make_unique<SoftRasterizer>(F, lit_raster) : nullptr;
  const long shading_from = lit_from(s);
  MeshTopology topo = mesh_topology(F, start.V.rows());
  double lr = s.lr;
  Points V = start.V;
  Points C = start.has_colors() ? Points(start.colors.cast<double>()) : Points(Points::Constant(V.rows(), 3, 0.5));
  Points mV = Points::Zero(V.rows(), 3), mC = Points::Zero(V.rows(), 3);  // momentum buffers

  // The critic and the targets at its resolution (N = 1 x 3 x S x S each).
  std::unique_ptr<Critic> critic;
  const int S = s.critic.size;
  const BilinearResize<float> to_critic(S, S, false);
  std::vector<Tensor> real_small(views.size());
  if (adversarial) {
    critic = std::make_unique<Critic>(s.critic, Rng::derived(s.seed, 0xc417cULL).next());
    for (size_t v = 0; v < views.size(); ++v) to_critic.forward(chw_of(views[v].rgb), real_small[v]);
  }
  const int nviews = static_cast<int>(views.size());
  const int k = std::min(s.views_per_step, nviews);
  const long exact_after = exact_silhouette_from(s);
  std::vector<int> order(static_cast<size_t>(nviews));
  RefineResult res;
  long step = 0;
  for (; step < s.iters; ++step) {
    // The step's views: the first k of a seeded shuffle (Fisher-Yates on a generator of (seed, step)).
    std::iota(order.begin(), order.end(), 0);
    Rng rng = Rng::derived(s.seed, static_cast<uint64_t>(step));
    for (int i = 0; i < k; ++i) std::swap(order[static_cast<size_t>(i)], order[static_cast<size_t>(i) + rng.below(static_cast<uint64_t>(nviews - i))]);

    Points gV = Points::Zero(V.rows(), 3), gC = Points::Zero(V.rows(), 3);
    const bool lit = shading_from >= 0 && step >= shading_from;
    if (lit && step == shading_from && s.uniform_albedo) {
      // One albedo from here on: the mean of the colours fitted so far (unlit, they hold the shading's mean too).
      C.rowwise() = Eigen::RowVector3d(C.colwise().mean());
      mC.setZero();
    }
    SoftRasterizer& raster_now = lit ? *shaded : *rasterizer;
    RefineRow row;
    row.step = step + 1;
    std::vector<SoftRasterCache> caches(static_cast<size_t>(k));
    std::vector<Image> d_alpha(static_cast<size_t>(k)), d_rgb(static_cast<size_t>(k)), rendered(static_cast<size_t>(k));
    // The exact silhouettes of the step's views (single-threaded renders, so one view per task).
    std::vector<Image> exact;
    if (s.exact_silhouette > 0 && step >= exact_after) {
      Mesh m;
      m.V = V;
      m.F = F;
      const SilhouetteRenderer sharp(m, s.exact_silhouette);
      exact.resize(static_cast<size_t>(k));
      tbb::parallel_for(0, k, [&](int i) {
        exact[static_cast<size_t>(i)] = sharp.render(views[static_cast<size_t>(order[static_cast<size_t>(i)])].camera);
      });
    }
    for (int i = 0; i < k; ++i) {
      const TargetView& tv = views[static_cast<size_t>(order[static_cast<size_t>(i)])];
      SoftRasterCache& cache = caches[static_cast<size_t>(i)];
      const SoftImages im = raster_now.render(V, C, tv.camera, &cache);
      rendered[static_cast<size_t>(i)] = im.rgb;
      const double npx = static_cast<double>(tv.camera.width) * tv.camera.height;
      Image da(tv.camera.width, tv.camera.height, 1), dc;
      double sil = 0, rgb = 0;
      // Loss per view: w_s mean (alpha - target)^2 + w_rgb mean (rgb - target)^2; the step's: their mean over views.
      // With the exact silhouette, alpha is its coverage and the soft silhouette's gradient carries the residual.
      const Image& alpha = exact.empty() ? im.alpha : exact[static_cast<size_t>(i)];
      for (size_t q = 0; q < da.data.size(); ++q) {
        const double e = double(alpha.data[q]) - tv.alpha.data[q];
        sil += e * e;
        da.data[q] = static_cast<float>(s.w_silhouette * 2 * e / (npx * k));
      }
      if (raster.colour) {
        dc = Image(tv.camera.width, tv.camera.height, 3);
        for (size_t q = 0; q < dc.data.size(); ++q) {
          const double e = double(im.rgb.data[q]) - tv.rgb.data[q];
          rgb += e * e;
          // Shaded, the error reaches the positions only where both silhouettes cover the pixel fully: its
          // contours are the silhouette term's (the soft colour image shares the soft alpha's dilation).
          const size_t p = q / 3;
          const bool inside = tv.alpha.data[p] >= 1.0f && alpha.data[p] >= 0.999f;
          if (!lit || inside) dc.data[q] = static_cast<float>(s.w_rgb * 2 * e / (3 * npx * k));
          else dc.data[q] = 0;
        }
      }
      if (adversarial && dc.empty()) dc = Image(tv.camera.width, tv.camera.height, 3);
      d_alpha[static_cast<size_t>(i)] = std::move(da);
      d_rgb[static_cast<size_t>(i)] = std::move(dc);
      row.silhouette += sil / npx / k;
      row.rgb += rgb / (3 * npx) / k;
    }
    if (adversarial) {
      // The generator's term with the critic as it is, then one critic step on the same real and rendered images.
      Tensor fake, fake_small, real, logits, dlogits, dsmall, dfake;
      stack_chw(rendered, fake);
      to_critic.forward(fake, fake_small);
      std::vector<const Tensor*> reals;
      for (int i = 0; i < k; ++i) reals.push_back(&real_small[static_cast<size_t>(order[static_cast<size_t>(i)])]);
      concat(reals, 0, real);
      critic->forward(fake_small, logits);
      row.adversarial = critic_loss(logits, 1.0f, &dlogits);
      for (float& g : dlogits.data) g *= static_cast<float>(s.w_adversarial);
      critic->backward(fake_small, logits, dlogits, &dsmall);
      critic->zero_grad();  // the generator's pass trains nothing in the critic
      to_critic.backward(fake, fake_small, dsmall, &dfake);
      for (int i = 0; i < k; ++i) {
        Image& dc = d_rgb[static_cast<size_t>(i)];
        const int64_t plane = int64_t(dc.width) * dc.height;
        for (int y = 0; y < dc.height; ++y)
          for (int x = 0; x < dc.width; ++x)
            for (int c = 0; c < 3; ++c)
              dc.at(x, y, c) += dfake.item(i)[c * plane + int64_t(y) * dc.width + x];
      }
      critic->forward(real, logits);
      row.critic = critic_loss(logits, 1.0f, &dlogits);
      critic->backward(real, logits, dlogits, nullptr);
      critic->forward(fake_small, logits);
      row.critic += critic_loss(logits, 0.0f, &dlogits);
      critic->backward(fake_small, logits, dlogits, nullptr);
      critic->step();
    }
    // Otherwise the silhouette moves the vertices and the colour term only the colours (shaded: also the vertices,
    // from the pixels inside both silhouettes).
    for (int i = 0; i < k; ++i)
      raster_now.backward(caches[static_cast<size_t>(i)], d_alpha[static_cast<size_t>(i)], d_rgb[static_cast<size_t>(i)],
                          gV, gC, colour_moves_vertices(s) || lit);
    if (lit && s.uniform_albedo) gC.rowwise() = Eigen::RowVector3d(gC.colwise().sum());  // the shared albedo's
    row.edge = edge_length_loss(V, topo, s.w_edge, gV);
    row.normal = normal_consistency_loss(V, F, topo, s.w_normal, gV);
    row.laplacian = laplacian_loss(V, topo, s.w_laplacian, gV);
    row.loss = s.w_silhouette * row.silhouette + s.w_rgb * row.rgb + s.w_edge * row.edge + s.w_normal * row.normal +
               s.w_laplacian * row.laplacian + s.w_adversarial * row.adversarial;
    if (!std::isfinite(row.loss) || !gV.allFinite() || !gC.allFinite())
      throw Error("refine: the loss or its gradient became non-finite at step " + std::to_string(step + 1));
    mV = s.momentum * mV + gV;
    mC = s.momentum * mC + gC;
    V -= lr * mV;
    C -= lr * mC;
    if (std::find(s.subdivide_at.begin(), s.subdivide_at.end(), step + 1) != s.subdivide_at.end()) {
      // Coarse to fine: every face into four, fresh momentum, the learning rate scaled as asked.
      Mesh m;
      m.V = V;
      m.F = F;
      m.colors = C.cast<float>();
      Points finer_colours;
      const Mesh finer = subdivide_midpoints(m, C, &finer_colours);
      V = finer.V;
      F = finer.F;
      C = finer_colours;
      mV = Points::Zero(V.rows(), 3);
      mC = Points::Zero(V.rows(), 3);
      rasterizer = std::make_unique<SoftRasterizer>(F, raster);
      if (s.lit) shaded = std::make_unique<SoftRasterizer>(F, lit_raster);
      topo = mesh_topology(F, V.rows());
      lr *= s.subdivide_lr_factor;
    }
    const bool out_of_time = s.time_limit_seconds > 0 && elapsed() >= s.time_limit_seconds;
    if ((step + 1) % s.log_every == 0 || step + 1 == s.iters || out_of_time) {
      row.seconds = elapsed();
      res.curve.push_back(row);
      if (on_row) on_row(row);
    }
    if (out_of_time) {
      ++step;
      break;
    }
  }
  res.steps = step;
  res.seconds = elapsed();
  res.seconds_per_step = res.steps > 0 ? res.seconds / static_cast<double>(res.steps) : 0;
  res.mesh.V = V;
  res.mesh.F = F;
  res.mesh.colors = C.cwiseMax(0.0).cwiseMin(1.0).cast<float>();
  return res;
}

Image refine_preview_sheet(const std::vector<TargetView>& views, const std::vector<int>& which, const Mesh& mesh,
                           const SoftRasterSettings& raster) {
  require(!which.empty(), "refine preview: no views chosen");
  int W = 0, H = 0;
  for (const int i : which) {
    require(i >= 0 && i < static_cast<int>(views.size()), "refine preview: view index out of range");
    W += views[static_cast<size_t>(i)].camera.width;
    H = std::max(H, views[static_cast<size_t>(i)].camera.height);
  }
  Image sheet(W, 2 * H, 3, 1.0f);
  int x0 = 0;
  SoftRasterSettings r = raster;
  r.colour = true;
  for (const int i : which) {
    const TargetView& tv = views[static_cast<size_t>(i)];
    const SoftImages im = render_for_view(mesh, tv, r);
    for (int y = 0; y < tv.camera.height; ++y)
      for (int x = 0; x < tv.camera.width; ++x) {
        const float a = im.alpha.at(x, y);
        for (int c = 0; c < 3; ++c) {
          sheet.at(x0 + x, y, c) = tv.rgb.at(x, y, c);
          sheet.at(x0 + x, H + y, c) = a * im.rgb.at(x, y, c) + (1 - a);
        }
      }
    x0 += tv.camera.width;
  }
  return sheet;
}

}  // namespace sdfkit
