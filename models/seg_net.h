// The foreground segmenter (`sdfkit train seg`, `recon --segment net`): a small fully convolutional figure/ground
// network that tells the object of a photo from its background, where GrabCut seeded with the whole image fails
// on clutter and off-centre objects.
//
//   input: RGB in [0, 1] letterboxed to S x S (letterbox(): the image scaled so that its longer side is S, the rest
//          filled by replicating the edge pixels), centred by -0.5 inside
//   encoder: per stage k = 1..K one 3x3 stride-2 convolution to encoder[k] channels + `extra_convs` 3x3 stride-1
//          convolutions, ReLU after each: maps m_k of S / 2^k pixels (16-32-64-96 channels by default)
//   context: c = global average of the last map (a per-image vector)
//   decoder (hypercolumn): every pixel of the S/2 grid sees [up(m_1), ..., up(m_K), c] (each map bilinearly resized
//          to S/2, the context broadcast to every pixel) -> 1x1 convolutions decoder[0], decoder[1], ... (ReLU)
//          -> 1 logit -> bilinearly resized to S x S
//   fine branch (`fine` > 0 channels, off by default): a map m_0 of S pixels, two 3x3 stride-1 convolutions of the
//          input (ReLU), joins the hypercolumn at full resolution: the decoder's first layer sums up(z_{S/2}) and
//          W_0 m_0 on the S grid and the rest of the decoder runs there, so that the logits resolve the input's
//          pixels (a chair leg 2 px wide in the input is under one pixel of the S/2 grid)
//
// The concatenation is never materialised: the first decoder layer is linear in it, and bilinear resizing is linear
// and acts per channel, so W [up(m_1); ...; up(m_K); c] + b = sum_k up(W_k m_k) + (W_c c + b). Each map is projected
// by its own 1x1 convolution W_k at its own resolution (a 64-channel projection of an 8 x 8 map costs 64 times less
// than at 64 x 64), the projections are resized and summed, and the context's term W_c c + b is one per-image
// bias broadcast to every pixel. Backward is the adjoint of each step: the pixel gradient of the sum goes to every
// projection (through the resize's adjoint), and the broadcast bias gets its sum over the pixels.
//
// Templated on the scalar so that the whole network's gradient is checked in double (tests/models/seg_net_test.cpp);
// training and inference use SegNet = SegNetT<float>. The object keeps its activations between forward and backward
// (one forward/backward at a time per object); data-parallel training runs one replica per item, each reading the
// master's parameters (share_parameters) and owning its gradient buffer, as the pose network's training does.
#pragma once

#include "camera/image.h"
#include "core/json.h"
#include "nets/layers.h"

#include <memory>
#include <vector>

namespace sdfkit {

/// Architecture of the segmenter (stored in its checkpoints).
struct SegNetConfig {
  int size = 128;                          ///< S: side of the letterboxed input (a multiple of 2^stages)
  std::vector<int> encoder = {16, 32, 64, 96};  ///< channels of the stride-2 stages
  int extra_convs = 1;                     ///< stride-1 3x3 convolutions after each stage's first
  std::vector<int> decoder = {64, 32};     ///< widths of the 1x1 decoder layers before the logit
  int fine = 0;                            ///< channels of the full-resolution branch (0 = decoder at S/2)

  /// "fine" is written only when the branch is on, so that models without it keep their stored architecture.
  [[nodiscard]] Json to_json() const;
  /// IoError naming the problem when a field is missing or malformed ("fine" may be missing: 0).
  static SegNetConfig from_json(const Json& j);
  /// InvalidInput naming the problem (empty lists, non-positive widths, a size not divisible by 2^stages).
  void validate() const;
};

template <typename T>
class SegNetT {
 public:
  /// with_grads = false: inference only (no gradient buffer; backward() is an InvalidInput).
  explicit SegNetT(const SegNetConfig& config = {}, bool with_grads = true);
  SegNetT(const SegNetT&) = delete;
  SegNetT& operator=(const SegNetT&) = delete;

  [[nodiscard]] const SegNetConfig& config() const { return c_; }
  /// {"model": "seg_net", "config", "layers"}: stored in checkpoints and compared on load.
  [[nodiscard]] Json architecture() const;
  [[nodiscard]] size_t n_params() const { return store_.size(); }
  ParamStore<T>& params() { return store_; }
  const ParamStore<T>& params() const { return store_; }
  /// Seeded Xavier initialisation (layer i from Rng::derived(seed, i)).
  void init(uint64_t seed) { store_.init(seed); }
  /// Read `master`'s parameter values, keep own activations and gradients (data-parallel replicas).
  void share_parameters(SegNetT& master) { store_.share_values(master.store_); }
  /// Start a network with the fine branch from one without it whose settings are otherwise the same (InvalidInput
  /// otherwise): every shared parameter copied, the fine branch's convolutions as init() left them and its
  /// projection W_0 zero, so that the fine branch starts disconnected and the decoder reads the coarse hypercolumn
  /// resized to S (its parameters come last in the buffer: the coarse network's are its prefix).
  void start_from_coarse(const SegNetT& coarse);

  /// Logits B x 1 x S x S of images B x 3 x S x S (RGB in [0, 1], letterboxed). training = true keeps what
  /// backward() needs. The reference stays valid until the next forward.
  const TensorT<T>& forward(const TensorT<T>& images, bool training);
  /// After forward(..., true): ADDS the parameter gradients of sum(dlogits * logits) (call params().zero_grad()
  /// first).
  void backward(const TensorT<T>& dlogits);

