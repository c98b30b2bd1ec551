#include "camera/camera.h"

#include "core/error.h"
#include "core/json.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace sdfkit {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Mat3 skew(const Vec3& v) {
  Mat3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

/// d pixel / d x_cam at a camera-frame point (depth clamped as documented in camera.h).
Eigen::Matrix<double, 2, 3> pixel_wrt_cam(const Eigen::Matrix3d& K, const Vec3& xc, Eigen::Vector2d& pixel) {
  Vec3 x = xc;
  const bool clamped = x.z() < kMinDepth;
  if (clamped) x.z() = kMinDepth;
  const Vec3 h = K * x;
  const double iz = 1.0 / h.z();
  pixel = Eigen::Vector2d(h.x() * iz, h.y() * iz);
  Eigen::Matrix<double, 2, 3> A;
  A << iz, 0, -h.x() * iz * iz, 0, iz, -h.y() * iz * iz;
  Eigen::Matrix<double, 2, 3> B = A * K;
  if (clamped) B.col(2).setZero();  // the clamped function does not depend on z_cam there
  return B;
}

/// Rows right, down, forward of the look-at rotation and their derivatives wrt azimuth and elevation (radians).
void lookat_rotation(double az, double el, Mat3& R, Mat3* dR_daz = nullptr, Mat3* dR_del = nullptr) {
  const double ca = std::cos(az), sa = std::sin(az), ce = std::cos(el), se = std::sin(el);
  const Vec3 right(ca, 0, -sa);
  const Vec3 fwd = -Vec3(ce * sa, se, ce * ca);
  const Vec3 down = fwd.cross(right);
  R.row(0) = right.transpose();
  R.row(1) = down.transpose();
  R.row(2) = fwd.transpose();
  if (dR_daz) {
    const Vec3 right_az(-sa, 0, -ca);
    const Vec3 fwd_az = -Vec3(ce * ca, 0, -ce * sa);
    dR_daz->row(0) = right_az.transpose();
    dR_daz->row(1) = (fwd_az.cross(right) + fwd.cross(right_az)).transpose();
    dR_daz->row(2) = fwd_az.transpose();
  }
  if (dR_del) {
    const Vec3 fwd_el = -Vec3(-se * sa, ce, -se * ca);
    dR_del->row(0).setZero();
    dR_del->row(1) = fwd_el.cross(right).transpose();
    dR_del->row(2) = fwd_el.transpose();
  }
}

}  // namespace

Eigen::Matrix3d disn_intrinsics(int width, int height) {
  require(width > 0 && height > 0, "disn_intrinsics: image size must be positive");
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = K(1, 1) = 35.0 / 32.0 * width;
  K(0, 2) = 0.5 * width;
  K(1, 2) = 0.5 * height;
  return K;
}

Camera look_at(double azimuth_deg, double elevation_deg, double distance, int width, int height) {
  require(std::isfinite(azimuth_deg) && std::isfinite(elevation_deg), "look_at: non-finite angle");
  require(std::isfinite(distance) && distance > 0, "look_at: distance must be positive and finite");
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.K = disn_intrinsics(width, height);
  lookat_rotation(azimuth_deg * kDeg, elevation_deg * kDeg, cam.R);
  // t = -R C and R C = -distance * e_z (C lies on the backward optical axis).
  cam.t = Vec3(0, 0, distance);
  return cam;
}

Vec3 camera_center(const Camera& cam) { return -cam.R.transpose() * cam.t; }

Camera distance_as_focal(const Camera& cam, double d_min, double d_max) {
  require(std::isfinite(d_min) && std::isfinite(d_max) && d_min > 0 && d_min <= d_max,
          "distance_as_focal: need 0 < d_min <= d_max");
  const double d = cam.t.norm();
  require(std::isfinite(d) && d > 0 && std::abs(cam.t.z()) > 0,
          "distance_as_focal: the camera must be away from the origin, which must not lie in its focal plane");
  const double target = std::clamp(d, d_min, d_max);
  if (target == d) return cam;
  const double k = target / d;
  Camera out = cam;
  out.t = k * cam.t;
  out.K(0, 0) *= k;
  out.K(0, 1) *= k;
  out.K(1, 1) *= k;
  // The origin projects at c + (f t_x + s t_y) / t_z; t_x / t_z is unchanged, f and s grew by k.
  out.K(0, 2) += (1 - k) * (cam.K(0, 0) * cam.t.x() + cam.K(0, 1) * cam.t.y()) / cam.t.z();
  out.K(1, 2) += (1 - k) * cam.K(1, 1) * cam.t.y() / cam.t.z();
  return out;
}

