#include "models/sdf_net.h"

#include "core/error.h"
#include "core/json.h"
#include "nets/bilinear_sample.h"
#include "nets/checkpoint.h"
#include "nets/denormals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace sdfkit {

std::string to_string(SdfVariant v) {
  switch (v) {
    case SdfVariant::kTwoStream: return "two-stream";
    case SdfVariant::kOneStream: return "one-stream";
    case SdfVariant::kGlobalOnly: return "global-only";
    case SdfVariant::kBinary: return "binary";
  }
  return "two-stream";
}

SdfVariant sdf_variant_from_string(const std::string& s) {
  if (s == "two-stream") return SdfVariant::kTwoStream;
  if (s == "one-stream") return SdfVariant::kOneStream;
  if (s == "global-only") return SdfVariant::kGlobalOnly;
  if (s == "binary") return SdfVariant::kBinary;
  throw InvalidInput("unknown SDF network variant '" + s + "' (two-stream, one-stream, global-only, binary)");
}

Json SdfNetConfig::to_json() const {
  Json j = {{"variant", to_string(variant)},
          {"image_size", image_size},
          {"input_channels", input_channels},
          {"encoder_channels", encoder_channels},
          {"extra_convs", extra_convs},
          {"first_stride", first_stride},
          {"global_features", global_features},
          {"point_mlp", point_mlp},
          {"decoder", decoder},
          {"one_stream_maps", one_stream_maps},
          {"mirror_features", mirror_features},
          {"sdf_scale", sdf_scale},
          {"sdf_offset", sdf_offset}};
  // Written only for the object mask, so that the models written before the field existed keep their bytes.
  if (mask_channel == MaskChannel::kObject) {
    j["mask_channel"] = "object";
    j["context_band"] = context_band;
  }
  return j;
}

SdfNetConfig SdfNetConfig::from_json(const Json& j) {
  SdfNetConfig c;
  try {
    c.variant = sdf_variant_from_string(j.at("variant").get<std::string>());
    c.image_size = j.at("image_size").get<int>();
    c.input_channels = j.value("input_channels", 3);  // absent in models written before the mask channel existed
    c.encoder_channels = j.at("encoder_channels").get<std::vector<int>>();
    c.extra_convs = j.at("extra_convs").get<int>();
    c.first_stride = j.value("first_stride", 2);  // absent in models written before the option existed
    c.global_features = j.at("global_features").get<int>();
    c.point_mlp = j.at("point_mlp").get<std::vector<int>>();
    c.decoder = j.at("decoder").get<std::vector<int>>();
    c.one_stream_maps = j.at("one_stream_maps").get<int>();
    c.mirror_features = j.value("mirror_features", false);  // absent in models written before the option existed
    c.sdf_scale = j.at("sdf_scale").get<float>();
    c.sdf_offset = j.at("sdf_offset").get<float>();
    const std::string mask = j.value("mask_channel", std::string("missing"));  // absent: written before it existed
    if (mask == "object") {
      c.mask_channel = MaskChannel::kObject;
      c.context_band = j.value("context_band", 0);
    } else if (mask != "missing") {
      throw IoError("SDF network configuration: unknown mask_channel '" + mask + "' (missing, object)");
    }
  } catch (const IoError&) {
    throw;
  } catch (const InvalidInput& e) {
    throw IoError(std::string("SDF network configuration: ") + e.what());
  } catch (const std::exception& e) {
    throw IoError(std::string("SDF network configuration: missing or invalid field (") + e.what() + ")");
  }
  return c;
}

template <typename T>
void project_for_sampling(const Camera& camera, const PointsF& points, int image_size, T* positions_xy) {
  const PixelsF px = project_points(camera, points);
  // Camera pixels have their corner at 0 (centre of pixel j at j + 0.5); the sampler puts centres at integers.
  const double sx = static_cast<double>(image_size) / camera.width;
  const double sy = static_cast<double>(image_size) / camera.height;
  for (Eigen::Index i = 0; i < px.rows(); ++i) {
    positions_xy[2 * i] = static_cast<T>(px(i, 0) * sx - 0.5);
    positions_xy[2 * i + 1] = static_cast<T>(px(i, 1) * sy - 0.5);
  }
}

namespace {

template <typename T>
void add_into(TensorT<T>& acc, const TensorT<T>& x) {
  if (acc.shape != x.shape) {
    acc = x;
    return;
  }
  for (int64_t i = 0; i < acc.size(); ++i) acc[i] += x[i];
}

}  // namespace

