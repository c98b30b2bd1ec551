#include "camera/silhouette.h"

#include "core/error.h"
#include "core/mesh_io.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace sdfkit {

namespace {

struct P2 {
  double x, y;
};

/// Marks the samples (x + 0.5, y + 0.5) inside the closed convex polygon `p` (n vertices, sample units, any
/// orientation) in the W x H byte buffer `cov`. Row by row: the polygon's intersection with the horizontal line
/// through the sample centres is one interval, bounded by the crossings of its edges.
void fill_convex(const P2* p, int n, int W, int H, uint8_t* cov) {
  double ymin = p[0].y, ymax = p[0].y;
  for (int k = 1; k < n; ++k) {
    ymin = std::min(ymin, p[k].y);
    ymax = std::max(ymax, p[k].y);
  }
  const double y0 = std::max(0.0, std::ceil(ymin - 0.5)), y1 = std::min(H - 1.0, std::floor(ymax - 0.5));
  for (double yd = y0; yd <= y1; yd += 1.0) {
    const double py = yd + 0.5;
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < n; ++k) {
      const P2& a = p[k];
      const P2& b = p[(k + 1) % n];
      if ((a.y < py && b.y < py) || (a.y > py && b.y > py)) continue;
      if (a.y == b.y) {  // horizontal edge on the line: both ends belong to the interval
        lo = std::min({lo, a.x, b.x});
        hi = std::max({hi, a.x, b.x});
        continue;
      }
      const double x = a.x + (py - a.y) * (b.x - a.x) / (b.y - a.y);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    if (lo > hi) continue;
    const double x0 = std::max(0.0, std::ceil(lo - 0.5)), x1 = std::min(W - 1.0, std::floor(hi - 0.5));
    if (x0 > x1) continue;
    uint8_t* row = cov + static_cast<size_t>(yd) * W;
    std::fill(row + static_cast<long>(x0), row + static_cast<long>(x1) + 1, uint8_t{1});
  }
}

}  // namespace

SilhouetteRenderer::SilhouetteRenderer(const Mesh& mesh, int supersampling, double near)
    : s_(supersampling), near_(near) {
  if (mesh.empty()) throw InvalidInput("silhouette: empty mesh");
  if (supersampling < 1 || supersampling > 8)
    throw InvalidInput("silhouette: supersampling must be 1..8, got " + std::to_string(supersampling));
  if (!(near > 0) || !std::isfinite(near)) throw InvalidInput("silhouette: near plane must be positive");
  if (!mesh.V.allFinite()) throw InvalidInput("silhouette: mesh has non-finite vertex coordinates");
  const Eigen::Index nv = mesh.num_vertices();
  V_.assign(mesh.V.data(), mesh.V.data() + nv * 3);
  F_.reserve(static_cast<size_t>(mesh.num_faces()) * 3);
  check_face_indices(mesh, "silhouette");
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) F_.push_back(mesh.F(f, k));
}

Image SilhouetteRenderer::render(const Camera& cam) const {
  validate_camera(cam, "silhouette camera");
  const int s = s_, W = cam.width * s, H = cam.height * s;
  // Intrinsics in sample units: a pixel coordinate u maps to the sample coordinate s * u.
  Eigen::Matrix3d K = cam.K;
  K.row(0) *= s;
  K.row(1) *= s;
  const size_t nv = V_.size() / 3;
  std::vector<Vec3> pc(nv);  // camera-frame positions
  std::vector<P2> px(nv);    // projections (valid where z >= near)
  for (size_t i = 0; i < nv; ++i) {
    const Vec3 x(V_[3 * i], V_[3 * i + 1], V_[3 * i + 2]);
    pc[i] = cam.R * x + cam.t;
    if (pc[i].z() >= near_) {
      const Vec3 q = K * pc[i];
      px[i] = {q.x() / q.z(), q.y() / q.z()};
    }
  }
  std::vector<uint8_t> cov(static_cast<size_t>(W) * H, 0);
  const auto project = [&](const Vec3& c) {
    const Vec3 q = K * c;
    return P2{q.x() / q.z(), q.y() / q.z()};
  };
  for (size_t f = 0; f < F_.size(); f += 3) {
    const int32_t a = F_[f], b = F_[f + 1], c = F_[f + 2];
    const int in = int(pc[a].z() >= near_) + int(pc[b].z() >= near_) + int(pc[c].z() >= near_);
    if (in == 0) continue;
    if (in == 3) {
      const P2 tri[3] = {px[a], px[b], px[c]};
      fill_convex(tri, 3, W, H, cov.data());
      continue;
    }
    // Clip against z = near in camera space (Sutherland-Hodgman): at most 4 vertices remain.
    const Vec3 v[3] = {pc[a], pc[b], pc[c]};
    P2 poly[4];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = v[k];
      const Vec3& q = v[(k + 1) % 3];
      const bool pin = p.z() >= near_, qin = q.z() >= near_;
      if (pin) poly[n++] = project(p);
      if (pin != qin) {
        const double t = (near_ - p.z()) / (q.z() - p.z());
        Vec3 x = p + t * (q - p);
        x.z() = near_;
        poly[n++] = project(x);
      }
    }
    if (n >= 3) fill_convex(poly, n, W, H, cov.data());
  }
  Image out(cam.width, cam.height, 1, 0.f);
  const float inv = 1.0f / static_cast<float>(s * s);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      int count = 0;
      for (int b = 0; b < s; ++b) {
        const uint8_t* row = cov.data() + static_cast<size_t>(y * s + b) * W + static_cast<size_t>(x) * s;
        for (int a = 0; a < s; ++a) count += row[a];
      }
      out.at(x, y) = static_cast<float>(count) * inv;
    }
  return out;
}

Image render_silhouette(const Mesh& mesh, const Camera& cam, int supersampling) {
  return SilhouetteRenderer(mesh, supersampling).render(cam);
}

double silhouette_iou(const Image& a, const Image& b) {
  if (a.empty() || b.empty()) throw InvalidInput("silhouette_iou: empty image");
  if (a.width != b.width || a.height != b.height)
    throw InvalidInput("silhouette_iou: images are " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                       " and " + std::to_string(b.width) + "x" + std::to_string(b.height));
  double inter = 0, uni = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const double p = std::clamp(static_cast<double>(a.at(x, y)), 0.0, 1.0);
      const double q = std::clamp(static_cast<double>(b.at(x, y)), 0.0, 1.0);
      inter += std::min(p, q);
      uni += std::max(p, q);
    }
  return uni > 0 ? inter / uni : 1.0;
}

}  // namespace sdfkit