Camera turn_about_vertical(const Camera& cam, double degrees) {
  const double a = degrees * kDeg, c = std::cos(a), s = std::sin(a);
  Mat3 Ry;
  Ry << c, 0, s, 0, 1, 0, -s, 0, c;
  Camera out = cam;
  out.R = cam.R * Ry.transpose();
  return out;
}

Camera mirror_camera(const Camera& cam) {
  const Mat3 S = Vec3(-1, 1, 1).asDiagonal();
  Camera out = cam;
  out.R = S * cam.R * S;
  out.t = S * cam.t;
  out.K(0, 1) = -cam.K(0, 1);
  out.K(0, 2) = cam.width - cam.K(0, 2);
  return out;
}

LookAtParams look_at_params(const Camera& cam) {
  const Vec3 C = camera_center(cam);
  LookAtParams p;
  p.distance = C.norm();
  if (!(p.distance > 0)) return p;
  p.elevation_deg = std::asin(std::clamp(C.y() / p.distance, -1.0, 1.0)) / kDeg;
  const double horiz = std::hypot(C.x(), C.z());
  if (horiz > 1e-9 * p.distance)
    p.azimuth_deg = std::atan2(C.x(), C.z()) / kDeg;
  else  // at a pole the azimuth only shows in the horizontal x axis (cos az, 0, -sin az)
    p.azimuth_deg = std::atan2(-cam.R(0, 2), cam.R(0, 0)) / kDeg;
  if (p.azimuth_deg < 0) p.azimuth_deg += 360.0;
  if (p.azimuth_deg >= 360.0) p.azimuth_deg -= 360.0;
  return p;
}

Eigen::Vector2d project(const Camera& cam, const Vec3& x, double* depth) {
  const Vec3 xc = to_camera(cam, x);
  if (depth) *depth = xc.z();
  const Vec3 h = cam.K * Vec3(xc.x(), xc.y(), std::max(xc.z(), kMinDepth));
  return {h.x() / h.z(), h.y() / h.z()};
}

Eigen::Vector2d project(const Camera& cam, const Vec3& x, ProjectionJacobians& jac, double* depth) {
  const Vec3 Rx = cam.R * x;
  const Vec3 xc = Rx + cam.t;
  if (depth) *depth = xc.z();
  Eigen::Vector2d pixel;
  const Eigen::Matrix<double, 2, 3> B = pixel_wrt_cam(cam.K, xc, pixel);
  jac.d_translation = B;
  jac.d_point = B * cam.R;
  jac.d_rotation = -B * skew(Rx);
  for (int j = 0; j < 3; ++j) jac.d_matrix.block<2, 3>(0, 3 * j) = B * x[j];
  return pixel;
}

Eigen::Matrix<double, 2, 3> project_jacobian_lookat(double azimuth_deg, double elevation_deg, double distance,
                                                    const Vec3& x, int width, int height) {
  const Camera cam = look_at(azimuth_deg, elevation_deg, distance, width, height);
  Mat3 R, dRa, dRe;
  lookat_rotation(azimuth_deg * kDeg, elevation_deg * kDeg, R, &dRa, &dRe);
  Eigen::Vector2d pixel;
  const Eigen::Matrix<double, 2, 3> B = pixel_wrt_cam(cam.K, to_camera(cam, x), pixel);
  Eigen::Matrix<double, 2, 3> J;
  J.col(0) = B * (dRa * x) * kDeg;
  J.col(1) = B * (dRe * x) * kDeg;
  J.col(2) = B.col(2);  // t = (0, 0, distance)
  return J;
}

namespace {
template <typename PointsT, typename PixelsT, typename DepthT>
PixelsT project_points_impl(const Camera& cam, const PointsT& X, DepthT* depth) {
  using S = typename PointsT::Scalar;
  const Eigen::Index n = X.rows();
  PixelsT out(n, 2);
  if (depth) depth->resize(n);
  // Fold K into the pose once: h = (K R) x + K t.
  const Mat3 KR = cam.K * cam.R;
  const Vec3 Kt = cam.K * cam.t;
  const Mat3& R = cam.R;
  const Vec3& t = cam.t;
  const bool plain_k = cam.K(2, 0) == 0 && cam.K(2, 1) == 0 && cam.K(2, 2) == 1;
  auto body = [&](Eigen::Index lo, Eigen::Index hi) {
    for (Eigen::Index i = lo; i < hi; ++i) {
      const Vec3 x(static_cast<double>(X(i, 0)), static_cast<double>(X(i, 1)), static_cast<double>(X(i, 2)));
      const double z = R.row(2).dot(x) + t.z();
      if (depth) (*depth)[i] = static_cast<S>(z);
      Vec3 h = KR * x + Kt;
      if (plain_k) {
        if (z < kMinDepth) h = cam.K * Vec3((R.row(0).dot(x) + t.x()), (R.row(1).dot(x) + t.y()), kMinDepth);
      } else {
        const Vec3 xc = R * x + t;
        h = cam.K * Vec3(xc.x(), xc.y(), std::max(xc.z(), kMinDepth));
      }
      out(i, 0) = static_cast<S>(h.x() / h.z());
      out(i, 1) = static_cast<S>(h.y() / h.z());
    }
  };
  if (n < 4096) {
    body(0, n);
  } else {
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 2048),
                      [&](const tbb::blocked_range<Eigen::Index>& r) { body(r.begin(), r.end()); });
  }
  return out;
}
}  // namespace

