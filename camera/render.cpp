#include "camera/render.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

namespace sdfkit {

std::vector<Light> default_light_rig() {
  return {{Eigen::Vector3f(-0.45f, -0.6f, -0.66f).normalized(), 0.55f},
          {Eigen::Vector3f(0.7f, -0.1f, -0.7f).normalized(), 0.25f},
          {Eigen::Vector3f(0.0f, -1.0f, 0.15f).normalized(), 0.15f}};
}

namespace {

constexpr int64_t kSub = 256;          // fixed-point steps per sample
constexpr double kGuard = 1 << 19;     // guard band, in samples, beyond which triangles are clipped
constexpr int kTile = 32;              // tile side in samples

int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

struct RasterTri {
  int32_t X[3], Y[3];  // fixed-point sample coordinates (|.| <= 2^28), counter-clockwise: area2 > 0
  double iz[3];        // 1 / z_cam per vertex
  int64_t area2;
  int x0, x1, y0, y1;  // inclusive sample bounding box, clipped to the image
  int face;
};

struct ViewSetup {
  int s, W, H;                      // supersampling and sample-grid size
  Eigen::Matrix3d K;
  std::vector<double> xc;           // camera-frame vertices, #V x 3
  std::vector<RasterTri> tris;
  std::vector<float> shade;         // per face: diffuse factor, specular term
  std::vector<float> normal;        // per face: camera-frame normal (when requested)
};

/// Fixed-point sample coordinates of a camera-frame point in front of the camera (rounded to nearest, ties to
/// even: llrint under the default rounding mode, the same on every IEEE machine).
inline void to_fixed(const ViewSetup& v, const Eigen::Vector3d& p, int32_t& X, int32_t& Y, double& iz) {
  const Eigen::Vector3d h = v.K * p;
  const double scale = v.s * kSub / h.z();
  X = static_cast<int32_t>(std::lrint(h.x() * scale));
  Y = static_cast<int32_t>(std::lrint(h.y() * scale));
  iz = 1.0 / p.z();
}

/// Orientation, area and sample bounding box of a fixed-point triangle; false when it covers no sample centre.
inline bool finish_tri(const ViewSetup& v, int face, RasterTri& t) {
  const int64_t min_x = std::min({t.X[0], t.X[1], t.X[2]}), max_x = std::max({t.X[0], t.X[1], t.X[2]});
  const int64_t min_y = std::min({t.Y[0], t.Y[1], t.Y[2]}), max_y = std::max({t.Y[0], t.Y[1], t.Y[2]});
  // Sample j is centred at j * kSub + kSub / 2.
  t.x0 = static_cast<int>(std::max<int64_t>(0, ceil_div(min_x - kSub / 2, kSub)));
  t.x1 = static_cast<int>(std::min<int64_t>(v.W - 1, floor_div(max_x - kSub / 2, kSub)));
  if (t.x0 > t.x1) return false;
  t.y0 = static_cast<int>(std::max<int64_t>(0, ceil_div(min_y - kSub / 2, kSub)));
  t.y1 = static_cast<int>(std::min<int64_t>(v.H - 1, floor_div(max_y - kSub / 2, kSub)));
  if (t.y0 > t.y1) return false;
  int64_t a = (int64_t(t.X[1]) - t.X[0]) * (int64_t(t.Y[2]) - t.Y[0]) -
              (int64_t(t.Y[1]) - t.Y[0]) * (int64_t(t.X[2]) - t.X[0]);
  if (a == 0) return false;
  if (a < 0) {  // two-sided: reorder instead of culling
    std::swap(t.X[1], t.X[2]);
    std::swap(t.Y[1], t.Y[2]);
    std::swap(t.iz[1], t.iz[2]);
    a = -a;
  }
  t.area2 = a;
  t.face = face;
  return true;
}

/// Fixed-point triangle from three camera-frame points in front of the camera and inside the guard band.
bool make_tri(const ViewSetup& v, const Eigen::Vector3d* p, int face, RasterTri& t) {
  for (int k = 0; k < 3; ++k) to_fixed(v, p[k], t.X[k], t.Y[k], t.iz[k]);
  return finish_tri(v, face, t);
}

/// Sutherland-Hodgman clipping of a camera-frame polygon against the near plane and the guard band.
int clip_polygon(const ViewSetup& v, double near, std::array<Eigen::Vector3d, 16>& poly, int n) {
  const double s = v.s;
  const Eigen::Vector3d k0 = v.K.row(0).transpose() * s, k1 = v.K.row(1).transpose() * s;
  // Plane functions phi(x) >= 0 keep x.
  const std::array<Eigen::Vector4d, 5> planes = {
      Eigen::Vector4d(0, 0, 1, -near),                                    // z >= near
      Eigen::Vector4d(k0.x(), k0.y(), k0.z() + kGuard, 0),                // sx >= -G
      Eigen::Vector4d(-k0.x(), -k0.y(), -k0.z() + kGuard, 0),             // sx <= G
      Eigen::Vector4d(k1.x(), k1.y(), k1.z() + kGuard, 0),                // sy >= -G
      Eigen::Vector4d(-k1.x(), -k1.y(), -k1.z() + kGuard, 0)};            // sy <= G
  std::array<Eigen::Vector3d, 16> out;
  for (const auto& pl : planes) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d& a = poly[i];
      const Eigen::Vector3d& b = poly[(i + 1) % n];
      const double da = pl.head<3>().dot(a) + pl[3], db = pl.head<3>().dot(b) + pl[3];
      if (da >= 0) out[m++] = a;
      if ((da >= 0) != (db >= 0) && m < 16) out[m++] = a + (b - a) * (da / (da - db));
    }
    n = std::min(m, 15);
    for (int i = 0; i < n; ++i) poly[i] = out[i];
    if (n < 3) return 0;
  }
  return n;
}

}  // namespace