/// Training takes a map's local term W_k sample(map_k, p) in the cheaper of two exact orders: project the map first
/// (W_k on every pixel, then each point samples H1 values) when the map has fewer pixels than the item has points,
/// else sample first (each point gathers the map's c_k channels, then one GEMM W_k over the points). The full-
/// resolution first map has 9x more pixels than a 2048-point item: projecting it would spend a 1x1 convolution and
/// a 19 MB gradient (zeroed, scattered into, then reduced) on pixels no point touches.
inline bool sample_first(int64_t points, int64_t pixels) { return points < pixels; }

template <typename T>
struct SdfNetT<T>::Impl {
  struct Stream {
    bool uses_global = true;
    int local_maps = 0;  // features of maps [0, local_maps)
    int local_channels = 0;
    Sequential<T> point_mlp;
    std::unique_ptr<Linear<T>> first_p;  // P -> H1 (bias only when the stream has no global term)
    std::unique_ptr<Linear<T>> first_g;  // G -> H1 with bias: the per-shape bias
    // The first layer's local part W_L L(p) = sum_k W_k sample(map_k, p) = sum_k sample(W_k map_k, p): the 1x1
    // convolutions W_k run once per image and each point gathers H1 values per map (exact: sampling is linear).
    std::vector<std::unique_ptr<Conv2d<T>>> local_proj;
    std::vector<std::unique_ptr<Conv2d<T>>> mirror_proj;  // the same for the mirror features (or empty)
    Activation<T> act{ActivationKind::kReLU};
    Sequential<T> rest;  // H1 -> ... -> 1
  };
  std::vector<Sequential<T>> stages;
  std::vector<int> map_channels, map_sizes;
  Sequential<T> global;  // flatten, linear, relu
  std::vector<Stream> streams;
  int max_local_maps = 0;
};

template <typename T>
struct SdfNetT<T>::Workspace::Data {
  TensorT<T> input;                            // B x 3 x S x S, centred
  std::vector<std::vector<TensorT<T>>> stage_acts;
  std::vector<TensorT<T>> maps;                // stage outputs (copies for the public accessor)
  std::vector<TensorT<T>> global_acts;
  TensorT<T> points;                           // B x N x 3
  TensorT<T> positions;                        // B x N x 2
  TensorT<T> positions_mirror;                 // B x N x 2: projections of the mirrored points
  struct StreamActs {
    std::vector<TensorT<T>> pmlp;
    TensorT<T> z, h, gbias;
    std::vector<TensorT<T>> proj;  // per map projected first: B x H1 x h_k x w_k
    std::vector<TensorT<T>> feat;  // per map sampled first: B x N x c_k
    std::vector<TensorT<T>> proj_mirror, feat_mirror;  // the same for the mirror features
    std::vector<TensorT<T>> rest;
  };
  std::vector<StreamActs> streams;
  int64_t B = 0, N = 0;
};

template <typename T>
SdfNetT<T>::Workspace::Workspace() : d(std::make_unique<Data>()) {}
template <typename T>
SdfNetT<T>::Workspace::~Workspace() = default;
template <typename T>
SdfNetT<T>::Workspace::Workspace(Workspace&&) noexcept = default;
template <typename T>
typename SdfNetT<T>::Workspace& SdfNetT<T>::Workspace::operator=(Workspace&&) noexcept = default;

