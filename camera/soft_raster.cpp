#include "camera/soft_raster.h"

#include "core/error.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace sdfkit {

namespace {

constexpr int kTile = 16;            // pixels per tile side: the unit of parallel work
constexpr double kMinArea = 1e-12;   // doubled projected area (px^2) under which a face is dropped
constexpr double kBlendEps = 1e-10;  // the background's zeta (PyTorch3D's eps)

/// One face seen through the camera: pixel coordinates and camera depths of its corners, doubled signed area.
struct FaceView {
  std::array<double, 3> x{}, y{}, z{};
  double area = 0;
  bool valid = false;
};

/// A vertex's pixel (u, v), camera depth z, and d(u, v, z) / d(object-frame position).
struct VertexView {
  double u = 0, v = 0, z = 0;
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Zero();
};

VertexView view_vertex(const Camera& cam, const Eigen::Vector3d& X) {
  VertexView out;
  const Eigen::Vector3d xc = cam.R * X + cam.t;
  const Eigen::Vector3d h = cam.K * xc;
  out.u = h.x() / h.z();
  out.v = h.y() / h.z();
  out.z = xc.z();
  Eigen::Matrix3d d_cam;  // rows: d u, d v, d z wrt x_cam
  d_cam.row(0) = (cam.K.row(0) - out.u * cam.K.row(2)) / h.z();
  d_cam.row(1) = (cam.K.row(1) - out.v * cam.K.row(2)) / h.z();
  d_cam.row(2) = Eigen::RowVector3d(0, 0, 1);
  out.jacobian = d_cam * cam.R;
  return out;
}

inline double cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

/// Everything about one (pixel, face) pair: barycentrics, inside flag, squared distance to the projection's
/// boundary with its nearest edge (corners e0 -> e1) and the parameter t of the nearest point on it.
struct FragmentGeometry {
  std::array<double, 3> lambda{};  // unclamped barycentrics
  bool inside = false;
  double d2 = 0;
  int e0 = 0, e1 = 1;
  double t = 0;
};

FragmentGeometry fragment_geometry(const FaceView& f, double qx, double qy) {
  FragmentGeometry g;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    g.lambda[static_cast<size_t>(i)] = cross2(f.x[j] - qx, f.y[j] - qy, f.x[k] - qx, f.y[k] - qy) / f.area;
  }
  g.inside = g.lambda[0] >= 0 && g.lambda[1] >= 0 && g.lambda[2] >= 0;
  g.d2 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const double ex = f.x[b] - f.x[a], ey = f.y[b] - f.y[a];
    const double len2 = ex * ex + ey * ey;
    double t = len2 > 0 ? ((qx - f.x[a]) * ex + (qy - f.y[a]) * ey) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double dx = qx - (f.x[a] + t * ex), dy = qy - (f.y[a] + t * ey);
    const double d2 = dx * dx + dy * dy;
    if (d2 < g.d2) {
      g.d2 = d2;
      g.e0 = a;
      g.e1 = b;
      g.t = t;
    }
  }
  return g;
}

inline double sigmoid(double x) { return x >= 0 ? 1.0 / (1.0 + std::exp(-x)) : std::exp(x) / (1.0 + std::exp(x)); }

/// Coverage from the geometry: sigmoid(+d^2 / sigma) inside, sigmoid(-d^2 / sigma) outside.
inline double coverage(const FragmentGeometry& g, double sigma) { return sigmoid((g.inside ? g.d2 : -g.d2) / sigma); }

/// Barycentrics clamped to [0, 1] and renormalised; their sum before renormalising in `sum`.
std::array<double, 3> clamped_barycentrics(const std::array<double, 3>& lambda, double* sum) {
  std::array<double, 3> m{};
  double s = 0;
  for (size_t i = 0; i < 3; ++i) {
    m[i] = std::clamp(lambda[i], 0.0, 1.0);
    s += m[i];
  }
  for (double& v : m) v /= s;
  if (sum) *sum = s;
  return m;
}

/// Faces seen through the camera, and the tiles each one touches.
struct Binning {
  std::vector<FaceView> faces;
  std::vector<std::vector<int32_t>> tiles;  // face indices per tile, increasing
  int tiles_x = 0, tiles_y = 0;
};

