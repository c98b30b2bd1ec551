// Pinhole camera in DISN's convention: look-at from azimuth/elevation/distance, projection with Jacobians,
// back-projection of a pixel to a ray, and the views/NN.json format.
//
// Frames (see docs/camera.md):
//  * Object frame: right-handed, +y is up (ShapeNet / DISN). Azimuth is measured around +y, starting at +z and
//    turning towards +x; elevation is the angle above the xz-plane. The camera centre is
//      C = d * (cos(el) sin(az), sin(el), cos(el) cos(az)),
//    so azimuth 0, elevation 0 looks from +z towards -z, and azimuth 90 looks from +x towards -x.
//  * Camera frame: OpenCV (x right, y down, z forward). x_cam = R x + t, pixel = K x_cam / z_cam.
//    The look-at camera has no roll: its x axis is horizontal, (cos az, 0, -sin az), also at the poles.
//  * Pixels: continuous coordinates with (0, 0) at the top-left corner of the top-left pixel; pixel (col j,
//    row i) covers [j, j+1] x [i, i+1] and its centre is (j + 0.5, i + 0.5). With c = 68.5 and 137 px the
//    optical axis passes through the centre of the image. Code that indexes arrays at pixel centres (bilinear
//    sampling of feature maps) uses u - 0.5, v - 0.5.
#pragma once

#include "core/files.h"
#include "core/types.h"

#include <Eigen/Core>