template <typename T>
SdfNetT<T>::SdfNetT(const SdfNetConfig& config) : config_(config), impl_(std::make_unique<Impl>()) {
  const SdfNetConfig& c = config_;
  require(c.image_size >= 8, "SDF network: image_size must be >= 8");
  require(!c.encoder_channels.empty(), "SDF network: need at least one encoder stage");
  require(!c.point_mlp.empty() && !c.decoder.empty(), "SDF network: point MLP and decoder need widths");
  require(c.sdf_scale > 0, "SDF network: sdf_scale must be positive");
  require(c.first_stride == 1 || c.first_stride == 2, "SDF network: first_stride must be 1 or 2");
  require(c.input_channels == 3 || c.input_channels == 4, "SDF network: input_channels must be 3 (RGB) or 4 (RGB + mask)");
  require(c.mask_channel == SdfNetConfig::MaskChannel::kMissing || c.input_channels == 4,
          "SDF network: an object-mask channel needs 4 input channels");
  require(c.context_band >= 0 && c.context_band <= c.image_size, "SDF network: context_band must be in [0, image_size]");
  Impl& m = *impl_;
  // Encoder.
  int in_c = c.input_channels, size = c.image_size;
  for (size_t k = 0; k < c.encoder_channels.size(); ++k) {
    const int out_c = c.encoder_channels[k];
    require(out_c > 0, "SDF network: encoder channels must be positive");
    Sequential<T> st;
    const int stride = k == 0 ? c.first_stride : 2;
    st.template emplace<Conv2d<T>>(Conv2dSettings{in_c, out_c, 3, stride, 1, true});
    st.template emplace<Activation<T>>(ActivationKind::kReLU);
    if (k > 0)
      for (int e = 0; e < c.extra_convs; ++e) {
        st.template emplace<Conv2d<T>>(Conv2dSettings{out_c, out_c, 3, 1, 1, true});
        st.template emplace<Activation<T>>(ActivationKind::kReLU);
      }
    size = (size + 2 - 3) / stride + 1;
    require(size >= 2, "SDF network: too many encoder stages for the image size");
    m.stages.push_back(std::move(st));
    m.map_channels.push_back(out_c);
    m.map_sizes.push_back(size);
    in_c = out_c;
  }
  const int flat = in_c * size * size;
  m.global.template emplace<Flatten<T>>();
  m.global.template emplace<Linear<T>>(flat, c.global_features);
  m.global.template emplace<Activation<T>>(ActivationKind::kReLU);

  // Streams.
  const int all_maps = static_cast<int>(c.encoder_channels.size());
  auto make_stream = [&](bool uses_global, int local_maps) {
    typename Impl::Stream s;
    s.uses_global = uses_global;
    s.local_maps = local_maps;
    for (int k = 0; k < local_maps; ++k) s.local_channels += m.map_channels[k];
    int prev = 3;
    for (int w : c.point_mlp) {
      s.point_mlp.template emplace<Linear<T>>(prev, w);
      s.point_mlp.template emplace<Activation<T>>(ActivationKind::kReLU);
      prev = w;
    }
    const int h1 = c.decoder[0];
    s.first_p = std::make_unique<Linear<T>>(prev, h1, !uses_global);
    if (uses_global) s.first_g = std::make_unique<Linear<T>>(c.global_features, h1, true);
    for (int k = 0; k < local_maps; ++k) {
      s.local_proj.push_back(std::make_unique<Conv2d<T>>(Conv2dSettings{m.map_channels[k], h1, 1, 1, 0, false}));
      if (c.mirror_features)
        s.mirror_proj.push_back(std::make_unique<Conv2d<T>>(Conv2dSettings{m.map_channels[k], h1, 1, 1, 0, false}));
    }
    prev = h1;
    for (size_t i = 1; i < c.decoder.size(); ++i) {
      s.rest.template emplace<Linear<T>>(prev, c.decoder[i]);
      s.rest.template emplace<Activation<T>>(ActivationKind::kReLU);
      prev = c.decoder[i];
    }
    s.rest.template emplace<Linear<T>>(prev, 1);
    m.max_local_maps = std::max(m.max_local_maps, local_maps);
    m.streams.push_back(std::move(s));
  };
  switch (c.variant) {
    case SdfVariant::kTwoStream:
    case SdfVariant::kBinary:
      make_stream(true, 0);
      make_stream(false, all_maps);
      break;
    case SdfVariant::kOneStream:
      require(c.one_stream_maps >= 1 && c.one_stream_maps <= all_maps,
              "SDF network: one_stream_maps must be in [1, number of encoder stages]");
      make_stream(true, c.one_stream_maps);
      break;
    case SdfVariant::kGlobalOnly: make_stream(true, 0); break;
  }
  // Parameters: encoder, global head, streams (this order is the checkpoint layout).
  for (auto& st : m.stages) st.add_children_to(store_);
  m.global.add_children_to(store_);
  for (auto& s : m.streams) {
    s.point_mlp.add_children_to(store_);
    store_.add(*s.first_p);
    if (s.first_g) store_.add(*s.first_g);
    for (auto& p : s.local_proj) store_.add(*p);
    s.rest.add_children_to(store_);
  }
  // The mirror weights come last, so that a network with them extends the layout of one without.
  for (auto& s : m.streams)
    for (auto& p : s.mirror_proj) store_.add(*p);
  store_.allocate(false);
}

template <typename T>
SdfNetT<T>::~SdfNetT() = default;

template <typename T>
int SdfNetT<T>::local_channels(int stream) const {
  return impl_->streams.at(static_cast<size_t>(stream)).local_channels;
}