Pixels project_points(const Camera& cam, const Points& X, Eigen::VectorXd* depth) {
  return project_points_impl<Points, Pixels, Eigen::VectorXd>(cam, X, depth);
}

PixelsF project_points(const Camera& cam, const PointsF& X, Eigen::VectorXf* depth) {
  return project_points_impl<PointsF, PixelsF, Eigen::VectorXf>(cam, X, depth);
}

Ray pixel_ray(const Camera& cam, double u, double v) {
  Ray ray;
  ray.origin = camera_center(cam);
  const Vec3 d_cam = cam.K.inverse() * Vec3(u, v, 1.0);
  ray.direction = (cam.R.transpose() * d_cam).normalized();
  return ray;
}

void validate_camera(const Camera& cam, const std::string& what) {
  require(cam.K.allFinite() && cam.R.allFinite() && cam.t.allFinite(), what + ": camera has non-finite values");
  require(cam.K(0, 0) > 0 && cam.K(1, 1) > 0, what + ": focal lengths must be positive");
  require(cam.K(2, 0) == 0 && cam.K(2, 1) == 0 && cam.K(2, 2) == 1, what + ": last row of K must be (0, 0, 1)");
  require((cam.R * cam.R.transpose() - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-6 && cam.R.determinant() > 0,
          what + ": R is not a rotation (orthonormal, det +1)");
  require(cam.width > 0 && cam.height > 0, what + ": image size must be positive");
}

namespace {
Json mat_rows(const Eigen::Matrix3d& M) {
  Json rows = Json::array();
  for (int i = 0; i < 3; ++i) rows.push_back({M(i, 0), M(i, 1), M(i, 2)});
  return rows;
}

Eigen::Matrix3d read_mat3(const Json& j, const char* key, const std::string& what) {
  if (!j.contains(key)) throw IoError(what + ": missing field \"" + key + "\"");
  const Json& m = j.at(key);
  if (!m.is_array() || m.size() != 3) throw IoError(what + ": field \"" + key + "\" must be a 3x3 array of rows");
  Eigen::Matrix3d M;
  for (int i = 0; i < 3; ++i) {
    if (!m[i].is_array() || m[i].size() != 3) throw IoError(what + ": field \"" + key + "\" must be 3x3");
    for (int k = 0; k < 3; ++k) {
      if (!m[i][k].is_number()) throw IoError(what + ": field \"" + key + "\" has a non-number");
      M(i, k) = m[i][k].get<double>();
    }
  }
  return M;
}
}  // namespace

Json camera_to_json(const Camera& cam) {
  validate_camera(cam, "camera_to_json");
  const LookAtParams p = look_at_params(cam);
  return Json{{"K", mat_rows(cam.K)},
              {"R", mat_rows(cam.R)},
              {"t", {cam.t.x(), cam.t.y(), cam.t.z()}},
              {"azimuth", p.azimuth_deg},
              {"elevation", p.elevation_deg},
              {"distance", p.distance},
              {"width", cam.width},
              {"height", cam.height}};
}

Camera camera_from_json(const Json& j, const std::string& what) {
  if (!j.is_object()) throw IoError(what + ": camera JSON must be an object");
  Camera cam;
  cam.K = read_mat3(j, "K", what);
  cam.R = read_mat3(j, "R", what);
  if (!j.contains("t") || !j["t"].is_array() || j["t"].size() != 3)
    throw IoError(what + ": field \"t\" must be an array of 3 numbers");
  for (int i = 0; i < 3; ++i) {
    if (!j["t"][i].is_number()) throw IoError(what + ": field \"t\" has a non-number");
    cam.t[i] = j["t"][i].get<double>();
  }
  for (const char* key : {"width", "height"}) {
    if (!j.contains(key) || !j[key].is_number_integer())
      throw IoError(what + ": field \"" + key + "\" must be an integer");
  }
  cam.width = j["width"].get<int>();
  cam.height = j["height"].get<int>();
  validate_camera(cam, what);
  return cam;
}

void write_camera(const std::string& path, const Camera& cam) { write_json(path, camera_to_json(cam)); }

Camera read_camera(const std::string& path) { return camera_from_json(read_json(path), path); }

}  // namespace sdfkit