namespace sdfkit {

/// DISN's renders: 137 px square images, 35 mm lens on a 32 mm sensor.
constexpr int kDisnImageSize = 137;
constexpr double kDisnFocal = 35.0 * 137.0 / 32.0;  // 149.84375 px
constexpr double kDisnPrincipal = 137.0 / 2.0;      // 68.5 px

struct Camera {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  ///< intrinsics [[f,0,cx],[0,f,cy],[0,0,1]]
  Mat3 R = Mat3::Identity();                        ///< world (object frame) -> camera rotation
  Vec3 t = Vec3::Zero();                            ///< world -> camera translation
  int width = kDisnImageSize, height = kDisnImageSize;
};

/// DISN's intrinsics scaled to a width x height image: f = 35/32 * width, principal point at the centre
/// (width/2, height/2). For 137 x 137 this is f = 149.84375, c = 68.5.
Eigen::Matrix3d disn_intrinsics(int width = kDisnImageSize, int height = kDisnImageSize);

/// Camera at azimuth/elevation (degrees)/distance looking at the object-frame origin, DISN intrinsics for the
/// image size. Throws InvalidInput for a non-positive or non-finite distance or size.
Camera look_at(double azimuth_deg, double elevation_deg, double distance, int width = kDisnImageSize,
               int height = kDisnImageSize);

/// The look-at parameters of a camera (exact inverse of look_at for look-at cameras): distance = |C|,
/// azimuth in [0, 360), elevation in [-90, 90] from the camera centre C.
struct LookAtParams {
  double azimuth_deg = 0, elevation_deg = 0, distance = 0;
};
LookAtParams look_at_params(const Camera& cam);

/// Camera centre in the object frame: C = -R^T t.
Vec3 camera_center(const Camera& cam);

/// The camera moved about the object frame's +y axis so that its centre's azimuth grows by `degrees`, seeing the
/// object turned by -degrees: R' = R Ry(degrees)^T, t' = t (Ry = rotation about +y, z towards x). For a look-at
/// camera, turn_about_vertical(look_at(a, e, d), x) = look_at(a + x, e, d).
Camera turn_about_vertical(const Camera& cam, double degrees);

/// The same view with the camera's distance to the object-frame origin |t| brought into [d_min, d_max] and the
/// focal lengths and skew scaled by the same factor k = d' / |t| (t' = k t, the principal point moved so that the
/// origin projects where it did). Points near the origin project nearly where they did (the same image in weak
/// perspective), but the perspective is that of a camera at d'. A distance read off a magnified image (an object
/// m times larger in the image answers d / m) becomes the distance the renders use and an m-times longer focal
/// length, which is how a crop of a photo is made; a camera already in range comes back unchanged. Throws
/// InvalidInput unless 0 < d_min <= d_max and |t| > 0.
Camera distance_as_focal(const Camera& cam, double d_min, double d_max);

/// The camera that sees the object mirrored across its x = 0 plane (x -> -x) as this camera's image flipped left to
/// right (pixel u -> width - u): R' = S R M, t' = S t, cx' = width - cx, skew' = -skew, with M = S = diag(-1, 1, 1).
/// R' is a proper rotation again: for a look-at camera, mirror_camera(look_at(a, e, d)) = look_at(-a, e, d).
Camera mirror_camera(const Camera& cam);

/// x_cam = R x + t.
inline Vec3 to_camera(const Camera& cam, const Vec3& x) { return cam.R * x + cam.t; }

/// Pixel of a world point: (K x_cam)_{0,1} / (K x_cam)_2. Points with z_cam <= kMinDepth are projected as if
/// z_cam = kMinDepth (finite, far outside the image); `depth` (optional) receives the true z_cam so that
/// callers can reject them.
constexpr double kMinDepth = 1e-9;
Eigen::Vector2d project(const Camera& cam, const Vec3& x, double* depth = nullptr);

/// Jacobians of the pixel (2 rows) of project():
///  d_point:       wrt the world point x;
///  d_translation: wrt t;
///  d_rotation:    wrt a rotation perturbation w applied on the left, R(w) = exp([w]_x) R, at w = 0;
///  d_matrix:      wrt the 9 entries of R, vec(R) column-major (R(0,0), R(1,0), R(2,0), R(0,1), ...),
///                 the layout rot6d_jacobian() uses, so d pixel / d b6 = d_matrix * rot6d_jacobian(b6).
struct ProjectionJacobians {
  Eigen::Matrix<double, 2, 3> d_point;
  Eigen::Matrix<double, 2, 3> d_translation;
  Eigen::Matrix<double, 2, 3> d_rotation;
  Eigen::Matrix<double, 2, 9> d_matrix;
};
Eigen::Vector2d project(const Camera& cam, const Vec3& x, ProjectionJacobians& jac, double* depth = nullptr);

/// Jacobian of the pixel wrt the look-at parameters (azimuth_deg, elevation_deg, distance), columns in that
/// order, per degree for the angles. Intrinsics are held fixed.
Eigen::Matrix<double, 2, 3> project_jacobian_lookat(double azimuth_deg, double elevation_deg, double distance,
                                                    const Vec3& x, int width = kDisnImageSize,
                                                    int height = kDisnImageSize);

/// Batch projection of #P x 3 points to #P x 2 pixels (TBB-parallel for large inputs, deterministic).
/// `depth` (optional) receives z_cam per point.
using Pixels = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;
using PixelsF = Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>;
Pixels project_points(const Camera& cam, const Points& X, Eigen::VectorXd* depth = nullptr);
/// Float variant for network inputs (computed in double, stored as float).
PixelsF project_points(const Camera& cam, const PointsF& X, Eigen::VectorXf* depth = nullptr);

/// A ray through a pixel: origin = camera centre, unit direction in the object frame. Points on it are
/// origin + s * direction; s is the distance along the ray (not z_cam).
struct Ray {
  Vec3 origin = Vec3::Zero();
  Vec3 direction = Vec3::UnitZ();
};
Ray pixel_ray(const Camera& cam, double u, double v);

/// Throws InvalidInput (message starts with `what`) unless K is finite with f > 0 and K(2,:) = (0,0,1),
/// R is a rotation (orthonormal to 1e-6, det +1), t finite and the size positive.
void validate_camera(const Camera& cam, const std::string& what);

/// The views/NN.json object: {"K": 3x3 rows, "R": 3x3 rows, "t": [3], "azimuth": deg, "elevation": deg,
/// "distance": d, "width": px, "height": px}. azimuth/elevation/distance are derived from R, t
/// (look_at_params) and are informational; K, R, t, width, height define the camera.
Json camera_to_json(const Camera& cam);
/// Parses camera_to_json()'s format (extra keys ignored). Throws IoError naming `what` on a missing or
/// malformed field and InvalidInput for an invalid camera.
Camera camera_from_json(const Json& j, const std::string& what = "camera");
/// Atomic write / read of a camera JSON file.
void write_camera(const std::string& path, const Camera& cam);
Camera read_camera(const std::string& path);

}  // namespace sdfkit