template <typename T>
double SdfNetT<T>::train_step_flops(int batch, int points) const {
  const Impl& m = *impl_;
  const int64_t S = config_.image_size, P = points;
  // Per item: forward f, backward 2f (weights + inputs) less the input gradients that are not computed.
  double fwd = 0, no_dx = 0;
  Shape in{1, config_.input_channels, S, S};
  for (size_t k = 0; k < m.stages.size(); ++k) {
    double first = 0;
    Shape out;
    fwd += m.stages[k].flops(in, &first, &out);
    if (k == 0) no_dx += first;  // no gradient for the image
    in = out;
  }
  fwd += m.global.flops(in);
  for (const auto& s : m.streams) {
    double first = 0;
    Shape out;
    fwd += s.point_mlp.flops({1, P, 3}, &first, &out);
    no_dx += first;  // no gradient for the points
    fwd += s.first_p->forward_flops(out);
    if (s.first_g) fwd += s.first_g->forward_flops({1, config_.global_features});
    const int64_t h1 = config_.decoder[0];
    const int sets = s.mirror_proj.empty() ? 1 : 2;  // the point's own features, and its mirror's
    for (int k = 0; k < s.local_maps; ++k) {
      const int64_t side = m.map_sizes[static_cast<size_t>(k)], c = m.map_channels[static_cast<size_t>(k)];
      if (sample_first(P, side * side)) {  // gather c channels, then one GEMM over the points
        fwd += sets * (8.0 * static_cast<double>(P * c) + 2.0 * static_cast<double>(P * c * h1));
        continue;
      }
      fwd += sets * s.local_proj[static_cast<size_t>(k)]->forward_flops({1, c, side, side});
      fwd += sets * 8.0 * static_cast<double>(P * h1);  // bilinear gather: 4 weighted taps of h1 values
    }
    fwd += s.rest.flops({1, P, h1});
  }
  return static_cast<double>(batch) * (3.0 * fwd - no_dx);
}

template <typename T>
std::vector<int> SdfNetT<T>::map_sizes() const {
  return impl_->map_sizes;
}

template <typename T>
const std::vector<TensorT<T>>& SdfNetT<T>::maps(const Workspace& ws) const {
  return ws.d->maps;
}

template <typename T>
void SdfNetT<T>::forward(const TensorT<T>& images, const std::vector<Camera>& cameras, const TensorT<T>& points,
                         Workspace& wsp, TensorT<T>& pred) const {
  auto& ws = *wsp.d;
  const Impl& m = *impl_;
  const int S = config_.image_size;
  require_rank(images, 4, "SDF network images");
  require_rank(points, 3, "SDF network points");
  const int64_t B = images.dim(0), N = points.dim(1);
  require(images.dim(1) == config_.input_channels && images.dim(2) == S && images.dim(3) == S,
          "SDF network: images must be B x " + std::to_string(config_.input_channels) + " x " + std::to_string(S) +
              " x " + std::to_string(S) + ", got " + shape_string(images.shape));
  require(points.dim(0) == B && points.dim(2) == 3, "SDF network: points must be B x N x 3");
  require(static_cast<int64_t>(cameras.size()) == B, "SDF network: one camera per image");
  ws.B = B;
  ws.N = N;
  // Encoder (input centred on 0).
  ws.input = images;
  for (auto& v : ws.input.data) v -= T(0.5);
  ws.stage_acts.resize(m.stages.size());
  ws.maps.resize(m.stages.size());
  const TensorT<T>* in = &ws.input;
  for (size_t k = 0; k < m.stages.size(); ++k) {
    m.stages[k].forward_into(*in, ws.stage_acts[k]);
    in = &ws.stage_acts[k].back();
    ws.maps[k] = *in;
  }
  m.global.forward_into(*in, ws.global_acts);
  const TensorT<T>& G = ws.global_acts.back();
  // Projections and local features.
  ws.points = points;
  ws.positions.resize({B, N, 2});
  const bool mirror = config_.mirror_features && m.max_local_maps > 0;
  if (mirror) ws.positions_mirror.resize({B, N, 2});
  if (m.max_local_maps > 0) {
    tbb::parallel_for(int64_t(0), B, [&](int64_t b) {
      PointsF p = Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 3, Eigen::RowMajor>>(points.item(b), N, 3)
                      .template cast<float>();
      project_for_sampling<T>(cameras[static_cast<size_t>(b)], p, S, ws.positions.item(b));
      if (mirror) {
        p.col(0) = -p.col(0);
        project_for_sampling<T>(cameras[static_cast<size_t>(b)], p, S, ws.positions_mirror.item(b));
      }
    });
  }
  BilinearSampleSettings bs{S, S};
  // Streams.
  ws.streams.resize(m.streams.size());
  pred.assign({B, N}, T(0));
  for (size_t si = 0; si < m.streams.size(); ++si) {
    const auto& s = m.streams[si];
    auto& a = ws.streams[si];
    s.point_mlp.forward_into(points, a.pmlp);
    const TensorT<T>& pf = Sequential<T>::output(points, a.pmlp);
    s.first_p->forward(pf, a.z);
    if (s.uses_global) {
      s.first_g->forward(G, a.gbias);
      TensorT<T> bc;
      broadcast_points(a.gbias, N, bc);
      for (int64_t i = 0; i < a.z.size(); ++i) a.z[i] += bc[i];
    }
    const int64_t h1 = a.z.dim(2);
    // z += sum_k W_k sample(map_k, positions), in the cheaper order per map.
    auto add_local = [&](const std::vector<std::unique_ptr<Conv2d<T>>>& weights, const TensorT<T>& positions,
                         std::vector<TensorT<T>>& proj, std::vector<TensorT<T>>& feat) {
      proj.resize(weights.size());
      feat.resize(weights.size());
      for (size_t k = 0; k < weights.size(); ++k) {
        const int64_t side = m.map_sizes[k], c = m.map_channels[k];
        if (sample_first(N, side * side)) {
          bilinear_sample(ws.maps[k], positions, feat[k], bs);
          MatMapT<T>(a.z.ptr(), B * N, h1).noalias() +=
              ConstMatMapT<T>(feat[k].ptr(), B * N, c) * ConstMatMapT<T>(weights[k]->params(), h1, c).transpose();
          proj[k] = TensorT<T>();
          continue;
        }
        weights[k]->forward(ws.maps[k], proj[k]);
        TensorT<T> f;
        bilinear_sample(proj[k], positions, f, bs);
        for (int64_t i = 0; i < a.z.size(); ++i) a.z[i] += f[i];
        feat[k] = TensorT<T>();
      }
    };
    add_local(s.local_proj, ws.positions, a.proj, a.feat);
    add_local(s.mirror_proj, ws.positions_mirror, a.proj_mirror, a.feat_mirror);
    s.act.forward(a.z, a.h);
    s.rest.forward_into(a.h, a.rest);
    const TensorT<T>& out = Sequential<T>::output(a.h, a.rest);
    for (int64_t i = 0; i < B * N; ++i) pred[i] += out[i];
  }
}

