// Reader of a prepared dataset (docs/FORMATS.md) and the seeded batches both networks
// train on: rendered views (views/NN.png), their cameras (views/NN.json) and SDF samples (samples.npy), in the
// networks' input format (models/net_input.h); and the augmentations of such batches.
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "camera/occlusion.h"
#include "core/files.h"
#include "core/types.h"
#include "models/net_input.h"
#include "train/mask_error.h"

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace sdfkit {

/// One prepared shape.
struct ShapeEntry {
  std::string id;        ///< "<category>/<shape>" as in the split files
  std::string category;  ///< first path component of id
  std::string dir;       ///< <root>/<category>/<shape>
  int num_views = 0;     ///< consecutive views/NN.json + NN.png found, from 00
};

struct DatasetSettings {
  std::string root;   ///< prepared dataset folder
  /// Split list: a file path, or a name ("train", "val", "test") looked up as <root>/<name>.lst and then as
  /// <root>/../<name>.lst. Empty: every complete shape folder under root (sorted).
  std::string split;
  bool require_views = true;  ///< shapes without views are an error (SDF/pose training needs images)
  int max_shapes = 0;         ///< keep the first N shapes of the list (0 = all)
  /// Keep only shapes of these categories (names as in the folder names; empty = all).
  std::vector<std::string> categories;
};

/// Resolve a split name or path to an existing list file (IoError naming both candidates when missing).
std::string resolve_split_file(const std::string& root, const std::string& split);
/// Lines "<category>/<shape>" of a split file (blank lines and '#' comments skipped).
std::vector<std::string> read_split_file(const std::string& path);

/// Read-only access to a prepared dataset. Thread-safe: samples are loaded once and cached.
class Dataset {
 public:
  /// Lists the shapes (see DatasetSettings). Throws IoError when root or the split file is unreadable, when a
  /// listed shape has no samples.npy, or (require_views) no views/00.json; the message names the shape folder.
  explicit Dataset(const DatasetSettings& settings);
  ~Dataset();
  Dataset(Dataset&&) noexcept;
  Dataset& operator=(Dataset&&) noexcept;

  [[nodiscard]] size_t size() const { return shapes_.size(); }
  [[nodiscard]] const ShapeEntry& shape(size_t i) const { return shapes_.at(i); }
  [[nodiscard]] const std::vector<ShapeEntry>& shapes() const { return shapes_; }
  [[nodiscard]] const std::string& root() const { return root_; }

  /// samples.npy of shape i: N x 4 float (x, y, z, sdf) in the object frame. Cached after the first call.
  [[nodiscard]] const MatrixXfR& samples(size_t i) const;
  /// Camera of view v of shape i (views/NN.json).
  [[nodiscard]] Camera camera(size_t i, int view) const;
  /// The raw view image (views/NN.png).
  [[nodiscard]] Image image(size_t i, int view) const;
  /// The view as network input (network_image of image(i, view)).
  [[nodiscard]] Eigen::VectorXf input(size_t i, int view) const;
  /// Path of views/NN.png / NN.json.
  [[nodiscard]] std::string view_path(size_t i, int view, const char* ext) const;
  /// Path of gt.obj of shape i.
  [[nodiscard]] std::string gt_mesh_path(size_t i) const;

 private:
  std::string root_;
  std::vector<ShapeEntry> shapes_;
  struct Cache;
  std::unique_ptr<Cache> cache_;
};

/// A training batch: B (shape, view) items, each with its image, camera and N SDF samples.
struct SdfBatch {
  MatrixXfR images;                 ///< B x (3 * 137 * 137), channels-first rows (network_image)
  std::vector<Camera> cameras;      ///< B ground-truth cameras
  PointsF points;                   ///< (B * N) x 3, item b owns rows [b*N, (b+1)*N)
  Eigen::VectorXf sdf;              ///< B * N raw SDF values (object frame units)
  std::vector<int> shape_index;     ///< B indices into the dataset
  std::vector<int> view_index;      ///< B view numbers
  MatrixXfR masks;                  ///< B x (137 * 137) missing-data masks (occlude_images); empty = nothing missing
  int points_per_item = 0;          ///< N
  [[nodiscard]] int size() const { return static_cast<int>(shape_index.size()); }
};

struct BatchSettings {
  int batch_size = 8;            ///< items (shape, view) per batch
  int points_per_shape = 2048;   ///< SDF samples drawn per item (with replacement when the file has fewer)
  bool load_images = true;       ///< false: skip image decoding (e.g. a points-only model or a test)
  uint64_t seed = 1;
};

/// Deterministic batches: the batch of a given step depends only on (seed, step), not on earlier calls or on
/// thread scheduling, so a resumed training run sees exactly the batches of an uninterrupted one. The (shape,
/// view) pairs are visited epoch by epoch in a seeded permutation; points are drawn per item from
/// Rng::derived(seed, global item number) without replacement (with replacement only when N exceeds the file).
class BatchSampler {
 public:
  BatchSampler(const Dataset& data, const BatchSettings& settings);
  /// Batch number `step` (0-based). Items are loaded in parallel (TBB); result is identical for any threads.
  [[nodiscard]] SdfBatch batch(long step) const { return batch(step, 0, settings_.batch_size); }
  /// Items [begin, end) of batch `step` only (a rank's share in data-parallel training): the same values as the
  /// corresponding items of batch(step).
  [[nodiscard]] SdfBatch batch(long step, int begin, int end) const;
  /// Number of (shape, view) pairs = items per epoch.
  [[nodiscard]] long items_per_epoch() const { return static_cast<long>(pairs_.size()); }
  [[nodiscard]] const BatchSettings& settings() const { return settings_; }

 private:
  const Dataset* data_;
  BatchSettings settings_;
  std::vector<std::pair<int, int>> pairs_;  // (shape, view)
};

/// Draw `n` rows of `samples` (N x 4) with a seeded generator: without replacement when n <= N.
void draw_samples(const MatrixXfR& samples, int n, uint64_t seed, PointsF& points, Eigen::VectorXf& sdf);

}  // namespace sdfkit

