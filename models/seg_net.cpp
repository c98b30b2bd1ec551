#include "models/seg_net.h"

#include "camera/mask_morphology.h"
#include "core/error.h"
#include "nets/checkpoint.h"
#include "nets/loss.h"

#include <algorithm>
#include <cmath>

namespace sdfkit {

namespace {
constexpr const char* kSegKind = "seg_model";
}  // namespace

// ----------------------------------------------------------------------------------------------- configuration
Json SegNetConfig::to_json() const {
  Json j = {{"size", size}, {"encoder", encoder}, {"extra_convs", extra_convs}, {"decoder", decoder}};
  if (fine > 0) j["fine"] = fine;
  return j;
}

SegNetConfig SegNetConfig::from_json(const Json& j) {
  SegNetConfig c;
  try {
    c.size = j.at("size").get<int>();
    c.encoder = j.at("encoder").get<std::vector<int>>();
    c.extra_convs = j.at("extra_convs").get<int>();
    c.decoder = j.at("decoder").get<std::vector<int>>();
    c.fine = j.value("fine", 0);
  } catch (const Json::exception& e) {
    throw IoError(std::string("segmenter settings: malformed (") + e.what() + ")");
  }
  return c;
}

void SegNetConfig::validate() const {
  require(!encoder.empty() && encoder.size() <= 6, "segmenter: 1 to 6 encoder stages");
  require(!decoder.empty(), "segmenter: at least one decoder width");
  for (const int c : encoder) require(c > 0, "segmenter: encoder widths must be positive");
  for (const int c : decoder) require(c > 0, "segmenter: decoder widths must be positive");
  require(extra_convs >= 0 && extra_convs <= 4, "segmenter: extra convolutions per stage must be 0..4");
  require(fine >= 0 && fine <= 256, "segmenter: the fine branch's channels must be 0..256");
  const int m = 1 << encoder.size();
  require(size >= 2 * m && size % m == 0 && size <= 1024,
          "segmenter: the input size must be a multiple of " + std::to_string(m) + " (2^stages), at least " +
              std::to_string(2 * m) + " and at most 1024 (got " + std::to_string(size) + ")");
}

// ----------------------------------------------------------------------------------------------- network
template <typename T>
SegNetT<T>::SegNetT(const SegNetConfig& config, bool with_grads) : c_(config), out_up_(config.size, config.size, false) {
  c_.validate();
  const int half = c_.size / 2, H1 = c_.decoder[0];
  int in = 3;
  for (size_t k = 0; k < c_.encoder.size(); ++k) {
    const int w = c_.encoder[k];
    auto s = std::make_unique<Sequential<T>>();
    s->template emplace<Conv2d<T>>(Conv2dSettings{in, w, 3, 2, 1, true});
    s->add(relu<T>());
    for (int e = 0; e < c_.extra_convs; ++e) {
      s->template emplace<Conv2d<T>>(Conv2dSettings{w, w, 3, 1, 1, true});
      s->add(relu<T>());
    }
    stages_.push_back(std::move(s));
    proj_.push_back(std::make_unique<Conv2d<T>>(Conv2dSettings{w, H1, 1, 1, 0, false}));
    up_.push_back(k == 0 ? nullptr : std::make_unique<BilinearResize<T>>(half, half, false));
    in = w;
  }
  ctx_ = std::make_unique<Linear<T>>(c_.encoder.back(), H1, true);
  head_.add(relu<T>());
  for (size_t d = 1; d < c_.decoder.size(); ++d) {
    head_.template emplace<Conv2d<T>>(Conv2dSettings{c_.decoder[d - 1], c_.decoder[d], 1, 1, 0, true});
    head_.add(relu<T>());
  }
  head_.template emplace<Conv2d<T>>(Conv2dSettings{c_.decoder.back(), 1, 1, 1, 0, true});
  if (c_.fine > 0) {
    fine_ = std::make_unique<Sequential<T>>();
    fine_->template emplace<Conv2d<T>>(Conv2dSettings{3, c_.fine, 3, 1, 1, true});
    fine_->add(relu<T>());
    fine_->template emplace<Conv2d<T>>(Conv2dSettings{c_.fine, c_.fine, 3, 1, 1, true});
    fine_->add(relu<T>());
    fine_proj_ = std::make_unique<Conv2d<T>>(Conv2dSettings{c_.fine, H1, 1, 1, 0, false});
  }
  for (auto& s : stages_) store_.add(*s);
  for (auto& p : proj_) store_.add(*p);
  store_.add(*ctx_);
  store_.add(head_);
  if (fine_) {  // last, so that a coarse network's parameters are a prefix (start_from_coarse)
    store_.add(*fine_);
    store_.add(*fine_proj_);
  }
  store_.allocate(with_grads);
  maps_.resize(stages_.size());
  projected_.resize(stages_.size());
}

template <typename T>
Json SegNetT<T>::architecture() const {
  return {{"model", "seg_net"}, {"config", c_.to_json()}, {"layers", store_.architecture()}};
}

template <typename T>
double SegNetT<T>::forward_flops(int batch) const {
  const int S = c_.size;
  Shape in{batch, 3, S, S};
  double f = 0;
  for (size_t k = 0; k < stages_.size(); ++k) {
    f += stages_[k]->forward_flops(in);
    in = stages_[k]->output_shape(in);
    f += proj_[k]->forward_flops(in);
  }
  f += 2.0 * batch * c_.encoder.back() * c_.decoder[0];
  const int decoder_side = fine_ ? S : S / 2;
  if (fine_) {
    const Shape x{batch, 3, S, S};
    f += fine_->forward_flops(x);
    f += fine_proj_->forward_flops(fine_->output_shape(x));
  }
  f += head_.forward_flops({batch, c_.decoder[0], decoder_side, decoder_side});
  return f;
}

template <typename T>
void SegNetT<T>::start_from_coarse(const SegNetT& coarse) {
  SegNetConfig expected = c_;
  expected.fine = 0;
  require(c_.fine > 0 && coarse.config().to_json() == expected.to_json(),
          "segmenter: starting the fine branch needs a network without it and otherwise the same settings");
  const auto& from = coarse.params().values;
  require(from.size() + fine_->n_params() + fine_proj_->n_params() == store_.size(),
          "segmenter: the coarse network's parameters are not a prefix of this one's");
  std::copy(from.begin(), from.end(), store_.values.begin());
  std::fill(store_.values.end() - static_cast<std::ptrdiff_t>(fine_proj_->n_params()), store_.values.end(), T(0));
}

template <typename T>
const TensorT<T>& SegNetT<T>::forward(const TensorT<T>& images, bool training) {
  const int S = c_.size;
  require(images.rank() == 4 && images.dim(1) == 3 && images.dim(2) == S && images.dim(3) == S && images.dim(0) > 0,
          "segmenter: expected B x 3 x " + std::to_string(S) + " x " + std::to_string(S) + " images, got " +
              shape_string(images.shape));
  const int64_t B = images.dim(0), half = S / 2, HW = half * half, H1 = c_.decoder[0];
  x_.resize(images.shape);
  for (int64_t i = 0; i < images.size(); ++i) x_[i] = images[i] - T(0.5);
  for (size_t k = 0; k < stages_.size(); ++k) {
    stages_[k]->training(training);
    stages_[k]->forward(k == 0 ? x_ : maps_[k - 1], maps_[k]);
  }
  pool_.forward(maps_.back(), pooled_);
  ctx_->forward(pooled_, bias_);
  // z = sum_k up(W_k m_k) + (W_c c + b) broadcast: the first decoder layer on the hypercolumn.
  z_.assign({B, H1, half, half}, T(0));
  TensorT<T> resized;
  for (size_t k = 0; k < stages_.size(); ++k) {
    proj_[k]->forward(maps_[k], projected_[k]);
    const TensorT<T>* p = &projected_[k];
    if (up_[k]) {
      up_[k]->forward(projected_[k], resized);
      p = &resized;
    }
    for (int64_t i = 0; i < z_.size(); ++i) z_[i] += (*p)[i];
  }
  for (int64_t bc = 0; bc < B * H1; ++bc) {
    T* plane = z_.ptr() + bc * HW;
    const T b = bias_[bc];
    for (int64_t i = 0; i < HW; ++i) plane[i] += b;
  }
  head_.training(training);
  if (!fine_) {
    head_.forward(z_, low_);
    out_up_.forward(low_, logits_);
    return logits_;
  }
  // Fine branch: z on the S grid = up(z_{S/2}) + W_0 m_0, and the rest of the decoder there.
  fine_->training(training);
  fine_->forward(x_, fine_map_);
  fine_proj_->forward(fine_map_, resized);
  out_up_.forward(z_, zfull_);
  for (int64_t i = 0; i < zfull_.size(); ++i) zfull_[i] += resized[i];
  head_.forward(zfull_, logits_);
  return logits_;
}

template <typename T>
void SegNetT<T>::backward(const TensorT<T>& dlogits) {
  require(store_.has_grads(), "segmenter: backward needs a network built with gradients");
  require(head_.is_training(), "segmenter: backward needs a training forward first");
  require(dlogits.shape == logits_.shape, "segmenter backward: gradient " + shape_string(dlogits.shape) +
                                              " != logits " + shape_string(logits_.shape));
  const int64_t B = z_.dim(0), H1 = z_.dim(1), HW = z_.dim(2) * z_.dim(3);
  TensorT<T> dlow, dz, dp, dbias, dpooled, dg;
  if (!fine_) {
    out_up_.backward(low_, logits_, dlogits, &dlow);
    head_.backward(z_, low_, dlow, &dz);
  } else {
    TensorT<T> dzfull, dfine;
    head_.backward(zfull_, logits_, dlogits, &dzfull);
    fine_proj_->backward(fine_map_, zfull_ /* y: unused by a convolution's backward */, dzfull, &dfine);
    fine_->backward(x_, fine_map_, dfine, nullptr);
    out_up_.backward(z_, zfull_, dzfull, &dz);
  }
  // The broadcast bias: the sum of its pixels' gradients (in pixel order).
  dbias.assign({B, H1}, T(0));
  for (int64_t bc = 0; bc < B * H1; ++bc) {
    const T* plane = dz.ptr() + bc * HW;
    T s = 0;
    for (int64_t i = 0; i < HW; ++i) s += plane[i];
    dbias[bc] = s;
  }
  ctx_->backward(pooled_, bias_, dbias, &dpooled);
  std::vector<TensorT<T>> dmaps(stages_.size());
  for (size_t k = 0; k < stages_.size(); ++k) {
    const TensorT<T>* d = &dz;
    if (up_[k]) {
      up_[k]->backward(projected_[k], dz /* y: unused by the resize */, dz, &dp);
      d = &dp;
    }
    proj_[k]->backward(maps_[k], projected_[k], *d, &dmaps[k]);
  }
  pool_.backward(maps_.back(), pooled_, dpooled, &dg);
  for (int64_t i = 0; i < dg.size(); ++i) dmaps.back()[i] += dg[i];
  for (size_t k = stages_.size(); k-- > 0;) {
    if (k == 0) {
      stages_[k]->backward(x_, maps_[k], dmaps[k], nullptr);
    } else {
      stages_[k]->backward(maps_[k - 1], maps_[k], dmaps[k], &dg);
      for (int64_t i = 0; i < dg.size(); ++i) dmaps[k - 1][i] += dg[i];
    }
  }
}

template class SegNetT<float>;
template class SegNetT<double>;

// ----------------------------------------------------------------------------------------------- loss
template <typename T>
double segmentation_loss(const TensorT<T>& logits, const TensorT<T>& labels, double iou_weight, TensorOut<T> grad,
                         double* bce, const TensorT<T>* bce_weight) {
  require(logits.shape == labels.shape && logits.rank() == 4 && logits.size() > 0,
          "segmentation loss: logits " + shape_string(logits.shape) + " and labels " + shape_string(labels.shape) +
              " differ");
  require(iou_weight >= 0 && std::isfinite(iou_weight), "segmentation loss: the IoU weight must be >= 0");
  const double ce = bce_weight ? weighted_bce_with_logits_loss(logits, labels, *bce_weight, grad)
                               : bce_with_logits_loss(logits, labels, grad);
  if (bce) *bce = ce;
  if (iou_weight == 0) return ce;
  const int64_t B = logits.dim(0), n = logits.item_size();
  double iou_sum = 0;
  for (int64_t b = 0; b < B; ++b) {
    const T* z = logits.item(b);
    const T* y = labels.item(b);
    double inter = 0, uni = 1;  // +1: an empty label and an empty prediction agree (IoU 1 in the limit)
    for (int64_t i = 0; i < n; ++i) {
      const double p = 1.0 / (1.0 + std::exp(-static_cast<double>(z[i])));
      const double t = static_cast<double>(y[i]);
      inter += p * t;
      uni += p + t - p * t;
    }
    iou_sum += inter / uni;
    if (grad) {
      // d(1 - I/U)/dp = -(t U - I (1 - t)) / U^2, times dp/dz = p (1 - p), times iou_weight / B.
      T* g = grad->item(b);
      const double s = iou_weight / static_cast<double>(B);
      for (int64_t i = 0; i < n; ++i) {
        const double p = 1.0 / (1.0 + std::exp(-static_cast<double>(z[i])));
        const double t = static_cast<double>(y[i]);
        g[i] += static_cast<T>(-s * (t * uni - inter * (1 - t)) / (uni * uni) * p * (1 - p));
      }
    }
  }
  return ce + iou_weight * (1.0 - iou_sum / static_cast<double>(B));
}

template double segmentation_loss(const TensorT<float>&, const TensorT<float>&, double, TensorOut<float>, double*,
                                  const TensorT<float>*);
template double segmentation_loss(const TensorT<double>&, const TensorT<double>&, double, TensorOut<double>, double*,
                                  const TensorT<double>*);

template <typename T>
TensorT<T> thin_part_weights(const TensorT<T>& labels, double weight, int radius) {
  require(labels.rank() == 4 && labels.dim(1) == 1 && labels.size() > 0,
          "thin-part weights: labels must be B x 1 x H x W, not " + shape_string(labels.shape));
  require(weight >= 1 && std::isfinite(weight), "thin-part weights: the weight must be >= 1");
  require(radius >= 1, "thin-part weights: the radius must be >= 1 px");
  const int64_t B = labels.dim(0), H = labels.dim(2), W = labels.dim(3);
  TensorT<T> w(labels.shape);
  Image label(static_cast<int>(W), static_cast<int>(H), 1);
  for (int64_t b = 0; b < B; ++b) {
    const T* y = labels.item(b);
    for (int64_t i = 0; i < H * W; ++i) label.data[static_cast<size_t>(i)] = static_cast<float>(y[i]);
    const Image thin = thin_parts(label, radius);
    T* out = w.item(b);
    for (int64_t i = 0; i < H * W; ++i) out[i] = thin.data[static_cast<size_t>(i)] > 0.5f ? static_cast<T>(weight) : T(1);
  }
  return w;
}

template TensorT<float> thin_part_weights(const TensorT<float>&, double, int);
template TensorT<double> thin_part_weights(const TensorT<double>&, double, int);

// ----------------------------------------------------------------------------------------------- letterbox
Letterbox letterbox_geometry(int width, int height, int size) {
  require(width > 0 && height > 0 && size > 0, "letterbox: empty image or size");
  Letterbox g;
  g.size = size;
  g.source_width = width;
  g.source_height = height;
  g.scale = static_cast<double>(size) / std::max(width, height);
  g.width = std::clamp(static_cast<int>(std::lround(width * g.scale)), 1, size);
  g.height = std::clamp(static_cast<int>(std::lround(height * g.scale)), 1, size);
  g.x0 = (size - g.width) / 2;
  g.y0 = (size - g.height) / 2;
  return g;
}

Image resample_image(const Image& image, int width, int height) {
  require(!image.empty() && width > 0 && height > 0, "resample: empty image or size");
  const int W = image.width, H = image.height, C = image.channels;
  Image out(width, height, C);
  const double sx = static_cast<double>(W) / width, sy = static_cast<double>(H) / height;
  const int nx = std::max(1, static_cast<int>(std::ceil(sx - 1e-9))), ny = std::max(1, static_cast<int>(std::ceil(sy - 1e-9)));
  std::vector<double> acc(static_cast<size_t>(C));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      std::fill(acc.begin(), acc.end(), 0.0);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const double fx = std::clamp(x * sx + (i + 0.5) * sx / nx - 0.5, 0.0, W - 1.0);
          const double fy = std::clamp(y * sy + (j + 0.5) * sy / ny - 0.5, 0.0, H - 1.0);
          const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
          const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
          const double ax = fx - x0, ay = fy - y0;
          for (int c = 0; c < C; ++c)
            acc[static_cast<size_t>(c)] +=
                (1 - ay) * ((1 - ax) * image.at(x0, y0, c) + ax * image.at(x1, y0, c)) +
                ay * ((1 - ax) * image.at(x0, y1, c) + ax * image.at(x1, y1, c));
        }
      for (int c = 0; c < C; ++c) out.at(x, y, c) = static_cast<float>(acc[static_cast<size_t>(c)] / (nx * ny));
    }
  return out;
}