template <typename T>
void SdfNetT<T>::backward(Workspace& wsp, const TensorT<T>& dpred) const {
  auto& ws = *wsp.d;
  const Impl& m = *impl_;
  const int64_t B = ws.B, N = ws.N;
  require(dpred.size() == B * N, "SDF network backward: dpred must be B x N");
  TensorT<T> dout = dpred;
  dout.reshape({B, N, 1});
  const TensorT<T>& G = ws.global_acts.back();
  TensorT<T> dG({B, static_cast<int64_t>(config_.global_features)}, T(0));
  const size_t K = m.stages.size();
  std::vector<TensorT<T>> dmaps(K);
  BilinearSampleSettings bs{config_.image_size, config_.image_size};
  for (size_t si = 0; si < m.streams.size(); ++si) {
    const auto& s = m.streams[si];
    auto& a = ws.streams[si];
    TensorT<T> dh, dz, dpf;
    s.rest.backward_from(a.h, a.rest, dout, &dh);
    s.act.backward(a.z, a.h, dh, &dz);
    if (s.uses_global) {
      TensorT<T> dgb, dGs;
      broadcast_points_backward(dz, dgb);
      s.first_g->backward(G, a.gbias, dgb, &dGs);
      add_into(dG, dGs);
    }
    const int64_t h1 = dz.dim(2);
    auto local_backward = [&](const std::vector<std::unique_ptr<Conv2d<T>>>& weights, const TensorT<T>& positions,
                              const std::vector<TensorT<T>>& proj, const std::vector<TensorT<T>>& feat) {
      for (size_t k = 0; k < weights.size(); ++k) {
        if (!feat[k].empty()) {  // sampled first: z += F W_k^T
          const int64_t c = feat[k].dim(2);
          const ConstMatMapT<T> dZ(dz.ptr(), B * N, h1), F(feat[k].ptr(), B * N, c);
          MatMapT<T>(weights[k]->grads(), h1, c).noalias() += dZ.transpose() * F;
          TensorT<T> df({B, N, c});
          MatMapT<T>(df.ptr(), B * N, c).noalias() = dZ * ConstMatMapT<T>(weights[k]->params(), h1, c);
          TensorT<T> dmap;
          bilinear_sample_backward<T>(ws.maps[k], positions, df, &dmap, static_cast<TensorT<T>*>(nullptr), bs);
          add_into(dmaps[k], dmap);
          continue;
        }
        TensorT<T> dproj(proj[k].shape, T(0)), dmap;
        bilinear_sample_backward<T>(proj[k], positions, dz, &dproj, static_cast<TensorT<T>*>(nullptr), bs);
        weights[k]->backward(ws.maps[k], proj[k], dproj, &dmap);
        add_into(dmaps[k], dmap);
      }
    };
    local_backward(s.local_proj, ws.positions, a.proj, a.feat);
    local_backward(s.mirror_proj, ws.positions_mirror, a.proj_mirror, a.feat_mirror);
    const TensorT<T>& pf = Sequential<T>::output(ws.points, a.pmlp);
    s.first_p->backward(pf, a.z, dz, &dpf);
    s.point_mlp.backward_from(ws.points, a.pmlp, dpf, nullptr);
  }
  {
    TensorT<T> dlast;
    m.global.backward_from(ws.maps[K - 1], ws.global_acts, dG, &dlast);
    add_into(dmaps[K - 1], dlast);
  }
  // Encoder, last stage first.
  for (size_t k = K; k-- > 0;) {
    if (dmaps[k].empty()) continue;
    const TensorT<T>& in = k == 0 ? ws.input : ws.maps[k - 1];
    TensorT<T> dx;
    m.stages[k].backward_from(in, ws.stage_acts[k], dmaps[k], k > 0 ? &dx : nullptr);
    if (k > 0) add_into(dmaps[k - 1], dx);
  }
}