namespace sdfkit {

/// Photometric augmentation of network input images that never moves the object (the camera of a training item
/// stays exact). Every operation acts on the "ink" 1 - x (the image is composited on a white background,
/// kNetBackground = 1), so the background stays exactly white and an anti-aliased edge pixel a*c + (1 - a) becomes
/// a*c' + (1 - a): the result is what a render of the same object with another colour would give.
///   - colour: per image, ink gains g_c = b * u_c with b ~ U(1 - colour, 1 + colour) (brightness) and
///     u_c ~ U(1 - colour/2, 1 + colour/2) per channel (tint); x' = clamp(1 - g_c (1 - x), 0, 1).
///   - channel_swap: with this probability, a uniformly chosen permutation of the RGB channels (6 orders).
///   - noise: Gaussian pixel noise of this standard deviation on every pixel (background too), clamped to [0, 1].
/// All zero = identity. Image b of a batch draws from Rng::derived(seed, stream + b) only, so the result does not
/// depend on the thread count or on other images.
struct ImageAugmentSettings {
  double colour = 0;        ///< brightness/tint strength in [0, 1)
  double channel_swap = 0;  ///< probability of an RGB permutation, [0, 1]
  double noise = 0;         ///< pixel noise standard deviation (images in [0, 1])

  [[nodiscard]] bool enabled() const { return colour > 0 || channel_swap > 0 || noise > 0; }
  [[nodiscard]] Json to_json() const;
};

/// Augment B x (3 * S * S) channels-first rows in place (S = sqrt(cols / 3)); see ImageAugmentSettings.
/// Throws InvalidInput on settings out of range or on rows that are not 3 square channels.
void augment_images(MatrixXfR& images, const ImageAugmentSettings& settings, uint64_t seed, uint64_t stream);

/// Zoom augmentation: objects at other scales in the image than the renders' (recon frames real inputs to the
/// renders' median object size, whatever the photo's scale).
///   - With probability `prob` an image is magnified by k about its centre (log-uniform in [min, max]), resampled
///     bilinearly (2 x 2 samples per pixel when shrinking), white outside the source. k is lowered when the magnified object would
///     leave the image (its non-white pixels stay at least one pixel inside the border).
///   - The camera follows in one of two ways (`camera`):
///     - kDistance (the pose estimator, which must answer with the distance the object's size implies): weak
///       perspective, t.z becomes t.z / k. For the prepared views (look-at cameras, the object-frame origin at the
///       image centre) this is exact for the origin and, for a unit-sphere object at distance 2.5, within about 6%
///       for its farthest points: the intrinsics stay DISN's, as that network assumes.
///     - kFocal (the SDF network, which projects points with the camera it is given): the intrinsics are magnified
///       about the image centre c (camera pixels, corner origin): f' = k f, c' = k c0 + (1 - k) c for the principal
///       point c0. Exact: every object point projects where the zoomed image shows it.
/// Image b draws from Rng::derived(seed, stream + b) only (k and the coin are always drawn, in that order).
struct ZoomAugmentSettings {
  enum class CameraFollow { kDistance, kFocal };
  double prob = 0;           ///< probability of zooming an image, [0, 1]
  double min = 1, max = 1;   ///< range of the magnification k, 0 < min <= max
  CameraFollow camera = CameraFollow::kDistance;