Binning bin_faces(const Faces& F, const std::vector<VertexView>& vv, const Camera& cam, const SoftRasterSettings& s) {
  Binning b;
  const int W = cam.width, H = cam.height;
  b.tiles_x = (W + kTile - 1) / kTile;
  b.tiles_y = (H + kTile - 1) / kTile;
  b.tiles.resize(static_cast<size_t>(b.tiles_x) * b.tiles_y);
  b.faces.resize(static_cast<size_t>(F.rows()));
  const double r = s.radius();
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    FaceView& fv = b.faces[static_cast<size_t>(f)];
    bool near_ok = true;
    for (int i = 0; i < 3; ++i) {
      const VertexView& v = vv[static_cast<size_t>(F(f, i))];
      fv.x[static_cast<size_t>(i)] = v.u;
      fv.y[static_cast<size_t>(i)] = v.v;
      fv.z[static_cast<size_t>(i)] = v.z;
      near_ok = near_ok && v.z >= s.near;
    }
    if (!near_ok) continue;
    fv.area = cross2(fv.x[1] - fv.x[0], fv.y[1] - fv.y[0], fv.x[2] - fv.x[0], fv.y[2] - fv.y[0]);
    if (!(std::abs(fv.area) >= kMinArea)) continue;
    fv.valid = true;
    const double x0 = *std::min_element(fv.x.begin(), fv.x.end()) - r, x1 = *std::max_element(fv.x.begin(), fv.x.end()) + r;
    const double y0 = *std::min_element(fv.y.begin(), fv.y.end()) - r, y1 = *std::max_element(fv.y.begin(), fv.y.end()) + r;
    // Pixels whose centre (j + 0.5) lies in [x0, x1].
    const double j0 = std::max(0.0, std::ceil(x0 - 0.5)), j1 = std::min(W - 1.0, std::floor(x1 - 0.5));
    const double i0 = std::max(0.0, std::ceil(y0 - 0.5)), i1 = std::min(H - 1.0, std::floor(y1 - 0.5));
    if (j0 > j1 || i0 > i1) continue;
    for (int ty = static_cast<int>(i0) / kTile; ty <= static_cast<int>(i1) / kTile; ++ty)
      for (int tx = static_cast<int>(j0) / kTile; tx <= static_cast<int>(j1) / kTile; ++tx)
        b.tiles[static_cast<size_t>(ty) * b.tiles_x + tx].push_back(static_cast<int32_t>(f));
  }
  return b;
}

/// The pixel range [lo, hi] of a face's grown bounding box inside one tile's range [t0, t1].
inline bool span(const std::array<double, 3>& c, double r, int t0, int t1, int* lo, int* hi) {
  const double a = *std::min_element(c.begin(), c.end()) - r, b = *std::max_element(c.begin(), c.end()) + r;
  *lo = std::max(t0, static_cast<int>(std::clamp(std::ceil(a - 0.5), -1.0, 1e9)));
  *hi = std::min(t1, static_cast<int>(std::clamp(std::floor(b - 0.5), -1.0, 1e9)));
  return *lo <= *hi;
}

/// camera/render.h's flat shading of a unit camera-frame normal: diffuse = ambient + sum_k I_k max(0, n.l_k),
/// specular = w sum_k [n.l_k > 0] I_k max(0, n.h_k)^shininess with h_k = normalise(l_k - z) (non-local viewer), and
/// their gradients with respect to n.
struct ShadeModel {
  std::vector<Eigen::Vector3d> l, h;
  std::vector<double> intensity;
  double ambient = 0, specular = 0, shininess = 1;

  explicit ShadeModel(const SoftRasterSettings& s) : ambient(s.ambient), specular(s.specular), shininess(s.shininess) {
    for (const Light& light : s.lights) {
      const Eigen::Vector3d d = light.direction.cast<double>().normalized();
      l.push_back(d);
      h.push_back((d + Eigen::Vector3d(0, 0, -1)).normalized());
      intensity.push_back(light.intensity);
    }
  }