template <typename T>
typename SdfNetT<T>::ShapeCode SdfNetT<T>::encode(const T* image, const Camera& camera) const {
  const Impl& m = *impl_;
  const int S = config_.image_size;
  ShapeCode code;
  code.camera = camera;
  TensorT<T> x({1, config_.input_channels, S, S});
  for (int64_t i = 0; i < x.size(); ++i) x[i] = image[i] - T(0.5);
  code.maps.resize(m.stages.size());
  const TensorT<T>* in = &x;
  for (size_t k = 0; k < m.stages.size(); ++k) {
    m.stages[k].run(*in, code.maps[k]);
    in = &code.maps[k];
  }
  m.global.run(*in, code.global);
  code.bias.resize(m.streams.size());
  code.proj.resize(m.streams.size());
  code.proj_mirror.resize(m.streams.size());
  auto project = [&](const std::vector<std::unique_ptr<Conv2d<T>>>& weights, std::vector<TensorT<T>>& out) {
    out.resize(weights.size());
    for (size_t k = 0; k < weights.size(); ++k) {
      TensorT<T> chw;
      weights[k]->forward(code.maps[k], chw);
      const int64_t C = chw.dim(1), HW = chw.dim(2) * chw.dim(3);
      TensorT<T>& hwc = out[k];
      hwc.resize({chw.dim(2), chw.dim(3), C});
      for (int64_t c = 0; c < C; ++c)
        for (int64_t i = 0; i < HW; ++i) hwc[i * C + c] = chw[c * HW + i];
    }
  };
  for (size_t si = 0; si < m.streams.size(); ++si) {
    const auto& s = m.streams[si];
    if (s.uses_global) s.first_g->forward(code.global, code.bias[si]);
    project(s.local_proj, code.proj[si]);
    project(s.mirror_proj, code.proj_mirror[si]);
  }
  return code;
}

template <typename T>
void SdfNetT<T>::local_features(const ShapeCode& code, const PointsF& points, TensorT<T>& features) const {
  const Impl& m = *impl_;
  const int S = config_.image_size;
  const auto n = static_cast<int64_t>(points.rows());
  TensorT<T> pos({1, n, 2});
  project_for_sampling<T>(code.camera, points, S, pos.ptr());
  std::vector<TensorT<T>> f(m.stages.size());
  std::vector<const TensorT<T>*> parts;
  for (size_t k = 0; k < m.stages.size(); ++k) {
    bilinear_sample(code.maps[k], pos, f[k], BilinearSampleSettings{S, S});
    parts.push_back(&f[k]);
  }
  concat(parts, -1, features);
  features.reshape({n, features.dim(-1)});
}