MeshRenderer::MeshRenderer(const Mesh& mesh, RenderSettings settings) : settings_(std::move(settings)) {
  require(!mesh.empty(), "render: empty mesh");
  require(settings_.supersampling >= 1 && settings_.supersampling <= 8, "render: supersampling must be in 1..8");
  require(std::isfinite(settings_.ambient) && settings_.ambient >= 0 && std::isfinite(settings_.specular) &&
              settings_.specular >= 0 && std::isfinite(settings_.shininess) && settings_.shininess > 0,
          "render: ambient, specular must be >= 0 and shininess > 0");
  require(settings_.default_color.allFinite(), "render: non-finite default colour");
  require(std::isfinite(settings_.near) && settings_.near > 0, "render: near plane must be positive");
  for (auto& l : settings_.lights) {
    require(l.direction.allFinite() && l.direction.norm() > 0 && std::isfinite(l.intensity) && l.intensity >= 0,
            "render: lights need a non-zero finite direction and a non-negative intensity");
    l.direction.normalize();
  }
  const Eigen::Index nv = mesh.V.rows(), nf = mesh.F.rows();
  V_.resize(static_cast<size_t>(nv) * 3);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      const double x = mesh.V(i, k);
      require(std::isfinite(x), "render: mesh has non-finite vertex coordinates");
      V_[3 * i + k] = static_cast<float>(x);
    }
  F_.resize(static_cast<size_t>(nf) * 3);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int32_t idx = mesh.F(f, k);
      require(idx >= 0 && idx < nv, "render: face index out of range");
      F_[3 * f + k] = idx;
    }
  if (mesh.has_colors()) {
    C_.resize(static_cast<size_t>(nv) * 3);
    for (Eigen::Index i = 0; i < nv; ++i)
      for (int k = 0; k < 3; ++k) C_[3 * i + k] = std::clamp(std::isfinite(mesh.colors(i, k)) ? mesh.colors(i, k) : 0.0f, 0.0f, 1.0f);
  }
}