  /// Floating-point operations of one forward of `batch` images (Layer::forward_flops; multiply-add = 2).
  [[nodiscard]] double forward_flops(int batch) const;

 private:
  SegNetConfig c_;
  std::vector<std::unique_ptr<Sequential<T>>> stages_;   // encoder stages
  std::vector<std::unique_ptr<Conv2d<T>>> proj_;        // 1x1 projections of the maps (first decoder layer)
  std::vector<std::unique_ptr<BilinearResize<T>>> up_;  // map k's projection to S/2 (null for stage 1)
  GlobalPool<T> pool_{PoolKind::kAverage};
  std::unique_ptr<Linear<T>> ctx_;  // context term of the first decoder layer (with its bias)
  Sequential<T> head_;              // ReLU, 1x1 convs ..., logit
  BilinearResize<T> out_up_;        // the S/2 logits to S (no fine branch) or the S/2 sum to S (fine branch)
  std::unique_ptr<Sequential<T>> fine_;  // fine branch: two 3x3 stride-1 convolutions (null when off)
  std::unique_ptr<Conv2d<T>> fine_proj_;  // its 1x1 projection W_0 (no bias)
  ParamStore<T> store_;
  // Activations of the last forward.
  TensorT<T> x_, pooled_, bias_, z_, low_, logits_, fine_map_, zfull_;
  std::vector<TensorT<T>> maps_, projected_;
};

using SegNet = SegNetT<float>;

/// The training loss of a batch of logits B x 1 x S x S against labels in [0, 1] of the same shape:
///   mean over every pixel of the binary cross-entropy on logits (nets/loss.h bce_with_logits_loss)
///   + iou_weight x mean over items of (1 - soft IoU), soft IoU = sum(p y) / (sum(p + y - p y) + 1), p = sigmoid(z).
/// The soft IoU weighs an item by its object, not by its pixel count, so that small objects count as much as large
/// ones. `grad` (may be null) receives d loss / d logits. *bce (may be null) receives the cross-entropy term alone.
/// `bce_weight` (may be null = 1 everywhere): a weight per pixel of the cross-entropy (weighted_bce_with_logits_loss,
/// still divided by the pixel count), e.g. thin_part_weights; the soft IoU is not weighted.
template <typename T>
double segmentation_loss(const TensorT<T>& logits, const TensorT<T>& labels, double iou_weight, TensorOut<T> grad,
                         double* bce = nullptr, const TensorT<T>* bce_weight = nullptr);

/// Per-pixel cross-entropy weights that stress an object's thin parts: `weight` on the label's thin parts
/// (camera/mask_morphology.h thin_parts of the pixels over 0.5, opening by a disc of `radius` px), 1 elsewhere. Labels
/// B x 1 x S x S; the result has their shape. On the test photographs of docs/results/framing.md most pixels the
/// segmenter misses are legs, arms, barrels and wing tips, and a missing part costs the reconstruction more than the
/// same area taken in. InvalidInput for weight < 1 or radius < 1.
template <typename T>
TensorT<T> thin_part_weights(const TensorT<T>& labels, double weight, int radius);

/// Where an image sits in its letterbox: scaled by `scale` to width x height pixels (longer side = size), its
/// top-left corner at (x0, y0) of the size x size square; the rest replicates the edge pixels.
struct Letterbox {
  int size = 0;
  int source_width = 0, source_height = 0;
  int width = 0, height = 0;  ///< the scaled image inside the square
  int x0 = 0, y0 = 0;
  double scale = 1;
};
/// The letterbox of a w x h image in a size x size square (InvalidInput for an empty image or size).
Letterbox letterbox_geometry(int width, int height, int size);
/// Resample `image` (any channel count) to w x h: each output pixel averages bilinear samples spread over its
/// footprint (box filter of the footprint when shrinking, bilinear when enlarging), pixel centres mapped as
/// x_in = (x_out + 0.5) W / w - 0.5.
Image resample_image(const Image& image, int width, int height);
/// The image letterboxed to size x size (same channels); its geometry in *geometry when given.
Image letterbox(const Image& image, int size, Letterbox* geometry = nullptr);
/// A letterboxed size x size 1-channel map back at the source image's size: each source pixel samples the map
/// bilinearly at its centre's place in the letterbox.
Image unletterbox(const Image& map, const Letterbox& geometry);

/// The network input of a letterboxed image: 3 x S x S channels-first RGB (to_rgb on white, clamped to [0, 1]),
/// written to item n of `x` (B x 3 x S x S).
void put_network_rgb(const Image& letterboxed, Tensor& x, int64_t n);

/// Foreground probability of every pixel of `image` (any size, 1-4 channels; alpha composited on white): the image
/// letterboxed to the network's size, the sigmoid of the logits mapped back to the image's size. 1 channel.
Image predict_foreground(SegNet& net, const Image& image);
/// The same for several images in one forward pass (the batch's items run in parallel; each item's probabilities
/// are those of predict_foreground up to float rounding in the context layer's product).
std::vector<Image> predict_foreground(SegNet& net, const std::vector<Image>& images);

/// Model files: a checkpoint with kind "seg_model", the architecture and the parameters (+ a training summary).
void save_seg_model(const std::string& path, const SegNet& net, const Json& training = Json::object());
/// Inference-only network from a model file (IoError naming the file when missing, corrupt or not a segmenter).
std::unique_ptr<SegNet> load_seg_model(const std::string& path, Json* training = nullptr);

}  // namespace sdfkit