  void eval(const Eigen::Vector3d& n, double* diffuse, double* spec, Eigen::Vector3d* d_diffuse,
            Eigen::Vector3d* d_spec) const {
    *diffuse = ambient;
    *spec = 0;
    if (d_diffuse) d_diffuse->setZero();
    if (d_spec) d_spec->setZero();
    for (size_t k = 0; k < l.size(); ++k) {
      const double ndl = n.dot(l[k]);
      if (ndl <= 0) continue;
      *diffuse += intensity[k] * ndl;
      if (d_diffuse) *d_diffuse += intensity[k] * l[k];
      const double ndh = n.dot(h[k]);
      if (ndh <= 0) continue;
      *spec += specular * intensity[k] * std::pow(ndh, shininess);
      if (d_spec) *d_spec += specular * intensity[k] * shininess * std::pow(ndh, shininess - 1) * h[k];
    }
  }
};

/// A face's corners in the camera frame, its unnormalised normal u = (p1 - p0) x (p2 - p0) and the unit normal
/// n = sign u / |u| turned towards the camera (camera/render.h: n.(p0 + p1 + p2) <= 0), (0, 0, -1) when degenerate.
struct FaceNormal {
  Eigen::Vector3d p[3], u, n;
  double length = 0, sign = 1;
};

FaceNormal face_normal(const Points& V, const Faces& F, Eigen::Index f, const Camera& cam) {
  FaceNormal out;
  for (int m = 0; m < 3; ++m) out.p[m] = cam.R * V.row(F(f, m)).transpose() + cam.t;
  out.u = (out.p[1] - out.p[0]).cross(out.p[2] - out.p[0]);
  out.length = out.u.norm();
  if (!(out.length > 0)) {
    out.n = Eigen::Vector3d(0, 0, -1);
    return out;
  }
  out.n = out.u / out.length;
  if (out.n.dot(out.p[0] + out.p[1] + out.p[2]) > 0) {
    out.sign = -1;
    out.n = -out.n;
  }
  return out;
}

/// A fragment's albedo: the face's vertex colours at its clamped barycentrics.
Eigen::Vector3d fragment_albedo(const Points& C, const Faces& F, const SoftRasterCache::Fragment& fr) {
  const auto tri = F.row(fr.face);
  return fr.bary[0] * C.row(tri[0]).transpose() + fr.bary[1] * C.row(tri[1]).transpose() +
         fr.bary[2] * C.row(tri[2]).transpose();
}

}  // namespace

Eigen::Vector3d fragment_colour(const SoftRasterCache& cache, const Points& C, const Faces& F,
                                const SoftRasterCache::Fragment& fr) {
  const Eigen::Vector3d albedo = fragment_albedo(C, F, fr);
  if (cache.shade.empty()) return albedo;
  const size_t f2 = 2 * static_cast<size_t>(fr.face);
  return cache.shade[f2] * albedo + Eigen::Vector3d::Constant(cache.shade[f2 + 1]);
}

double SoftRasterSettings::radius() const { return std::sqrt(sigma * std::log(1.0 / cutoff - 1.0)); }

void validate_soft_raster_settings(const SoftRasterSettings& s) {
  require(std::isfinite(s.sigma) && s.sigma > 0, "soft raster: sigma must be positive");
  require(s.cutoff > 0 && s.cutoff < 0.5, "soft raster: cutoff must be in (0, 0.5)");
  require(std::isfinite(s.gamma) && s.gamma > 0, "soft raster: gamma must be positive");
  require(std::isfinite(s.z_near) && std::isfinite(s.z_far) && s.z_near >= 0 && s.z_near < s.z_far,
          "soft raster: need 0 <= z_near < z_far");
  require(std::isfinite(s.near) && s.near > 0, "soft raster: the near plane must be positive");
  require(s.background.allFinite(), "soft raster: the background colour must be finite");
  require(std::isfinite(s.ambient) && s.ambient >= 0 && std::isfinite(s.specular) && s.specular >= 0 &&
              std::isfinite(s.shininess) && s.shininess >= 1,
          "soft raster: ambient and specular must be >= 0 and shininess >= 1");
  for (const Light& l : s.lights)
    require(l.direction.allFinite() && l.direction.norm() > 0 && std::isfinite(l.intensity) && l.intensity >= 0,
            "soft raster: lights need a non-zero finite direction and a non-negative intensity");
}