RenderResult MeshRenderer::render(const Camera& cam) const {
  validate_camera(cam, "render");
  const RenderSettings& st = settings_;
  ViewSetup v;
  v.s = st.supersampling;
  v.W = cam.width * v.s;
  v.H = cam.height * v.s;
  v.K = cam.K;
  const size_t nv = V_.size() / 3, nf = F_.size() / 3;

  // 1. Vertices to the camera frame and to fixed-point sample coordinates; flag those that need no clipping.
  v.xc.resize(nv * 3);
  std::vector<uint8_t> inside(nv);
  std::vector<int32_t> vx(nv), vy(nv);
  std::vector<double> viz(nv);
  const Eigen::Matrix3d& R = cam.R;
  for (size_t i = 0; i < nv; ++i) {
    const Eigen::Vector3d x(V_[3 * i], V_[3 * i + 1], V_[3 * i + 2]);
    const Eigen::Vector3d c = R * x + cam.t;
    v.xc[3 * i] = c.x();
    v.xc[3 * i + 1] = c.y();
    v.xc[3 * i + 2] = c.z();
    bool ok = c.z() >= st.near;
    if (ok) {
      const Eigen::Vector3d h = cam.K * c;
      const double sx = v.s * h.x() / h.z(), sy = v.s * h.y() / h.z();
      ok = std::abs(sx) <= kGuard && std::abs(sy) <= kGuard;
      if (ok) to_fixed(v, c, vx[i], vy[i], viz[i]);
    }
    inside[i] = ok;
  }
  auto vert = [&](int32_t i) { return Eigen::Vector3d(v.xc[3 * i], v.xc[3 * i + 1], v.xc[3 * i + 2]); };

  // 2. Triangle setup in face order (deterministic). Faces that end up visible are shaded after rasterisation.
  v.tris.reserve(nf + 16);
  for (size_t f = 0; f < nf; ++f) {
    const int32_t a = F_[3 * f], b = F_[3 * f + 1], c = F_[3 * f + 2];
    if (inside[a] && inside[b] && inside[c]) {
      RasterTri t;
      t.X[0] = vx[a], t.X[1] = vx[b], t.X[2] = vx[c];
      t.Y[0] = vy[a], t.Y[1] = vy[b], t.Y[2] = vy[c];
      t.iz[0] = viz[a], t.iz[1] = viz[b], t.iz[2] = viz[c];
      if (finish_tri(v, static_cast<int>(f), t)) v.tris.push_back(t);
    } else {
      const Eigen::Vector3d p[3] = {vert(a), vert(b), vert(c)};
      if (p[0].z() < st.near && p[1].z() < st.near && p[2].z() < st.near) continue;
      std::array<Eigen::Vector3d, 16> poly;
      poly[0] = p[0];
      poly[1] = p[1];
      poly[2] = p[2];
      const int n = clip_polygon(v, st.near, poly, 3);
      for (int k = 1; k + 1 < n; ++k) {
        const Eigen::Vector3d q[3] = {poly[0], poly[k], poly[k + 1]};
        RasterTri t;
        if (make_tri(v, q, static_cast<int>(f), t)) v.tris.push_back(t);
      }
    }
  }

  // 3. Bin triangles to tiles, keeping face order inside each tile.
  const int tx_n = (v.W + kTile - 1) / kTile, ty_n = (v.H + kTile - 1) / kTile;
  std::vector<int> tile_start(static_cast<size_t>(tx_n) * ty_n + 1, 0);
  for (const RasterTri& t : v.tris)
    for (int ty = t.y0 / kTile; ty <= t.y1 / kTile; ++ty)
      for (int tx = t.x0 / kTile; tx <= t.x1 / kTile; ++tx) ++tile_start[ty * tx_n + tx + 1];
  for (size_t i = 1; i < tile_start.size(); ++i) tile_start[i] += tile_start[i - 1];
  std::vector<int> tile_tris(static_cast<size_t>(tile_start.back()));
  {
    std::vector<int> fill(tile_start.begin(), tile_start.end() - 1);
    for (size_t i = 0; i < v.tris.size(); ++i) {
      const RasterTri& t = v.tris[i];
      for (int ty = t.y0 / kTile; ty <= t.y1 / kTile; ++ty)
        for (int tx = t.x0 / kTile; tx <= t.x1 / kTile; ++tx) tile_tris[fill[ty * tx_n + tx]++] = static_cast<int>(i);
    }
  }

  // 4. Rasterise tiles in parallel: each tile owns its samples.
  const size_t ns = static_cast<size_t>(v.W) * v.H;
  std::vector<float> zbuf(ns, 0.0f);     // 1 / z, 0 = empty (visible samples have 1/z > 0)
  std::vector<int32_t> fbuf(ns, -1);     // face index
  tbb::parallel_for(tbb::blocked_range<int>(0, tx_n * ty_n, 1), [&](const tbb::blocked_range<int>& range) {
    for (int tile = range.begin(); tile < range.end(); ++tile) {
      const int tx = tile % tx_n, ty = tile / tx_n;
      const int bx0 = tx * kTile, bx1 = std::min(v.W, bx0 + kTile) - 1;
      const int by0 = ty * kTile, by1 = std::min(v.H, by0 + kTile) - 1;
      for (int k = tile_start[tile]; k < tile_start[tile + 1]; ++k) {
        const RasterTri& t = v.tris[tile_tris[k]];
        const int x0 = std::max(t.x0, bx0), x1 = std::min(t.x1, bx1);
        const int y0 = std::max(t.y0, by0), y1 = std::min(t.y1, by1);
        if (x0 > x1 || y0 > y1) continue;
        // Edge i is opposite vertex i: from vertex (i+1)%3 to (i+2)%3.
        // e_row holds E_i - bias_i, so "inside" is all three >= 0; bias_i re-enters the depth as c_bias.
        int64_t e_row[3], step_x[3], step_y[3];
        double c[3], c_bias = 0;
        const double inv_area = 1.0 / static_cast<double>(t.area2);
        const int64_t px = x0 * kSub + kSub / 2, py = y0 * kSub + kSub / 2;
        for (int i = 0; i < 3; ++i) {
          const int a = (i + 1) % 3, b = (i + 2) % 3;
          const int64_t dx = int64_t(t.X[b]) - t.X[a], dy = int64_t(t.Y[b]) - t.Y[a];
          // Top-left rule: an edge owns its samples when it runs upwards, or exactly rightwards. The same edge
          // traversed the other way (by the neighbouring triangle) does not, so shared edges are drawn once.
          const int64_t bias = (dy < 0 || (dy == 0 && dx > 0)) ? 0 : 1;
          e_row[i] = dx * (py - t.Y[a]) - dy * (px - t.X[a]) - bias;
          step_x[i] = -dy * kSub;
          step_y[i] = dx * kSub;
          c[i] = t.iz[i] * inv_area;
          c_bias += static_cast<double>(bias) * c[i];
        }
        for (int y = y0; y <= y1; ++y) {
          int64_t e0 = e_row[0], e1 = e_row[1], e2 = e_row[2];
          float* zrow = zbuf.data() + static_cast<size_t>(y) * v.W;
          int32_t* frow = fbuf.data() + static_cast<size_t>(y) * v.W;
          for (int x = x0; x <= x1; ++x) {
            if ((e0 | e1 | e2) >= 0) {
              const float iz = static_cast<float>(static_cast<double>(e0) * c[0] + static_cast<double>(e1) * c[1] +
                                                  static_cast<double>(e2) * c[2] + c_bias);
              if (iz > zrow[x]) {
                zrow[x] = iz;
                frow[x] = t.face;
              }
            }
            e0 += step_x[0];
            e1 += step_x[1];
            e2 += step_x[2];
          }
          for (int i = 0; i < 3; ++i) e_row[i] += step_y[i];
        }
      }
    }
  });

  // 5. Shade the faces that won at least one sample (flat normal, turned towards the camera).
  std::vector<uint8_t> seen(nf, 0);
  for (const int32_t f : fbuf)
    if (f >= 0) seen[static_cast<size_t>(f)] = 1;
  v.shade.resize(nf * 2);
  if (st.normals) v.normal.resize(nf * 3);
  const double shininess = st.shininess;
  const int ishin = static_cast<int>(shininess);
  const bool integer_shininess = ishin == shininess && ishin <= 256;
  auto power = [&](double x) {
    if (!integer_shininess) return std::pow(x, shininess);
    double r = 1, b = x;  // exponentiation by squaring: exact repeatable products, much cheaper than pow
    for (int e = ishin; e > 0; e >>= 1, b *= b)
      if (e & 1) r *= b;
    return r;
  };
  std::vector<Eigen::Vector3d> light_dirs, halfways;
  for (const Light& l : st.lights) {
    light_dirs.push_back(l.direction.cast<double>());
    // Specular with a non-local viewer (view direction = -optical axis, as OpenGL's default light model), so
    // shading depends on the normal only and coplanar triangles get the same colour.
    halfways.push_back((l.direction.cast<double>() + Eigen::Vector3d(0, 0, -1)).normalized());
  }
  for (size_t f = 0; f < nf; ++f) {
    if (!seen[f]) continue;
    const Eigen::Vector3d p0 = vert(F_[3 * f]), p1 = vert(F_[3 * f + 1]), p2 = vert(F_[3 * f + 2]);
    Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    const double len = n.norm();
    n = len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d(0, 0, -1);
    if (n.dot(p0 + p1 + p2) > 0) n = -n;  // two-sided: face the camera (at the origin of this frame)
    double diffuse = st.ambient, spec = 0;
    for (size_t k = 0; k < light_dirs.size(); ++k) {
      const double ndl = n.dot(light_dirs[k]);
      if (ndl <= 0) continue;
      diffuse += st.lights[k].intensity * ndl;
      spec += st.lights[k].intensity * power(std::max(0.0, n.dot(halfways[k])));
    }
    v.shade[2 * f] = static_cast<float>(diffuse);
    v.shade[2 * f + 1] = static_cast<float>(st.specular * spec);
    if (st.normals)
      for (int k = 0; k < 3; ++k) v.normal[3 * f + k] = static_cast<float>(n[k]);
  }

  // 6. Resolve pixels: average the covered samples' colours; depth and normal from the centre sample.
  RenderResult out;
  out.rasterised_triangles = static_cast<long>(v.tris.size());
  out.rgba = Image(cam.width, cam.height, 4, 0.0f);
  if (st.depth) out.depth = Image(cam.width, cam.height, 1, 0.0f);
  if (st.normals) out.normals = Image(cam.width, cam.height, 3, 0.0f);
  if (st.albedo) out.albedo = Image(cam.width, cam.height, 3, 0.0f);
  const Eigen::Matrix3d Kinv = cam.K.inverse();
  const bool colored = !C_.empty();
  const int s = v.s, centre = s / 2;
  const float inv_n = 1.0f / static_cast<float>(s * s);
  // Perspective-correct barycentrics of the sample's ray in face f, from triple products with the camera
  // centre at the origin; also the hit point's z.
  auto barycentric = [&](int f, double sx, double sy, double w[3]) {
    const Eigen::Vector3d d = Kinv * Eigen::Vector3d(sx / s, sy / s, 1.0);
    const Eigen::Vector3d a = vert(F_[3 * f]), b = vert(F_[3 * f + 1]), c = vert(F_[3 * f + 2]);
    w[0] = d.dot(b.cross(c));
    w[1] = d.dot(c.cross(a));
    w[2] = d.dot(a.cross(b));
    const double sum = w[0] + w[1] + w[2];
    if (sum != 0 && std::isfinite(sum)) {
      for (int k = 0; k < 3; ++k) w[k] /= sum;
    } else {
      w[0] = w[1] = w[2] = 1.0 / 3.0;
    }
    return w[0] * a.z() + w[1] * b.z() + w[2] * c.z();
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, cam.height, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < cam.width; ++x) {
        float acc[3] = {0, 0, 0}, alb[3] = {0, 0, 0};
        int covered = 0;
        for (int b = 0; b < s; ++b) {
          const size_t row = static_cast<size_t>(y * s + b) * v.W;
          for (int a = 0; a < s; ++a) {
            const int f = fbuf[row + x * s + a];
            if (f < 0) continue;
            ++covered;
            const float diffuse = v.shade[2 * f], spec = v.shade[2 * f + 1];
            Eigen::Vector3f albedo = st.default_color;
            if (colored) {
              double w[3];
              barycentric(f, x * s + a + 0.5, y * s + b + 0.5, w);
              albedo.setZero();
              double wsum = 0;
              for (int k = 0; k < 3; ++k) wsum += std::max(0.0, w[k]);
              for (int k = 0; k < 3; ++k) {
                const float wk = static_cast<float>(wsum > 0 ? std::max(0.0, w[k]) / wsum : 1.0 / 3.0);
                const float* col = &C_[3 * static_cast<size_t>(F_[3 * f + k])];
                albedo += wk * Eigen::Vector3f(col[0], col[1], col[2]);
              }
            }
            for (int k = 0; k < 3; ++k) {
              acc[k] += std::min(1.0f, albedo[k] * diffuse + spec);
              alb[k] += albedo[k];
            }
          }
        }
        if (covered == 0) continue;
        float* px = &out.rgba.at(x, y, 0);
        for (int k = 0; k < 3; ++k) px[k] = acc[k] / static_cast<float>(covered);
        px[3] = static_cast<float>(covered) * inv_n;
        if (st.albedo)
          for (int k = 0; k < 3; ++k) out.albedo.at(x, y, k) = alb[k] / static_cast<float>(covered);
        if (st.depth || st.normals) {
          const int f = fbuf[static_cast<size_t>(y * s + centre) * v.W + x * s + centre];
          if (f < 0) continue;
          if (st.depth) {
            double w[3];
            out.depth.at(x, y) = static_cast<float>(barycentric(f, x * s + centre + 0.5, y * s + centre + 0.5, w));
          }
          if (st.normals)
            for (int k = 0; k < 3; ++k) out.normals.at(x, y, k) = v.normal[3 * f + k];
        }
      }
  });
  return out;
}

