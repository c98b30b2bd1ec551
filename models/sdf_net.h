// The DISN-style SDF network: image + camera + 3D points -> signed distance (or occupancy logit) per point.
//
//   image (3 x S x S, S = 137) -> CNN encoder: one stage per entry of encoder_channels, stride 2 (the first may
//     be stride 1), each stage's output a feature map (69, 35, 18, 9, 5 px for S = 137; 137, 69, ... with a
//     stride-1 first stage) ...
//   ... global feature G = ReLU(Linear(flatten(last map)))
//   ... local feature L(p) = bilinear samples of the maps at the projection of p through the camera
//   point feature  P(p) = PointMLP(p), one per stream
//   global stream: MLP([P_g(p), G]) -> 1
//   local stream:  MLP([P_l(p), L(p)]) -> 1
//   The first decoder layer of each stream is split by input: W_p P(p) + (W_g G + b) + sum_k sample(W_k map_k, p).
//   W_g G + b is a per-shape bias, and because bilinear sampling is linear, W_k L_k(p) = sample(W_k map_k, p):
//   the 1x1 convolutions W_k map_k run once per image and each point gathers 4 x H1 values per map instead of
//   multiplying its full local feature. Inference always works this way; training takes, per map, the cheaper of
//   the two exact orders (project then sample when the map has fewer pixels than the item has points, else
//   sample the map's channels and multiply by W_k).
//   mirror features (optional): the local stream also samples the maps at the projection of the point's mirror
//   image across the object frame's x = 0 plane, the plane ShapeNet-style shapes are symmetric about, through
//   first-layer weights of its own, so that a part hidden in the image (occluded, or behind the object) can read
//   the features of its visible twin (the symmetry-aware local features of Ladybird, Xu et al. 2020).
//   output = global + local (two-stream), or one decoder on [P, G, L(first maps)] (one-stream), or the global
//   stream alone (global-only); the binary variant has the two-stream architecture and predicts an occupancy
//   logit (trained with BCE) instead of 10 x (sdf - 0.003).
//
// SDF variants predict pred = sdf_scale * (sdf - sdf_offset) (DISN: 10 x (sdf - 0.003)); field() converts back to
// an approximate distance whose 0 level is the sdf_offset level of the true SDF (DISN's 0.003 iso-surface).
//
// The class is templated on the scalar: float for training and inference, double for gradient checks.
// Everything mutable lives in caller-owned workspaces, so one network can serve several threads at once.
#pragma once