template <typename T>
void SdfNetT<T>::predict(const ShapeCode& code, const PointsF& points, Eigen::Matrix<T, Eigen::Dynamic, 1>& pred,
                         int chunk) const {
  const Impl& m = *impl_;
  const int S = config_.image_size;
  const BilinearSampleSettings bs{S, S};
  const auto total = static_cast<int64_t>(points.rows());
  pred.setZero(total);
  require(code.bias.size() == m.streams.size() && code.proj.size() == m.streams.size() &&
              code.proj_mirror.size() == m.streams.size(),
          "SDF network: the shape code was not made by this network");
  const bool mirror = config_.mirror_features && m.max_local_maps > 0;
  const int64_t block = std::clamp<int64_t>(chunk, 1, 256);
  const int64_t blocks = (total + block - 1) / block;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, blocks), [&](const tbb::blocked_range<int64_t>& range) {
    flush_denormals_on_this_thread();
    // The chains run as every chain does (Sequential::run), on this task's buffers.
    TensorT<T> x, pf, z, out, a, b;
    std::vector<T> pos, pos_mirror;
    for (int64_t bi = range.begin(); bi < range.end(); ++bi) {
      const int64_t c0 = bi * block, n = std::min(block, total - c0);
      PointsF p = points.middleRows(c0, n);
      x.resize({n, 3});
      x.mat(n, 3) = p.template cast<T>();
      if (m.max_local_maps > 0) {
        pos.resize(static_cast<size_t>(2 * n));
        project_for_sampling<T>(code.camera, p, S, pos.data());
      }
      if (mirror) {
        pos_mirror.resize(static_cast<size_t>(2 * n));
        p.col(0) = -p.col(0);
        project_for_sampling<T>(code.camera, p, S, pos_mirror.data());
      }
      for (size_t si = 0; si < m.streams.size(); ++si) {
        const auto& s = m.streams[si];
        s.point_mlp.run(x, pf, a, b);
        s.first_p->forward(pf, z);
        const int64_t H = z.dim(-1);
        MatMapT<T> zm = z.mat(n, H);
        if (s.uses_global) zm.rowwise() += Eigen::Map<const Eigen::Matrix<T, 1, Eigen::Dynamic>>(code.bias[si].ptr(), H);
        // z += the projected maps' values at each point's position (its own, then its mirror image's).
        auto gather = [&](const std::vector<TensorT<T>>& maps, const std::vector<T>& positions) {
          for (const TensorT<T>& map : maps)
            for (int64_t i = 0; i < n; ++i)
              bilinear_accumulate_hwc(map.ptr(), map.dim(0), map.dim(1), H, positions[2 * i], positions[2 * i + 1],
                                      bs, z.ptr() + i * H);
        };
        gather(code.proj[si], pos);
        gather(code.proj_mirror[si], pos_mirror);
        zm = zm.cwiseMax(T(0));
        s.rest.run(z, out, a, b);
        pred.segment(c0, n) += Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>>(out.ptr(), n);
      }
    }
  });
}

template <typename T>
void SdfNetT<T>::field(const ShapeCode& code, const Points& points, Eigen::VectorXd& values, int chunk) const {
  Eigen::Matrix<T, Eigen::Dynamic, 1> pred;
  predict(code, points.template cast<float>(), pred, chunk);
  const double sign = config_.variant == SdfVariant::kBinary ? -1.0 : 1.0;
  values = pred.template cast<double>() * (sign / config_.sdf_scale);
}

template <typename T>
bool SdfNetT<T>::can_adopt(const SdfNetConfig& from, const SdfNetConfig& to) {
  if (from.input_channels > to.input_channels || (from.mirror_features && !to.mirror_features)) return false;
  if (from.input_channels == to.input_channels && from.mirror_features == to.mirror_features) return false;
  SdfNetConfig f = from;
  f.input_channels = to.input_channels;
  f.mirror_features = to.mirror_features;
  return f.to_json() == to.to_json();
}

template <typename T>
void SdfNetT<T>::adopt_parameters(const SdfNetT& other) {
  require(can_adopt(other.config_, config_),
          "SDF network: adopt_parameters needs a model of the same architecture that lacks only the mask channel "
          "and/or the mirror features of this one");
  const T* src = other.store_.values.data();
  T* dst = store_.values.data();
  size_t rest_src = 0, rest_dst = 0;
  if (other.config_.input_channels == 3 && config_.input_channels == 4) {
    // Layer 0 is the first convolution: weights Cout x (Cin * 3 * 3), input channel slowest, then Cout biases.
    const auto& conv = static_cast<const Conv2d<T>&>(*store_.layers().at(0));
    const int out_c = conv.settings().out_channels, k2 = conv.settings().kernel * conv.settings().kernel;
    for (int o = 0; o < out_c; ++o) {
      std::copy(src + o * 3 * k2, src + (o + 1) * 3 * k2, dst + o * 4 * k2);
      std::fill(dst + o * 4 * k2 + 3 * k2, dst + (o + 1) * 4 * k2, T(0));
    }
    std::copy(src + out_c * 3 * k2, src + out_c * 3 * k2 + out_c, dst + out_c * 4 * k2);
    rest_src = other.store_.offset(1);
    rest_dst = store_.offset(1);
  }
  // Every other layer of `other` has its twin at the same place here; the mirror weights follow them.
  const size_t n = other.store_.size() - rest_src;
  require(rest_dst + n <= store_.size(), "SDF network: parameter layouts differ");
  std::copy(src + rest_src, src + other.store_.size(), dst + rest_dst);
  std::fill(dst + rest_dst + n, dst + store_.size(), T(0));
}

