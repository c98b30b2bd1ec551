// Test-time camera refinement by silhouette alignment: given a mesh reconstructed in the object frame, a camera
// estimate and the input's object mask, find the camera near the estimate through which the mesh's silhouette best
// overlaps the mask.
//
// Parameters (4, bounded): a rotation w (axis-angle, camera-frame axes, |w_i| <= max_rotation_deg) applied to the
// estimate as R' = exp([w]x) R, i.e. the object turns about its own origin (tilt about x and y, roll about the
// optical axis) while the origin keeps its image position; and the distance, t' = r t with
// r in [1 / (1 + max_distance_change), 1 + max_distance_change] (log-scaled). Intrinsics are kept.
// Objective: 1 - soft IoU (camera/silhouette.h) between the mesh's coverage (supersampled) and the mask.
// Optimiser: optionally a coarse sweep of azimuth turns (sweep_azimuth_deg), then Nelder-Mead on the normalised box
// [-1, 1]^4 around the sweep's best camera (points outside it cost more than any inside), restarted from the best
// point with a fresh simplex until a restart no longer improves: derivative-free (the coverage is piecewise
// constant in the parameters) and deterministic (no randomness, fixed evaluation order). The bounds of the local
// search are relative to the sweep's camera.
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "core/types.h"

#include <functional>

namespace sdfkit {

struct CameraRefineSettings {
  double max_rotation_deg = 20.0;     ///< bound of each rotation component
  double max_distance_change = 0.2;   ///< distance ratio bound: [1 / (1 + c), 1 + c]
  bool refine_distance = true;        ///< false: rotation only (3 parameters), the distance is kept
  double initial_step = 0.2;          ///< simplex edge in the normalised box (0.2 = 4 degrees / ~3.7% distance)
  int supersampling = 2;              ///< silhouette samples per pixel side
  bool local_search = true;           ///< the Nelder-Mead stage (false: the sweep alone)
  int max_evaluations = 400;          ///< objective evaluations of the local search over all restarts
  int max_restarts = 3;
  double tolerance = 1e-4;            ///< stop a run when the simplex's objective spread and size fall under this
  /// Coarse stage before the local search (0 = none): the objective at turns of the object about its vertical
  /// axis (object-frame +y, i.e. azimuth changes of a look-at camera) by -sweep..+sweep degrees in steps of
  /// sweep_step; the local search starts from the best (the estimate on ties). Pose networks err most in azimuth.
  double sweep_azimuth_deg = 0;
  double sweep_step_deg = 10;
};

struct CameraRefineResult {
  Camera camera;                 ///< the refined camera (the start when nothing better was found)
  double iou_before = 0;         ///< soft silhouette IoU of the mesh through the start camera
  double iou_after = 0;          ///< ... through the refined camera (>= iou_before)
  Vec3 rotation_deg = Vec3::Zero();  ///< w of the result, degrees (camera-frame axes), relative to `start`
  double distance_ratio = 1;     ///< r of the result
  double sweep_azimuth_deg = 0;  ///< azimuth turn chosen by the coarse stage (0 when none or the estimate won)
  int evaluations = 0;           ///< objective evaluations: the start, the sweep and the local search
  double seconds = 0;
};

/// Refines `start` so that `mesh` (object frame) projects onto `mask` (1+ channels, first channel = coverage in
/// [0, 1], the size of `start`'s image). Throws InvalidInput for an empty mesh, a mask of another size than the
/// camera's image, or a mask without any object pixel (nothing to align to).
CameraRefineResult refine_camera(const Mesh& mesh, const Image& mask, const Camera& start,
                                 const CameraRefineSettings& settings = {});

/// Joint variant: the mesh depends on the camera (`mesh_for(camera)`, e.g. a reconstruction by a network that
/// samples image features where points project), and the objective is the IoU of mesh_for(C) seen through C.
/// mesh_for is called once per objective evaluation (the start camera first), in a fixed order. An empty mesh
/// has an empty silhouette (IoU 0). Same errors as above.
using MeshForCamera = std::function<Mesh(const Camera&)>;
CameraRefineResult refine_camera(const MeshForCamera& mesh_for, const Image& mask, const Camera& start,
                                 const CameraRefineSettings& settings = {});

/// The camera of parameters (w in degrees, distance ratio r) applied to `start` as described above.
Camera perturb_camera(const Camera& start, const Vec3& rotation_deg, double distance_ratio);

}  // namespace sdfkit
