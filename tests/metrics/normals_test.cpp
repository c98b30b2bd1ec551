#include "metrics/normals.h"

#include "core/error.h"
#include "core/primitives.h"
#include "metrics/sampling.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

TEST_CASE("normal consistency: hand-computed example, sign-blind, and 1 for the same sphere") {
  // pred: two points with normals +z and +x; gt: one point (near the first) with normal (0, 0, -1).
  Points p(2, 3), pn(2, 3), g(1, 3), gn(1, 3);
  p << 0, 0, 0, 1, 0, 0;
  pn << 0, 0, 2, 1, 0, 0;  // lengths are normalised
  g << 0.1, 0, 0;
  gn << 0, 0, -1;
  const NormalConsistency nc = normal_consistency(p, pn, g, gn);
  CHECK(nc.accuracy == doctest::Approx(0.5));      // |+z.-z| = 1, |+x.-z| = 0
  CHECK(nc.completeness == doctest::Approx(1.0));  // gt's nearest pred is the first point
  CHECK(nc.value() == doctest::Approx(0.75));

  const Mesh sphere = make_icosphere(Vec3::Zero(), 1.0, 4);
  const SurfaceSamples a = sample_surface(sphere, 4000, 1), b = sample_surface(sphere, 4000, 2);
  CHECK(normal_consistency(a.points, a.normals, b.points, b.normals).value() > 0.99);
  // a flipped mesh has the same consistency (absolute dot product)
  CHECK(normal_consistency(a.points, -a.normals, b.points, b.normals).value() ==
        doctest::Approx(normal_consistency(a.points, a.normals, b.points, b.normals).value()));
  CHECK_THROWS_AS(normal_consistency(p, gn, g, gn), InvalidInput);  // 1 normal for 2 points
}