Image letterbox(const Image& image, int size, Letterbox* geometry) {
  require(!image.empty(), "letterbox: empty image");
  const Letterbox g = letterbox_geometry(image.width, image.height, size);
  const Image r = (g.width == image.width && g.height == image.height) ? image : resample_image(image, g.width, g.height);
  Image out(size, size, image.channels);
  for (int y = 0; y < size; ++y) {
    const int sy = std::clamp(y - g.y0, 0, g.height - 1);
    for (int x = 0; x < size; ++x) {
      const int sx = std::clamp(x - g.x0, 0, g.width - 1);
      for (int c = 0; c < image.channels; ++c) out.at(x, y, c) = r.at(sx, sy, c);
    }
  }
  if (geometry) *geometry = g;
  return out;
}

Image unletterbox(const Image& map, const Letterbox& g) {
  require(map.width == g.size && map.height == g.size && map.channels == 1,
          "unletterbox: expected a " + std::to_string(g.size) + " x " + std::to_string(g.size) + " 1-channel map");
  Image out(g.source_width, g.source_height, 1);
  const int S = g.size;
  for (int y = 0; y < g.source_height; ++y) {
    const double v = std::clamp(g.y0 + (y + 0.5) * g.height / g.source_height - 0.5, 0.0, S - 1.0);
    const int y0 = static_cast<int>(v), y1 = std::min(y0 + 1, S - 1);
    const double ay = v - y0;
    for (int x = 0; x < g.source_width; ++x) {
      const double u = std::clamp(g.x0 + (x + 0.5) * g.width / g.source_width - 0.5, 0.0, S - 1.0);
      const int x0 = static_cast<int>(u), x1 = std::min(x0 + 1, S - 1);
      const double ax = u - x0;
      out.at(x, y) = static_cast<float>((1 - ay) * ((1 - ax) * map.at(x0, y0) + ax * map.at(x1, y0)) +
                                        ay * ((1 - ax) * map.at(x0, y1) + ax * map.at(x1, y1)));
    }
  }
  return out;
}