SoftRasterizer::SoftRasterizer(Faces faces, SoftRasterSettings settings)
    : faces_(std::move(faces)), settings_(std::move(settings)) {
  validate_soft_raster_settings(settings_);
  require(faces_.rows() > 0, "soft raster: no faces");
  require(faces_.minCoeff() >= 0, "soft raster: negative vertex index");
}

SoftImages SoftRasterizer::render(const Points& V, const Points& C, const Camera& cam, SoftRasterCache* cache) const {
  const SoftRasterSettings& s = settings_;
  require(faces_.maxCoeff() < V.rows(), "soft raster: a face uses vertex " + std::to_string(faces_.maxCoeff() + 1) +
                                            " of " + std::to_string(V.rows()));
  require(V.allFinite(), "soft raster: non-finite vertex positions");
  require(!s.colour || C.rows() == V.rows(), "soft raster: " + std::to_string(C.rows()) + " colours for " +
                                                 std::to_string(V.rows()) + " vertices");
  require(cam.width > 0 && cam.height > 0, "soft raster: empty image");
  const int W = cam.width, H = cam.height;
  std::vector<VertexView> vv(static_cast<size_t>(V.rows()));
  tbb::parallel_for(Eigen::Index(0), V.rows(), [&](Eigen::Index i) {
    vv[static_cast<size_t>(i)] = view_vertex(cam, V.row(i).transpose());
  });
  const Binning bin = bin_faces(faces_, vv, cam, s);
  const double r = s.radius(), r2 = r * r;

  // Fragments per tile, grouped by pixel (faces in index order within a pixel).
  struct TileFragments {
    std::vector<int32_t> pixel;  // pixel index of each fragment
    std::vector<SoftRasterCache::Fragment> frags;
  };
  std::vector<TileFragments> tf(bin.tiles.size());
  tbb::parallel_for(size_t(0), bin.tiles.size(), [&](size_t t) {
    const int tx = static_cast<int>(t) % bin.tiles_x, ty = static_cast<int>(t) / bin.tiles_x;
    const int x0 = tx * kTile, x1 = std::min(W, x0 + kTile) - 1, y0 = ty * kTile, y1 = std::min(H, y0 + kTile) - 1;
    std::vector<std::vector<SoftRasterCache::Fragment>> per_pixel(static_cast<size_t>((x1 - x0 + 1) * (y1 - y0 + 1)));
    for (const int32_t f : bin.tiles[t]) {
      const FaceView& fv = bin.faces[static_cast<size_t>(f)];
      int jx0 = 0, jx1 = 0, iy0 = 0, iy1 = 0;
      if (!span(fv.x, r, x0, x1, &jx0, &jx1) || !span(fv.y, r, y0, y1, &iy0, &iy1)) continue;
      for (int i = iy0; i <= iy1; ++i)
        for (int j = jx0; j <= jx1; ++j) {
          const FragmentGeometry g = fragment_geometry(fv, j + 0.5, i + 0.5);
          if (!g.inside && g.d2 > r2) continue;
          SoftRasterCache::Fragment fr;
          fr.face = f;
          fr.p = coverage(g, s.sigma);
          const std::array<double, 3> lc = clamped_barycentrics(g.lambda, nullptr);
          fr.z = lc[0] * fv.z[0] + lc[1] * fv.z[1] + lc[2] * fv.z[2];
          std::copy(lc.begin(), lc.end(), fr.bary);
          per_pixel[static_cast<size_t>((i - y0) * (x1 - x0 + 1) + (j - x0))].push_back(fr);
        }
    }
    TileFragments& out = tf[t];
    for (int i = y0; i <= y1; ++i)
      for (int j = x0; j <= x1; ++j)
        for (const auto& fr : per_pixel[static_cast<size_t>((i - y0) * (x1 - x0 + 1) + (j - x0))]) {
          out.pixel.push_back(i * W + j);
          out.frags.push_back(fr);
        }
  });

  // Pixel-major layout: offsets from the per-pixel counts, then each tile copies its own pixels' fragments.
  SoftRasterCache local;
  SoftRasterCache& c = cache ? *cache : local;
  c.camera = cam;
  c.offsets.assign(static_cast<size_t>(W) * H + 1, 0);
  for (const TileFragments& t : tf)
    for (const int32_t p : t.pixel) ++c.offsets[static_cast<size_t>(p) + 1];
  for (size_t k = 1; k < c.offsets.size(); ++k) c.offsets[k] += c.offsets[k - 1];
  c.fragments.resize(static_cast<size_t>(c.offsets.back()));
  tbb::parallel_for(size_t(0), tf.size(), [&](size_t t) {
    int64_t at = -1;
    int32_t last = -1;
    for (size_t k = 0; k < tf[t].pixel.size(); ++k) {
      const int32_t p = tf[t].pixel[k];
      if (p != last) {
        at = c.offsets[static_cast<size_t>(p)];
        last = p;
      }
      c.fragments[static_cast<size_t>(at++)] = tf[t].frags[k];
    }
  });

  c.shade.clear();
  if (s.colour && s.lit) {
    const ShadeModel model(s);
    c.shade.resize(static_cast<size_t>(faces_.rows()) * 2);
    tbb::parallel_for(Eigen::Index(0), faces_.rows(), [&](Eigen::Index f) {
      const FaceNormal fn = face_normal(V, faces_, f, cam);
      model.eval(fn.n, &c.shade[2 * static_cast<size_t>(f)], &c.shade[2 * static_cast<size_t>(f) + 1], nullptr,
                 nullptr);
    });
  }

  SoftImages out;
  out.alpha = Image(W, H, 1, 0.0f);
  if (s.colour) out.rgb = Image(W, H, 3, 0.0f);
  c.background_weight.assign(static_cast<size_t>(W) * H, 0.0);
  const double zrange = s.z_far - s.z_near;
  tbb::parallel_for(0, H, [&](int i) {
    for (int j = 0; j < W; ++j) {
      const size_t k = static_cast<size_t>(i) * W + j;
      const int64_t a = c.offsets[k], b = c.offsets[k + 1];
      double transmit = 1;
      for (int64_t q = a; q < b; ++q) transmit *= 1 - c.fragments[static_cast<size_t>(q)].p;
      out.alpha.at(j, i) = static_cast<float>(1 - transmit);
      if (!s.colour) continue;
      double zmax = kBlendEps;
      for (int64_t q = a; q < b; ++q) zmax = std::max(zmax, (s.z_far - c.fragments[static_cast<size_t>(q)].z) / zrange);
      const double wb = std::exp((kBlendEps - zmax) / s.gamma);
      c.background_weight[k] = wb;
      double den = wb;
      Eigen::Vector3d num = wb * s.background;
      for (int64_t q = a; q < b; ++q) {
        SoftRasterCache::Fragment& fr = c.fragments[static_cast<size_t>(q)];
        const double zeta = (s.z_far - fr.z) / zrange;
        fr.weight = fr.p * std::exp((zeta - zmax) / s.gamma);
        num += fr.weight * fragment_colour(c, C, faces_, fr);
        den += fr.weight;
      }
      for (int ch = 0; ch < 3; ++ch) out.rgb.at(j, i, ch) = static_cast<float>(num[ch] / den);
    }
  });
  if (cache) {
    c.V = V;
    if (s.colour) c.C = C;
  }
  return out;
}

