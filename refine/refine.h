// Multi-view mesh refinement by differentiable rendering (`sdfkit refine`): a mesh (a sphere, or a `recon` result)
// is deformed, and its vertex colours fitted, so that its soft renders (camera/soft_raster.h) match a view set's
// images, with edge, normal-consistency and Laplacian regularisers (refine/regularisers.h). The recipe is the
// refinement paper's (PyTorch3D's mesh fitting): SGD lr 1.0, momentum 0.9 on vertex positions and colours;
// silhouette and RGB squared errors (means over pixels) of a random subset of views per step; weights 1 except
// normal consistency 0.01.
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "camera/soft_raster.h"
#include "core/types.h"
#include "models/critic.h"

#include <functional>
#include <string>
#include <vector>

namespace sdfkit {

/// One target image with its camera.
struct TargetView {
  std::string name;  ///< e.g. "07"
  Camera camera;
  Image alpha;       ///< 1 channel, [0, 1]
  Image rgb;         ///< 3 channels, composited on the rasteriser's background
};

/// Reads a view set folder (`sdfkit render`, `prep --views`): every NN.json with its NN.png (RGBA; RGB without
/// alpha is refused since the silhouette is the main signal), in name order. The image composited on
/// `background`. Throws IoError naming the file for a missing or unreadable image, a camera whose size differs from
/// its image, or a folder without views. `only` (when not empty) keeps those views, in that order; a name
/// without its files is an IoError.
std::vector<TargetView> read_target_views(const std::string& dir,
                                          const Eigen::Vector3d& background = Eigen::Vector3d::Ones(),
                                          const std::vector<std::string>& only = {});

struct RefineSettings {
  long iters = 2000;               ///< 0: the starting mesh comes back unchanged (colours grey or its own)
  int views_per_step = 4;          ///< views drawn (without replacement) per step; all when >= the view count
  double lr = 1.0, momentum = 0.9; ///< SGD on positions and colours (PyTorch's: buf = mu buf + g; x -= lr buf)
  /// Regularisers weaker than the paper's (edge 1, Laplacian 1): against the exact silhouette's residual those pull
  /// the surface inside the silhouettes (the cow, 1000 steps of the paper's loss, then 1000 with the exact
  /// silhouette: 87.7% IoU with both weights at 1, 91.2 at 0.3, 92.5 at 0.1). From a recon mesh, whose thin parts
  /// they hold together, the paper's weights and loss do better (paper_loss).
  double w_silhouette = 1, w_rgb = 1, w_edge = 0.1, w_normal = 0.01, w_laplacian = 0.1;
  /// Whether the RGB term's gradient reaches the vertex positions (the paper's) or only their colours. Off by
  /// default: the soft colour image is composited with the same dilated alpha as the soft silhouette, so on the
  /// unlit colours it pulls every contour inwards, and inside the contours it carries no shape (the carved cow /
  /// camel of docs/results/refine.md, 2000 steps: 94.5 / 93.4% IoU with it, 94.9 / 94.5 without). Forced on with
  /// the critic (its verdict reaches the mesh through the colour image); `lit` has its own rule (below).
  bool rgb_moves_vertices = false;
  /// Shape from shading (`sdfkit refine --lit`, for views made by `sdfkit render` or `prep --views`): from the first
  /// exact-silhouette step on (from the start when exact_silhouette is 0), the colours are shaded as `render` lights
  /// its views (SoftRasterSettings::lit: flat Lambert + Blinn-Phong, the camera-fixed light rig) and the colour error
  /// moves the vertices; it counts only at the pixels that both the target and the mesh cover fully (target alpha 1,
  /// and the exact coverage, or the soft alpha without it, at least 0.999; rgb_moves_vertices rules the unlit steps
  /// only): the contours stay the silhouette term's, whose dilation the soft colour image shares (the
  /// loss curve's rgb column still averages every pixel). What it adds is the surface's orientation where no contour
  /// passes, such as the concavities a visual hull fills (docs/results/refine.md: from the hull, the bull 94.2 ->
  /// 97.1% IoU). The soft steps before stay unlit (their colours fitted only, as rgb_moves_vertices says).
  /// Set this, not raster.lit (validate_refine_settings refuses raster.lit: the schedule is refine's).
  bool lit = false;
  /// With `lit`: one albedo for the whole mesh (set to the mean of the fitted colours when shading starts, then
  /// fitted), so that the shading cannot be absorbed by per-vertex colours; false: one per vertex.
  bool uniform_albedo = true;
  /// Weight of the adversarial term (0 = no critic): the generator's binary cross-entropy of the critic's verdict
  /// on the step's renders against "real" (models/critic.h); the critic is trained on the same steps (Adam, real
  /// targets against the renders) from a seed derived from `seed`.
  double w_adversarial = 0;
  CriticSettings critic;
  /// sigma, gamma, background, ... Edges sharper than the rasteriser's default (0.1 px^2 against 0.5): measured
  /// best on the cow of docs/results/refine.md (volumetric IoU 88 at sigma 0.1, 82 at 0.5, 86 at 0.02).
  SoftRasterSettings raster = [] {
    SoftRasterSettings r;
    r.sigma = 0.1;
    return r;
  }();
  /// Supersampling of the exact silhouette whose difference with the target drives the silhouette term after
  /// `exact_after` steps (0: never, the soft silhouette's own error throughout, the paper's loss). Its residual at
  /// a pixel is the coverage of the mesh's sharp projection at S x S samples (camera/silhouette.h) minus the
  /// target's, and the soft rasteriser only carries it to the vertices. Why: the soft silhouette is dilated
  /// (1 - prod(1 - p) exceeds 1/2 where two or more faces meet at the contour, as on every contour of a closed
  /// mesh), so its own error is smallest for a mesh smaller than the object (the cow of docs/results/refine.md:
  /// at sigma 0.1 the true mesh scaled by 0.99 scores 0.0025 against 0.0037 for the true one), while the exact
  /// one vanishes on the object itself when S is the targets' sampling (`sdfkit render`: 3). The soft error pulls
  /// a mesh from far away (its halo reaches pixels the mesh does not cover), the exact one only moves edges that
  /// straddle pixels, hence the schedule.
  int exact_silhouette = 3;
  /// Steps with the soft silhouette's own error before the exact one takes over; -1: three quarters of `iters`
  /// (for a start far from the object, such as a sphere: from the cow, elephant and camel of docs/results/refine.md,
  /// 2000 steps, mean IoU 89.2% switching at 1000, 89.9 at 1500, 90.2 at 1750; the soft error alone 86.3). From
  /// the visual hull, already close, half the steps do better (`sdfkit refine --carve` passes iters / 2:
  /// docs/refine.md).
  long exact_after = -1;
  uint64_t seed = 1;               ///< draws the views of every step
  /// Coarse to fine: after each of these steps every face is split into four (subdivide_midpoints), momentum
  /// restarts and the learning rate is multiplied by subdivide_lr_factor.
  std::vector<long> subdivide_at;
  double subdivide_lr_factor = 1;  ///< learning-rate factor at each subdivision
  int log_every = 10;              ///< a loss-curve row every N steps (and the last)
  double time_limit_seconds = 0;   ///< stop early after this long (0 = no limit)
};

/// `s` with the refinement paper's loss: the soft silhouette's own error throughout (exact_silhouette 0) and its
/// edge and Laplacian weights (1). `sdfkit refine` starts from it for a mesh file (a recon result), where it measured
/// best (docs/results/refine.md).
RefineSettings paper_loss(RefineSettings s);

/// Whether the colour error's gradient moves the vertices on every pixel: `rgb_moves_vertices`, or forced by the
/// critic (`w_adversarial` > 0). (With `lit`, the shaded steps also move them, at the pixels inside both
/// silhouettes.)
bool colour_moves_vertices(const RefineSettings& s);

/// The first step with shading when `lit` (the exact silhouette's first step, or 0 without it); -1 when not lit.
long lit_from(const RefineSettings& s);

/// The first step that uses the exact silhouette: `exact_after`, or three quarters of `iters` when it is -1.
long exact_silhouette_from(const RefineSettings& s);

/// Throws InvalidInput naming the bad field.
void validate_refine_settings(const RefineSettings& settings);

/// One row of the loss curve: the step's weighted total and its unweighted terms (image terms averaged over the
/// step's views), wall seconds since the start.
struct RefineRow {
  long step = 0;
  double loss = 0, silhouette = 0, rgb = 0, edge = 0, normal = 0, laplacian = 0, seconds = 0;
  double adversarial = 0;  ///< the generator's critic loss (0 without a critic)
  double critic = 0;       ///< the critic's own loss on the step's real and rendered images
};

struct RefineResult {
  Mesh mesh;                     ///< positions and vertex colours (clamped to [0, 1]) after the last step
  std::vector<RefineRow> curve;  ///< every log_every steps
  long steps = 0;                ///< steps taken (fewer than iters when the time limit stopped it)
  double seconds = 0;
  double seconds_per_step = 0;
};

/// Midpoint subdivision: every triangle into four, new vertices (and colours, when `colours` has a row per vertex)
/// at the edge midpoints, shared between the two faces of an edge. The new colours go to `finer_colours`.
Mesh subdivide_midpoints(const Mesh& mesh, const Points& colours = Points(), Points* finer_colours = nullptr);

/// The refinement paper's starting mesh: a level-`levels` icosphere of `radius` at the origin, grey (0.5).
Mesh refine_sphere(int levels = 4, double radius = 1.0);

/// Runs the optimisation from `init` (its colours, or 0.5 grey when it has none). `on_row` sees each curve row.
/// Throws InvalidInput for an empty or invalid mesh, no views, or bad settings.
RefineResult refine_mesh(const std::vector<TargetView>& views, const Mesh& init, const RefineSettings& settings,
                         const std::function<void(const RefineRow&)>& on_row = {});

/// Renders `mesh` (positions and colours) through `view`'s camera with the soft rasteriser of `raster`.
SoftImages render_for_view(const Mesh& mesh, const TargetView& view, const SoftRasterSettings& raster);

/// A preview sheet: for each chosen view, the target image above the mesh's soft render (RGB composited with its
/// alpha on white), side by side.
Image refine_preview_sheet(const std::vector<TargetView>& views, const std::vector<int>& which, const Mesh& mesh,
                           const SoftRasterSettings& raster);

}  // namespace sdfkit