  [[nodiscard]] bool enabled() const { return prob > 0; }
  [[nodiscard]] Json to_json() const;
};

/// Zoom B x (3 * S * S) channels-first rows in place and their cameras with them (see ZoomAugmentSettings); the
/// magnification applied to each image in `applied` when not null (1 = left as it was). Throws InvalidInput on
/// settings out of range, rows that are not 3 square channels, or a camera count other than the row count.
void zoom_images(MatrixXfR& images, std::vector<Camera>& cameras, const ZoomAugmentSettings& settings, uint64_t seed,
                 uint64_t stream, std::vector<double>* applied = nullptr);

/// Reframing augmentation (`train sdf --aug-reframe`): the framing recon gives a real input (recon/framing.h),
/// applied to training images so that the network meets it. With probability `prob` an image is mapped by the
/// similarity that brings its object's box (ink_box) to a longer side of `extent` image sides, the box centre at
/// ((0.5 + centre_dx) S, (0.5 + centre_dy) S). The principal point goes through the same map (in the camera's
/// pixels), so it leaves the image centre as it does in recon's crop of an off-centre object; the magnification k
/// follows as in ZoomAugmentSettings (`camera`):
///   - kFocal (the SDF network): f and skew times k; exact, every object point projects where the new image shows it.
///   - kDistance (the pose estimator, whose intrinsics are DISN's but for the principal point): t.z / k, weak
///     perspective, exact for the object-frame origin.
/// All-white images stay. Image b draws its coin from Rng::derived(seed, stream + b) only.
struct ReframeAugmentSettings {
  double prob = 0;          ///< probability of reframing an image, [0, 1]
  double extent = 0.67;     ///< the object's box longer side / image side, (0, 1]
  double centre_dx = 0;     ///< box centre - image centre, image sides, x right, [-0.5, 0.5]
  double centre_dy = 0.033; ///< same, y down
  ZoomAugmentSettings::CameraFollow camera = ZoomAugmentSettings::CameraFollow::kFocal;