RenderResult render(const Mesh& mesh, const Camera& cam, const RenderSettings& settings) {
  return MeshRenderer(mesh, settings).render(cam);
}

ViewDifference view_difference(const Image& a, const Image& b, float colour_tol) {
  require(a.channels == 4 && b.channels == 4, "view_difference: both images must be RGBA");
  require(a.width == b.width && a.height == b.height, "view_difference: the images differ in size");
  require(std::isfinite(colour_tol) && colour_tol >= 0, "view_difference: colour_tol must be finite and >= 0");
  ViewDifference d;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const bool in_a = a.at(x, y, 3) >= 0.5f, in_b = b.at(x, y, 3) >= 0.5f;
      if (!in_a && !in_b) continue;
      ++d.silhouette;
      bool differs = in_a != in_b;
      for (int c = 0; c < 3 && !differs; ++c) differs = std::abs(a.at(x, y, c) - b.at(x, y, c)) > colour_tol;
      d.differing += differs ? 1 : 0;
    }
  return d;
}

std::vector<double> view_twin_turns(const MeshRenderer& renderer, const Camera& truth, double turn_deg,
                                    const TwinSearch& search, double* best_share) {
  require(std::isfinite(search.step) && search.step > 0, "view_twin_turns: the step must be positive");
  require(std::isfinite(search.window) && search.window >= 0 && std::isfinite(search.min_turn) &&
              search.min_turn >= 0,
          "view_twin_turns: the window and the smallest turn must be finite and >= 0");
  require(2 * search.window / search.step <= 3600, "view_twin_turns: more than 3600 candidate turns");
  require(search.tol >= 0 && search.tol <= 1, "view_twin_turns: the tolerance must be in [0, 1]");
  require(std::isfinite(turn_deg), "view_twin_turns: the turn must be finite");
  std::vector<double> out;
  double best = std::numeric_limits<double>::infinity();
  std::optional<Image> view;
  const double k0 = std::ceil((turn_deg - search.window) / search.step);
  for (double k = k0; k * search.step <= turn_deg + search.window; k += 1) {
    const double a = k * search.step;
    if (std::abs(std::remainder(a, 360.0)) < search.min_turn) continue;
    if (!view) view = renderer.render(truth).rgba;
    const double share =
        view_difference(*view, renderer.render(turn_about_vertical(truth, -a)).rgba, search.colour_tol).share();
    best = std::min(best, share);
    if (share <= search.tol) out.push_back(a);
  }
  if (best_share) *best_share = best;
  return out;
}

}  // namespace sdfkit