void SoftRasterizer::backward(const SoftRasterCache& c, const Image& d_alpha, const Image& d_rgb, Points& dV,
                              Points& dC, bool rgb_to_positions) const {
  const SoftRasterSettings& s = settings_;
  const Camera& cam = c.camera;
  const int W = cam.width, H = cam.height;
  require(d_alpha.width == W && d_alpha.height == H && d_alpha.channels == 1,
          "soft raster backward: d_alpha must be a 1-channel image of the forward's size");
  const bool rgb = !d_rgb.empty();
  require(!rgb || (s.colour && d_rgb.width == W && d_rgb.height == H && d_rgb.channels == 3),
          "soft raster backward: d_rgb must be empty or a 3-channel image of the forward's size (colour on)");
  const Eigen::Index nv = c.V.rows();
  if (dV.rows() != nv) dV = Points::Zero(nv, 3);
  if (dC.rows() != nv) dC = Points::Zero(nv, 3);
  if (c.fragments.empty()) return;

  std::vector<VertexView> vv(static_cast<size_t>(nv));
  tbb::parallel_for(Eigen::Index(0), nv, [&](Eigen::Index i) {
    vv[static_cast<size_t>(i)] = view_vertex(cam, c.V.row(i).transpose());
  });
  // Per fragment: d loss / d (x, y, z) of its face's three corners and d loss / d their colours.
  struct FragmentGrad {
    double xyz[3][3];
    double col[3][3];
    double shade[2];  // lit: d loss / d the face's diffuse factor and specular term
  };
  const bool lit = rgb && !c.shade.empty();
  const bool rgb_pos = rgb && rgb_to_positions;  // the colour term's gradient also reaches the positions
  const bool shade_pos = lit && rgb_to_positions;  // through the shading (face normals)
  std::vector<FragmentGrad> fg(c.fragments.size());
  const double zrange = s.z_far - s.z_near;
  tbb::parallel_for(0, H, [&](int i) {
    std::vector<double> prefix, suffix;
    for (int j = 0; j < W; ++j) {
      const size_t k = static_cast<size_t>(i) * W + j;
      const int64_t a = c.offsets[k], b = c.offsets[k + 1];
      const size_t n = static_cast<size_t>(b - a);
      if (n == 0) continue;
      const SoftRasterCache::Fragment* fr = c.fragments.data() + a;
      // d alpha / d p_f = prod over the other fragments of (1 - p): prefix and suffix products, no division.
      prefix.assign(n + 1, 1.0);
      suffix.assign(n + 1, 1.0);
      for (size_t q = 0; q < n; ++q) prefix[q + 1] = prefix[q] * (1 - fr[q].p);
      for (size_t q = n; q-- > 0;) suffix[q] = suffix[q + 1] * (1 - fr[q].p);
      const double ga = d_alpha.at(j, i);
      Eigen::Vector3d gc = Eigen::Vector3d::Zero(), pix = Eigen::Vector3d::Zero();
      double den = 0;
      if (rgb) {
        gc = Eigen::Vector3d(d_rgb.at(j, i, 0), d_rgb.at(j, i, 1), d_rgb.at(j, i, 2));
        den = c.background_weight[k];
        pix = den * s.background;
      }
      // The fragments' colours and the blended pixel only feed the colour term's position gradient.
      std::vector<Eigen::Vector3d> colours(rgb_pos ? n : 0);
      if (rgb) {
        for (size_t q = 0; q < n; ++q) {
          if (rgb_pos) {
            colours[q] = fragment_colour(c, c.C, faces_, fr[q]);
            pix += fr[q].weight * colours[q];
          }
          den += fr[q].weight;
        }
        pix /= den;
      }
      for (size_t q = 0; q < n; ++q) {
        const SoftRasterCache::Fragment& f = fr[q];
        FragmentGrad& g = fg[static_cast<size_t>(a) + q];
        std::fill(&g.xyz[0][0], &g.xyz[0][0] + 9, 0.0);
        std::fill(&g.col[0][0], &g.col[0][0] + 9, 0.0);
        g.shade[0] = g.shade[1] = 0;
        double gp = ga * prefix[q] * suffix[q + 1];
        std::array<double, 3> glc{};  // d loss / d clamped barycentrics
        const auto tri = faces_.row(f.face);
        const FaceView fv = [&] {
          FaceView v;
          for (int m = 0; m < 3; ++m) {
            const VertexView& x = vv[static_cast<size_t>(tri[m])];
            v.x[static_cast<size_t>(m)] = x.u;
            v.y[static_cast<size_t>(m)] = x.v;
            v.z[static_cast<size_t>(m)] = x.z;
          }
          v.area = cross2(v.x[1] - v.x[0], v.y[1] - v.y[0], v.x[2] - v.x[0], v.y[2] - v.y[0]);
          return v;
        }();
        if (rgb) {
          const double gw = rgb_pos ? gc.dot(colours[q] - pix) / den : 0.0;
          // weight = p exp((zeta - zmax) / gamma): d/dp = weight / p, d/dzeta = weight / gamma.
          gp += gw * (f.weight / f.p);
          const double gz = -gw * f.weight / s.gamma / zrange;
          const Eigen::Vector3d gshaded = gc * (f.weight / den);  // d loss / d the fragment's colour
          // Lit: colour = diffuse * albedo + specular, albedo = sum_m bary_m C_m.
          double diffuse = 1;
          if (lit) diffuse = c.shade[2 * static_cast<size_t>(f.face)];
          if (shade_pos) {
            g.shade[0] = gshaded.dot(fragment_albedo(c.C, faces_, f));
            g.shade[1] = gshaded.sum();
          }
          const Eigen::Vector3d gcol = gshaded * diffuse;  // d loss / d the fragment's albedo
          for (int m = 0; m < 3; ++m) {
            for (int ch = 0; ch < 3; ++ch) g.col[m][ch] += gcol[ch] * f.bary[m];
            if (!rgb_pos) continue;
            glc[static_cast<size_t>(m)] += gcol.dot(c.C.row(tri[m]).transpose()) + gz * fv.z[static_cast<size_t>(m)];
            g.xyz[m][2] += gz * f.bary[m];
          }
        }
        const FragmentGeometry geo = fragment_geometry(fv, j + 0.5, i + 0.5);
        // p = sigmoid(+-d2 / sigma): d p / d d2 = +-p (1 - p) / sigma.
        const double gd2 = gp * f.p * (1 - f.p) / s.sigma * (geo.inside ? 1.0 : -1.0);
        if (gd2 != 0) {
          // d2 = |q - (a + t (b - a))|^2 at the optimal t (envelope): d/da = -2 (1 - t) diff, d/db = -2 t diff.
          const double ex = fv.x[static_cast<size_t>(geo.e1)] - fv.x[static_cast<size_t>(geo.e0)];
          const double ey = fv.y[static_cast<size_t>(geo.e1)] - fv.y[static_cast<size_t>(geo.e0)];
          const double dx = j + 0.5 - (fv.x[static_cast<size_t>(geo.e0)] + geo.t * ex);
          const double dy = i + 0.5 - (fv.y[static_cast<size_t>(geo.e0)] + geo.t * ey);
          g.xyz[geo.e0][0] += gd2 * -2 * (1 - geo.t) * dx;
          g.xyz[geo.e0][1] += gd2 * -2 * (1 - geo.t) * dy;
          g.xyz[geo.e1][0] += gd2 * -2 * geo.t * dx;
          g.xyz[geo.e1][1] += gd2 * -2 * geo.t * dy;
        }
        if (rgb_pos) {
          // Clamp and renormalise: lc = m / M, m = clamp(lambda, 0, 1); d lc_i = (d m_i - lc_i d M) / M.
          double M = 0;
          clamped_barycentrics(geo.lambda, &M);
          double dot = 0;
          for (size_t m = 0; m < 3; ++m) dot += glc[m] * f.bary[m];
          std::array<double, 3> gl{};
          for (size_t m = 0; m < 3; ++m)
            gl[m] = (geo.lambda[m] > 0 && geo.lambda[m] < 1) ? (glc[m] - dot) / M : 0.0;
          // lambda_m = A_m / A with A_m = cross(p_{m+1} - q, p_{m+2} - q), A = cross(p1 - p0, p2 - p0):
          // d lambda_m = (d A_m - lambda_m d A) / A.
          double sl = 0;
          for (size_t m = 0; m < 3; ++m) sl += gl[m] * geo.lambda[m];
          const double qx = j + 0.5, qy = i + 0.5;
          for (int m = 0; m < 3; ++m) {
            if (gl[static_cast<size_t>(m)] == 0) continue;
            const int u = (m + 1) % 3, w = (m + 2) % 3;
            // cross(a, b) = ax by - ay bx: d/da = (by, -bx), d/db = (-ay, ax); a = p_u - q, b = p_w - q.
            const double ax = fv.x[static_cast<size_t>(u)] - qx, ay = fv.y[static_cast<size_t>(u)] - qy;
            const double bx = fv.x[static_cast<size_t>(w)] - qx, by = fv.y[static_cast<size_t>(w)] - qy;
            const double s_m = gl[static_cast<size_t>(m)] / fv.area;
            g.xyz[u][0] += s_m * by;
            g.xyz[u][1] += s_m * -bx;
            g.xyz[w][0] += s_m * -ay;
            g.xyz[w][1] += s_m * ax;
          }
          if (sl != 0) {
            const double sa = -sl / fv.area;
            // A = cross(e1, e2), e1 = p1 - p0, e2 = p2 - p0.
            const double e1x = fv.x[1] - fv.x[0], e1y = fv.y[1] - fv.y[0], e2x = fv.x[2] - fv.x[0],
                         e2y = fv.y[2] - fv.y[0];
            g.xyz[1][0] += sa * e2y;
            g.xyz[1][1] += sa * -e2x;
            g.xyz[2][0] += sa * -e1y;
            g.xyz[2][1] += sa * e1x;
            g.xyz[0][0] += sa * (-e2y + e1y);
            g.xyz[0][1] += sa * (e2x - e1x);
          }
        }
      }
    }
  });

  // Fragments to vertices in a fixed order: the same sums for any thread count.
  std::vector<Eigen::Vector3d> gview(static_cast<size_t>(nv), Eigen::Vector3d::Zero());
  std::vector<double> gshade(shade_pos ? c.shade.size() : 0, 0.0);
  for (size_t q = 0; q < c.fragments.size(); ++q) {
    const auto tri = faces_.row(c.fragments[q].face);
    if (shade_pos) {
      gshade[2 * static_cast<size_t>(c.fragments[q].face)] += fg[q].shade[0];
      gshade[2 * static_cast<size_t>(c.fragments[q].face) + 1] += fg[q].shade[1];
    }
    for (int m = 0; m < 3; ++m) {
      Eigen::Vector3d& v = gview[static_cast<size_t>(tri[m])];
      for (int a = 0; a < 3; ++a) v[a] += fg[q].xyz[m][a];
      if (rgb)
        for (int ch = 0; ch < 3; ++ch) dC(tri[m], ch) += fg[q].col[m][ch];
    }
  }
  for (Eigen::Index v = 0; v < nv; ++v)
    dV.row(v) += (vv[static_cast<size_t>(v)].jacobian.transpose() * gview[static_cast<size_t>(v)]).transpose();
  if (!shade_pos) return;
  // Shading to positions through the face normals: per face in parallel, then summed per vertex in face order.
  const ShadeModel model(s);
  std::vector<std::array<Eigen::Vector3d, 3>> gface(static_cast<size_t>(faces_.rows()));
  tbb::parallel_for(Eigen::Index(0), faces_.rows(), [&](Eigen::Index f) {
    auto& out = gface[static_cast<size_t>(f)];
    out.fill(Eigen::Vector3d::Zero());
    const double gd = gshade[2 * static_cast<size_t>(f)], gs = gshade[2 * static_cast<size_t>(f) + 1];
    if (gd == 0 && gs == 0) return;
    const FaceNormal fn = face_normal(c.V, faces_, f, cam);
    if (!(fn.length > 0)) return;
    double diffuse = 0, spec = 0;
    Eigen::Vector3d dd, ds;
    model.eval(fn.n, &diffuse, &spec, &dd, &ds);
    const Eigen::Vector3d gn = gd * dd + gs * ds;
    // n = sign u / |u|: d n = sign (I - n n^T) d u / |u| (the sign squares away in n n^T).
    const Eigen::Vector3d gu = fn.sign * (gn - fn.n * fn.n.dot(gn)) / fn.length;
    // u = (p1 - p0) x (p2 - p0): d/d p1 = (p2 - p0) x gu, d/d p2 = gu x (p1 - p0), d/d p0 = -(both).
    out[1] = (fn.p[2] - fn.p[0]).cross(gu);
    out[2] = gu.cross(fn.p[1] - fn.p[0]);
    out[0] = -(out[1] + out[2]);
  });
  std::vector<Eigen::Vector3d> gcam(static_cast<size_t>(nv), Eigen::Vector3d::Zero());
  for (Eigen::Index f = 0; f < faces_.rows(); ++f)
    for (int m = 0; m < 3; ++m) gcam[static_cast<size_t>(faces_(f, m))] += gface[static_cast<size_t>(f)][m];
  for (Eigen::Index v = 0; v < nv; ++v) dV.row(v) += (cam.R.transpose() * gcam[static_cast<size_t>(v)]).transpose();
}

}  // namespace sdfkit