#include "camera/camera.h"
#include "core/files.h"
#include "core/json.h"
#include "core/types.h"
#include "nets/layers.h"

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace sdfkit {

enum class SdfVariant { kTwoStream, kOneStream, kGlobalOnly, kBinary };
std::string to_string(SdfVariant v);
/// "two-stream", "one-stream", "global-only", "binary" (InvalidInput otherwise).
SdfVariant sdf_variant_from_string(const std::string& s);

struct SdfNetConfig {
  SdfVariant variant = SdfVariant::kTwoStream;
  int image_size = 137;                              ///< input is C x image_size x image_size
  /// C: 3 (RGB) or 4 (RGB + a missing-data mask: 1 where the pixel is unknown, e.g. occluded; the RGB of such a
  /// pixel is the white background). Models without the field are RGB.
  int input_channels = 3;
  /// What the fourth channel of a 4-channel network is. kMissing: the missing-data mask above (the object
  /// composited on white). kObject: the object's mask (1 = object) over an unmasked image, the object among the
  /// photograph's pixels (train/context.h; `train sdf --object-channel`). Models without the field are kMissing.
  enum class MaskChannel { kMissing, kObject };
  MaskChannel mask_channel = MaskChannel::kMissing;
  /// kObject only: the image's pixels farther than this (pixels of the image_size input) from the mask's object
  /// (coverage over 0.5) are the white background, so that the network reads the photograph only in a band around
  /// the mask, where a mask's errors mostly lie; 0 = the whole image.
  int context_band = 0;
  std::vector<int> encoder_channels{16, 32, 64, 96, 128};  ///< one stride-2 3x3 conv stage each (+ReLU)
  int extra_convs = 1;          ///< stride-1 3x3 convs added to every stage after the first
  /// Stride of the first stage: 2 (every stage halves the map), or 1: the first map has the image's resolution,
  /// as DISN's conv1 stage whose 137 px map its local features sample.
  int first_stride = 2;
  int global_features = 256;    ///< G
  std::vector<int> point_mlp{32, 64};   ///< 3 -> ... (ReLU after every layer), per stream
  std::vector<int> decoder{96, 48};     ///< hidden widths of each stream's decoder, then -> 1
  int one_stream_maps = 3;              ///< one-stream: local features from the first K maps (DISN: 3 of 5)
  /// The local stream also reads the features at the projection of (-x, y, z), with weights of its own.
  bool mirror_features = false;
  float sdf_scale = 10.f;               ///< pred = sdf_scale * (sdf - sdf_offset)
  float sdf_offset = 0.003f;

  [[nodiscard]] Json to_json() const;
  static SdfNetConfig from_json(const Json& j);  ///< IoError on missing/invalid fields
  /// A 4-channel network that reads unmasked images with the object's mask (MaskChannel::kObject).
  [[nodiscard]] bool reads_context() const { return input_channels == 4 && mask_channel == MaskChannel::kObject; }
  [[nodiscard]] bool uses_global() const { return true; }
  [[nodiscard]] bool uses_local() const { return variant != SdfVariant::kGlobalOnly; }
  [[nodiscard]] int num_streams() const {
    return variant == SdfVariant::kTwoStream || variant == SdfVariant::kBinary ? 2 : 1;
  }
};

/// Pixel positions (in the network image, pixel centres at integer coordinates as nets/bilinear_sample.h
/// expects) of object-frame points seen by `camera`, whose image is rescaled to image_size. The camera's own
/// width/height define its pixel grid; positions are scaled by image_size / width.
template <typename T>
void project_for_sampling(const Camera& camera, const PointsF& points, int image_size, T* positions_xy);

template <typename T>
class SdfNetT {
 public:
  explicit SdfNetT(const SdfNetConfig& config);
  ~SdfNetT();
  SdfNetT(const SdfNetT&) = delete;
  SdfNetT& operator=(const SdfNetT&) = delete;

  [[nodiscard]] const SdfNetConfig& config() const { return config_; }
  /// The flat parameter buffer (and gradients once allocate_grads(true)).
  ParamStore<T>& params() { return store_; }
  [[nodiscard]] const ParamStore<T>& params() const { return store_; }
  [[nodiscard]] size_t n_params() const { return store_.size(); }
  /// Xavier init from a seed (every layer from Rng::derived(seed, layer)).
  void init(uint64_t seed) { store_.init(seed); }
  void allocate_grads(bool on) { store_.allocate(on); }

  // ---- training: whole batches, activations kept in a workspace -------------------------------------------
  /// Activations of one training forward (opaque; reuse it across steps to keep buffers allocated).
  class Workspace {
   public:
    Workspace();
    ~Workspace();
    Workspace(Workspace&&) noexcept;
    Workspace& operator=(Workspace&&) noexcept;
    struct Data;
    std::unique_ptr<Data> d;
  };
  /// Forward on B images (B x C x S x S, C = input_channels, values in [0,1]), B cameras and B x N x 3 points; writes pred (B x N).
  void forward(const TensorT<T>& images, const std::vector<Camera>& cameras, const TensorT<T>& points,
               Workspace& ws, TensorT<T>& pred) const;
  /// Backward from dL/dpred (B x N) of the last forward with `ws`; ADDS parameter gradients.
  void backward(Workspace& ws, const TensorT<T>& dpred) const;
  /// Feature maps of the last forward with `ws` (B x c_k x h_k x w_k), for tests.
  [[nodiscard]] const std::vector<TensorT<T>>& maps(const Workspace& ws) const;

  // ---- inference: per-shape work once, then any number of point batches (thread-safe) ----------------------
  struct ShapeCode {
    std::vector<TensorT<T>> maps;  ///< 1 x c_k x h_k x w_k
    TensorT<T> global;             ///< 1 x G
    std::vector<TensorT<T>> bias;  ///< per stream: 1 x H1, W_g G + b (the per-shape bias of the first layer)
    /// per stream, per map used: h_k x w_k x H1 (channel-last, so the H1 values a point gathers from one pixel
    /// are contiguous), the first layer's local weights applied to every map pixel
    std::vector<std::vector<TensorT<T>>> proj;
    std::vector<std::vector<TensorT<T>>> proj_mirror;  ///< the same for the mirror features' weights
    Camera camera;
  };
  /// Encode one image (C x S x S channels-first, C = input_channels, values in [0,1]) seen from `camera`.
  ShapeCode encode(const T* image, const Camera& camera) const;
  /// Network output (pred) for points (object frame). Thread-safe; TBB-parallel over fixed blocks of
  /// min(chunk, 256) points (so the values do not depend on the thread count), each block run through the
  /// whole network with its own buffers (no gradient storage, no per-layer parallel overhead).
  void predict(const ShapeCode& code, const PointsF& points, Eigen::Matrix<T, Eigen::Dynamic, 1>& pred,
               int chunk = 8192) const;
  /// Approximate signed distance for extraction: pred / sdf_scale (SDF variants; 0 level = sdf_offset level),
  /// or -logit / sdf_scale for the binary variant (negative inside, not a distance).
  void field(const ShapeCode& code, const Points& points, Eigen::VectorXd& values, int chunk = 8192) const;
  /// Local feature of points (N x L, all maps concatenated in order) for tests.
  void local_features(const ShapeCode& code, const PointsF& points, TensorT<T>& features) const;

  /// Floating-point operations of one training step (forward + backward) on `batch` items of `points` points each:
  /// the multiply-adds of every convolution and dense layer (Layer::forward_flops) and of the bilinear gathers;
  /// backward counts weight and input gradients, except the input gradients of the image and of the points, which
  /// are never computed. Per-shape work (encoder, global feature, local projections) is counted once per item.
  [[nodiscard]] double train_step_flops(int batch, int points) const;

  /// Copy the parameters of `other`, whose configuration equals this one's except that it may read RGB (3
  /// channels) where this network reads RGB + mask (4), and may lack the mirror features this one has: the new
  /// weights (the first convolution's mask weights, the mirror features' first-layer weights) are set to 0, so
  /// this network computes exactly what `other` does on any input whose mask is 0. InvalidInput for any other
  /// configuration pair, and for identical ones (copy the parameters instead).
  void adopt_parameters(const SdfNetT& other);
  /// Whether adopt_parameters accepts a model of configuration `from` for a network of configuration `to`.
  static bool can_adopt(const SdfNetConfig& from, const SdfNetConfig& to);
  /// Start this binary network from a two-stream SDF model of the same architecture (the same configuration but for
  /// the variant): its parameters, with each stream's output layer multiplied by -scale, so that the logit starts
  /// as -scale x the model's pred (positive inside) and field() as scale x the model's field. The model may also lack
  /// the mask channel and/or the mirror features this network has (zero weights for them, as adopt_parameters; the
  /// equality then holds on inputs whose mask is 0). InvalidInput unless this is binary and `sdf_model` two-stream
  /// with otherwise equal configurations.
  void adopt_as_binary(const SdfNetT& sdf_model, T scale);
  static bool can_adopt_as_binary(const SdfNetConfig& from, const SdfNetConfig& to);

  /// Channel count of the local feature a stream sees (0 for global-only).
  [[nodiscard]] int local_channels(int stream) const;
  /// Output size (h = w) of each encoder stage.
  [[nodiscard]] std::vector<int> map_sizes() const;

 private:
  struct Impl;
  SdfNetConfig config_;
  std::unique_ptr<Impl> impl_;
  ParamStore<T> store_;
};

using SdfNet = SdfNetT<float>;

/// Save a model (network configuration + parameters; optional training state) / load one for inference.
/// load_sdf_model throws IoError naming the file when it is missing, corrupt, or not an SDF model.
void save_sdf_model(const std::string& path, const SdfNet& net, const Json& training = Json::object());
std::unique_ptr<SdfNet> load_sdf_model(const std::string& path, Json* training = nullptr);

}  // namespace sdfkit
