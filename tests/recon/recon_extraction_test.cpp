// Reconstructor's extraction of a binary-variant model: its field (-logit / sdf_scale) is no distance, so the adaptive
// extraction's distance bound misjudges cells; following the surface from the cells kept gives the dense mesh.
#include "recon/recon.h"

#include "nets/dataset.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace sdfkit;

namespace {

SdfNetConfig small_config(SdfVariant variant) {
  SdfNetConfig c;
  c.variant = variant;
  c.encoder_channels = {8, 16};
  c.extra_convs = 0;
  c.global_features = 16;
  c.point_mlp = {8};
  c.decoder = {16, 8};
  return c;
}

/// Grid points of the recon box at `res` per axis.
Points box_grid(int res, double half) {
  Points p(static_cast<Eigen::Index>(res) * res * res, 3);
  Eigen::Index i = 0;
  for (int z = 0; z < res; ++z)
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x, ++i)
        p.row(i) = Vec3(x, y, z) * (2 * half / (res - 1)) - Vec3::Constant(half);
  return p;
}

double median(Eigen::VectorXd v) {
  std::nth_element(v.data(), v.data() + v.size() / 2, v.data() + v.size());
  return v[v.size() / 2];
}

/// A grey disc on white, 3 x 137 x 137 channels-first.
Eigen::VectorXf disc_input() {
  const int s = kNetImageSize;
  Eigen::VectorXf in = Eigen::VectorXf::Ones(3L * s * s);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x)
        if (std::hypot(x - 68.0, y - 68.0) < 35.0) in[(static_cast<Eigen::Index>(c) * s + y) * s + x] = 0.4f + 0.1f * c;
  return in;
}

}  // namespace

TEST_CASE("Reconstructor: a binary-variant model extracted adaptively with surface following gives the dense mesh") {
  const Camera camera = look_at(30.0, 20.0, 2.7, kNetImageSize, kNetImageSize);
  const Eigen::VectorXf input = disc_input();
  auto binary = std::make_unique<SdfNet>(small_config(SdfVariant::kBinary));
  binary->init(7);

  // The untrained field is nearly flat: scale the last layer (stream 2's output layer) 100 times so that it varies
  // by more than the cells' size, then shift its bias (the last parameter) so that the field's median over the box is
  // 0: the field then has an inside and an outside. The shift must move every value alike (checked), else it was no
  // bias.
  auto& store = binary->params();
  for (size_t i = store.offset(store.layers().size() - 1); i < store.size(); ++i) store.values[i] *= 100.f;
  ReconSettings s;
  s.resolution = 33;
  s.preview = false;
  const Points grid = box_grid(9, s.box_half);
  const SdfNet::ShapeCode code = binary->encode(input.data(), camera);
  Eigen::VectorXd before, after;
  binary->field(code, grid, before);
  const double m = median(before);
  store.values[store.size() - 1] += static_cast<float>(m * binary->config().sdf_scale);
  binary->field(binary->encode(input.data(), camera), grid, after);
  REQUIRE(((after - before).array() + m).abs().maxCoeff() < 1e-4);
  REQUIRE((after.array() < 0).count() > 0);
  REQUIRE((after.array() > 0).count() > 0);

  const Reconstructor rb(std::move(binary), nullptr);
  const ReconResult b = rb.run_input(input, &camera, s, "binary");
  CHECK_FALSE(b.dense);
  CHECK(b.evaluations < 33L * 33 * 33);
  CHECK(rb.extraction_safety(s) == default_extraction_safety(SdfVariant::kBinary));
  ReconSettings d = s;
  d.dense = true;
  const ReconResult bd = rb.run_input(input, &camera, d, "binary dense");
  CHECK(bd.dense);
  CHECK(bd.evaluations == 33L * 33 * 33);
  REQUIRE(bd.mesh.num_vertices() > 100);
  REQUIRE(bd.mesh.num_vertices() == b.mesh.num_vertices());
  // The network's values may differ in the last bits with the batch a point is evaluated in.
  CHECK((bd.mesh.V - b.mesh.V).cwiseAbs().maxCoeff() < 1e-5);
  CHECK(bd.mesh.F == b.mesh.F);
  // Without surface following the distance bound drops cells the surface runs through.
  ReconSettings p = s;
  p.follow_surface = false;
  p.safety = 1;
  const ReconResult bp = rb.run_input(input, &camera, p, "binary pruned");
  CHECK(bp.mesh.num_faces() < b.mesh.num_faces());
  p.follow_surface = true;
  const ReconResult bf = rb.run_input(input, &camera, p, "binary followed");
  CHECK(bf.mesh.F == b.mesh.F);
}