template <typename T>
bool SdfNetT<T>::can_adopt_as_binary(const SdfNetConfig& from, const SdfNetConfig& to) {
  if (from.variant != SdfVariant::kTwoStream || to.variant != SdfVariant::kBinary) return false;
  SdfNetConfig f = from;
  f.variant = SdfVariant::kBinary;
  return f.to_json() == to.to_json() || can_adopt(f, to);
}

template <typename T>
void SdfNetT<T>::adopt_as_binary(const SdfNetT& sdf_model, T scale) {
  require(can_adopt_as_binary(sdf_model.config_, config_),
          "SDF network: adopt_as_binary needs a two-stream model of this binary network's architecture");
  require(scale > 0 && std::isfinite(static_cast<double>(scale)), "SDF network: adopt_as_binary needs a positive scale");
  SdfNetConfig same = sdf_model.config_;
  same.variant = SdfVariant::kBinary;
  if (same.to_json() != config_.to_json()) {
    // The model lacks the mask channel or the mirror features: widen it first (zero weights), as adopt_parameters.
    SdfNetConfig wide = config_;
    wide.variant = SdfVariant::kTwoStream;
    SdfNetT widened(wide);
    widened.adopt_parameters(sdf_model);
    adopt_as_binary(widened, scale);
    return;
  }
  require(sdf_model.store_.size() == store_.size(), "SDF network: parameter layouts differ");
  std::copy(sdf_model.store_.values.begin(), sdf_model.store_.values.begin() + static_cast<std::ptrdiff_t>(store_.size()),
            store_.values.begin());
  const auto& layers = store_.layers();
  for (auto& s : impl_->streams) {
    const Layer<T>* out = &s.rest[s.rest.size() - 1];
    const auto it = std::find(layers.begin(), layers.end(), out);
    require(it != layers.end(), "SDF network: output layer not in the parameter store");
    T* w = store_.values.data() + store_.offset(static_cast<size_t>(it - layers.begin()));
    for (size_t k = 0; k < out->n_params(); ++k) w[k] *= -scale;
  }
}

template class SdfNetT<float>;
template class SdfNetT<double>;
template void project_for_sampling<float>(const Camera&, const PointsF&, int, float*);
template void project_for_sampling<double>(const Camera&, const PointsF&, int, double*);

// ------------------------------------------------------------------------------------------------ model files
void save_sdf_model(const std::string& path, const SdfNet& net, const Json& training) {
  Checkpoint ck;
  ck.header["kind"] = "sdfkit-sdf-net";
  ck.header["config"] = net.config().to_json();
  ck.header["architecture"] = net.params().architecture();
  ck.header["n_params"] = net.n_params();
  ck.header["training"] = training;
  ck.set_block("params", std::vector<float>(net.params().values.begin(), net.params().values.end()));
  save_checkpoint(path, ck);
}

std::unique_ptr<SdfNet> load_sdf_model(const std::string& path, Json* training) {
  const Checkpoint ck = load_checkpoint(path);
  if (ck.header.value("kind", std::string()) != "sdfkit-sdf-net")
    throw IoError(path + ": not an SDF network model (header kind is '" + ck.header.value("kind", std::string()) +
                  "')");
  if (!ck.header.contains("config")) throw IoError(path + ": SDF model without a configuration");
  SdfNetConfig config;
  try {
    config = SdfNetConfig::from_json(ck.header.at("config"));
  } catch (const IoError& e) {
    throw IoError(path + ": " + e.what());
  }
  auto net = std::make_unique<SdfNet>(config);
  const auto& p = ck.block("params", static_cast<long>(net->n_params()));
  std::copy(p.begin(), p.end(), net->params().values.begin());
  if (training) *training = ck.header.value("training", Json::object());
  return net;
}

}  // namespace sdfkit
