#include "refine/regularisers.h"

#include "core/error.h"
#include "core/primitives.h"
#include "core/random.h"

#include <doctest/doctest.h>

#include <cmath>
#include <functional>

using namespace sdfkit;

namespace {

Mesh bumpy(uint64_t seed) {
  Mesh m = make_icosphere(Vec3::Zero(), 1.0, 1);
  Rng rng(seed);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) m.V(i, a) += 0.1 * rng.uniform(-1, 1);
  return m;
}

using Loss = std::function<double(const Points&, double, Points&)>;

/// Largest relative difference between the analytic gradient (weight 1.7) and central differences of 1.7 * loss.
double gradient_error(const Points& V, const Loss& loss) {
  Points g = Points::Zero(V.rows(), 3), scratch = Points::Zero(V.rows(), 3);
  loss(V, 1.7, g);
  double worst = 0;
  const double h = 1e-6;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    for (int a = 0; a < 3; ++a) {
      Points p = V, m = V;
      p(i, a) += h;
      m(i, a) -= h;
      const double fd = 1.7 * (loss(p, 1.0, scratch) - loss(m, 1.0, scratch)) / (2 * h);
      worst = std::max(worst, std::abs(fd - g(i, a)) / std::max(1e-3, std::abs(fd)));
    }
  return worst;
}

}  // namespace

TEST_CASE("mesh topology: an icosahedron has 30 edges, 30 interior face pairs, 5 neighbours per vertex") {
  const Mesh m = make_icosphere(Vec3::Zero(), 1.0, 0);
  REQUIRE(m.V.rows() == 12);
  const MeshTopology t = mesh_topology(m.F, m.V.rows());
  CHECK(t.edges.size() == 30);
  CHECK(t.face_pairs.size() == 30);
  for (const auto& p : t.face_pairs) CHECK_FALSE(p.flip);
  for (Eigen::Index v = 0; v < 12; ++v) CHECK(t.offsets[static_cast<size_t>(v) + 1] - t.offsets[static_cast<size_t>(v)] == 5);
  Faces bad = m.F;
  bad(0, 0) = 12;
  CHECK_THROWS_AS(mesh_topology(bad, 12), InvalidInput);
}

TEST_CASE("regularisers: closed forms on a regular icosahedron") {
  const Mesh m = make_icosphere(Vec3::Zero(), 1.0, 0);
  const MeshTopology t = mesh_topology(m.F, m.V.rows());
  Points g = Points::Zero(12, 3);
  // Edge of the icosahedron inscribed in the unit sphere: a = 4 / sqrt(10 + 2 sqrt 5).
  const double a = 4.0 / std::sqrt(10 + 2 * std::sqrt(5.0));
  CHECK(edge_length_loss(m.V, t, 1, g) == doctest::Approx(a * a));
  // Dihedral angle: cos(pi - theta) between neighbouring face normals = sqrt(5) / 3.
  CHECK(normal_consistency_loss(m.V, m.F, t, 1, g) == doctest::Approx(1 - std::sqrt(5.0) / 3));
  // Mean of the 5 neighbours of a vertex v: (cos of the angle between neighbours, 1/sqrt 5) v; |L| = 1 - 1/sqrt 5.
  CHECK(laplacian_loss(m.V, t, 1, g) == doctest::Approx(1 - 1 / std::sqrt(5.0)));
  // Scaling the mesh leaves the normals alone and scales the others.
  Points g2 = Points::Zero(12, 3);
  const Points big = 2 * m.V;
  CHECK(edge_length_loss(big, t, 1, g2) == doctest::Approx(4 * a * a));
  CHECK(laplacian_loss(big, t, 1, g2) == doctest::Approx(2 * (1 - 1 / std::sqrt(5.0))));
  CHECK(normal_consistency_loss(big, m.F, t, 1, g2) == doctest::Approx(1 - std::sqrt(5.0) / 3));
  // A flipped face is compared with its normal turned back.
  Faces f = m.F;
  std::swap(f(0, 1), f(0, 2));
  const MeshTopology tf = mesh_topology(f, 12);
  int flips = 0;
  for (const auto& p : tf.face_pairs) flips += p.flip;
  CHECK(flips == 3);
  CHECK(normal_consistency_loss(m.V, f, tf, 1, g) == doctest::Approx(1 - std::sqrt(5.0) / 3));
}

TEST_CASE("regularisers: gradients match central differences") {
  const Mesh m = bumpy(3);
  const MeshTopology t = mesh_topology(m.F, m.V.rows());
  CHECK(gradient_error(m.V, [&](const Points& V, double w, Points& g) { return edge_length_loss(V, t, w, g); }) < 1e-6);
  CHECK(gradient_error(m.V, [&](const Points& V, double w, Points& g) {
          return normal_consistency_loss(V, m.F, t, w, g);
        }) < 1e-5);
  CHECK(gradient_error(m.V, [&](const Points& V, double w, Points& g) { return laplacian_loss(V, t, w, g); }) < 1e-5);
}