void put_network_rgb(const Image& letterboxed, Tensor& x, int64_t n) {
  const int S = letterboxed.width;
  require(letterboxed.height == S && x.rank() == 4 && x.dim(1) == 3 && x.dim(2) == S && x.dim(3) == S &&
              n >= 0 && n < x.dim(0),
          "segmenter input: image and tensor sizes differ");
  const Image rgb = letterboxed.channels == 3 ? letterboxed : to_rgb(letterboxed, 1.0f);
  float* dst = x.item(n);
  const int64_t plane = int64_t(S) * S;
  for (int y = 0; y < S; ++y)
    for (int xx = 0; xx < S; ++xx)
      for (int c = 0; c < 3; ++c) {
        const float v = rgb.at(xx, y, c);
        dst[c * plane + int64_t(y) * S + xx] = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 1.0f;
      }
}

std::vector<Image> predict_foreground(SegNet& net, const std::vector<Image>& images) {
  require(!images.empty(), "segmenter: no image");
  const int S = net.config().size;
  const int64_t B = static_cast<int64_t>(images.size());
  std::vector<Letterbox> g(images.size());
  Tensor x({B, 3, S, S});
  for (int64_t n = 0; n < B; ++n) {
    const Image& image = images[static_cast<size_t>(n)];
    require(!image.empty(), "segmenter: empty image");
    put_network_rgb(letterbox(image.channels == 3 ? image : to_rgb(image, 1.0f), S, &g[static_cast<size_t>(n)]), x, n);
  }
  const Tensor& logits = net.forward(x, false);
  std::vector<Image> out;
  out.reserve(images.size());
  const int64_t SS = int64_t(S) * S;
  for (int64_t n = 0; n < B; ++n) {
    Image prob(S, S, 1);
    const float* l = logits.ptr() + n * SS;
    for (int64_t i = 0; i < SS; ++i) prob.data[static_cast<size_t>(i)] = 1.0f / (1.0f + std::exp(-l[i]));
    out.push_back(unletterbox(prob, g[static_cast<size_t>(n)]));
  }
  return out;
}