  [[nodiscard]] bool enabled() const { return prob > 0; }
  [[nodiscard]] Json to_json() const;
  /// Throws InvalidInput naming the setting out of range.
  void validate() const;
};

/// Point the training reframing augmentation (`train sdf|pose --aug-reframe`) at this framing, so that training
/// shows the networks what recon/framing.h frame_input gives them: extent and centre offsets from `tf`, the rest of `r` kept.
void frame_like_recon(ReframeAugmentSettings& r, const TrainingFraming& tf = {});

/// Reframe B x (3 * S * S) rows in place and their cameras with them (see ReframeAugmentSettings); the magnification
/// applied to each image in `applied` when not null (1 and untouched = left as it was; a reframed image may also get
/// k = 1). `reframed` (optional) marks the images that were. Throws InvalidInput on settings out of range, rows that
/// are not 3 square channels, or a camera count other than the row count.
void reframe_images(MatrixXfR& images, std::vector<Camera>& cameras, const ReframeAugmentSettings& settings,
                    uint64_t seed, uint64_t stream, std::vector<double>* applied = nullptr,
                    std::vector<char>* reframed = nullptr);

/// Occlusion augmentation (the occlusion paper's protocol, `train sdf --occlusion`): parts of the object's image are
/// missing data. A removed pixel becomes the white background in RGB and 1 in the image's missing-data mask, the
/// fourth input channel of an RGB + mask network (SdfNetConfig::input_channels; an RGB network sees only the white,
/// which is the paper's "set to transparent"). The geometry is camera/occlusion.h's on the network image, the object
/// being its non-white pixels (is_ink):
///   - half: the left or the right half (coin flip) of the object's box removed, split at the box's centre column;
///   - rect: one rectangle of 0.25-0.5 of the image side centred in the object's box;
///   - mixed: half or rect (coin flip).
/// With probability `prob` an image is occluded. Image b draws from Rng::derived(seed, stream + b) only.
struct OcclusionAugmentSettings {
  enum class Kind { kNone, kHalf, kRect, kMixed };
  Kind kind = Kind::kNone;
  double prob = 0.5;  ///< probability of occluding an image, [0, 1]

  [[nodiscard]] bool enabled() const { return kind != Kind::kNone && prob > 0; }
  [[nodiscard]] Json to_json() const;
};
/// "none" | "half" | "rect" | "mixed" (InvalidInput otherwise).
OcclusionAugmentSettings::Kind parse_occlusion_kind(const std::string& name);
std::string to_string(OcclusionAugmentSettings::Kind kind);

/// Apply `settings` (camera/occlusion.h) to one network image (3 * S * S channels-first, white background) in place:
/// removed pixels become white. Returns the missing-data mask (S * S, row by row, 1 = removed).
Eigen::VectorXf occlude_network_image(Eigen::Ref<Eigen::VectorXf> image, int size, const OcclusionSettings& settings,
                                      uint64_t seed);

/// Occlude B x (3 * S * S) rows in place (see OcclusionAugmentSettings); `masks` becomes B x (S * S), 1 = removed
/// (all zero for images left whole). Throws InvalidInput on settings out of range or rows that are not 3 square
/// channels.
void occlude_images(MatrixXfR& images, MatrixXfR& masks, const OcclusionAugmentSettings& settings, uint64_t seed,
                    uint64_t stream);

/// Segmentation-error augmentation (`train sdf|pose --aug-mask-error P`): with probability P an image shows what
/// recon's composite of a photo shows when the object's mask is off (train/mask_error.h: thin parts dropped to the
/// background, the outline moved by 1-2 px, a textured blob added beside the object), the object being the image's non-white pixels (is_ink).
/// The camera and the shape stay the true ones: the networks learn to read them from such composites. Applied before
/// the zoom and the reframing, whose object box then follows the erroneous mask as recon's crop does. Image b draws
/// from Rng::derived(seed, stream + b) only.
struct MaskErrorAugmentSettings {
  double prob = 0;  ///< probability of an image getting a mask error, [0, 1]
  MaskErrorSettings error;

  [[nodiscard]] bool enabled() const { return prob > 0; }
  [[nodiscard]] Json to_json() const;
  /// Throws InvalidInput naming the setting out of range.
  void validate() const;
};

/// Apply a seeded segmentation error (MaskErrorAugmentSettings) to B x (3 * S * S) rows in place; `applied`
/// (optional) marks the images that got one. Throws InvalidInput on settings out of range or rows that are not 3
/// square channels.
void mask_error_images(MatrixXfR& images, const MaskErrorAugmentSettings& settings, uint64_t seed, uint64_t stream,
                       std::vector<char>* applied = nullptr);

}  // namespace sdfkit