Image predict_foreground(SegNet& net, const Image& image) {
  return std::move(predict_foreground(net, std::vector<Image>{image}).front());
}

// ----------------------------------------------------------------------------------------------- model files
void save_seg_model(const std::string& path, const SegNet& net, const Json& training) {
  Checkpoint ck;
  ck.header["kind"] = kSegKind;
  ck.header["architecture"] = net.architecture();
  ck.header["training"] = training;
  ck.set_block("params", std::vector<float>(net.params().values.begin(), net.params().values.end()));
  save_checkpoint(path, ck);
}

std::unique_ptr<SegNet> load_seg_model(const std::string& path, Json* training) {
  const Checkpoint ck = load_checkpoint(path);
  if (ck.header.value("kind", std::string()) != kSegKind)
    throw IoError(path + ": not a segmenter model (kind '" + ck.header.value("kind", std::string()) + "')");
  SegNetConfig c;
  try {
    c = SegNetConfig::from_json(ck.header.at("architecture").at("config"));
  } catch (const Json::exception&) {
    throw IoError(path + ": segmenter model without its configuration");
  } catch (const IoError& e) {
    throw IoError(path + ": " + e.what());
  }
  std::unique_ptr<SegNet> net;
  try {
    net = std::make_unique<SegNet>(c, false);
  } catch (const InvalidInput& e) {
    throw IoError(path + ": segmenter model with impossible settings (" + e.what() + ")");
  }
  require_header_match(ck, "architecture", net->architecture(), path);
  const auto& p = ck.block("params", static_cast<long>(net->n_params()));
  std::copy(p.begin(), p.end(), net->params().values.begin());
  if (training) *training = ck.header.value("training", Json::object());
  return net;
}

}  // namespace sdfkit
