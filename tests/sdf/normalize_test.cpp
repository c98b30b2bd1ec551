#include "core/error.h"
#include "core/json.h"
#include "core/primitives.h"
#include "sdf/normalize.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("normalisation: box -> centre and half diagonal, result fits the unit sphere exactly") {
  const Vec3 lo(1, 2, 3), hi(3, 3, 5);
  const Mesh b = make_box(lo, hi);
  const Normalization n = unit_sphere_normalization(b);
  CHECK((n.center - Vec3(2, 2.5, 4)).norm() < 1e-12);
  CHECK(n.radius == doctest::Approx(0.5 * (hi - lo).norm()));
  const Mesh o = apply_normalization(b, n);
  CHECK(o.V.rowwise().norm().maxCoeff() == doctest::Approx(1.0));
  const Mesh back = undo_normalization(o, n);
  CHECK((back.V - b.V).cwiseAbs().maxCoeff() < 1e-12);
  CHECK((n.from_object(n.to_object(Vec3(7, 8, 9))) - Vec3(7, 8, 9)).norm() < 1e-12);
}

TEST_CASE("normalisation: area-weighted centroid, not the vertex mean, unreferenced vertices ignored") {
  // A big square with a dense cluster of vertices in one corner: the vertex mean moves, the area centroid not.
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 2, 0, 0, 2, 2, 0, 0, 2, 0, 100, 100, 100;  // last vertex unreferenced
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  const Normalization n = unit_sphere_normalization(m);
  CHECK((n.center - Vec3(1, 1, 0)).norm() < 1e-12);
  CHECK(n.radius == doctest::Approx(std::sqrt(2.0)));
}

TEST_CASE("normalisation JSON round trip and errors") {
  Normalization n;
  n.center = Vec3(0.1, -2, 3.5);
  n.radius = 0.25;
  const Normalization back = normalization_from_json(normalization_to_json(n));
  CHECK(back.center == n.center);
  CHECK(back.radius == n.radius);
  CHECK_THROWS_AS(normalization_from_json(Json{{"norm", {1, 2, 3}}}), InvalidInput);
  CHECK_THROWS_AS(normalization_from_json(Json{{"norm", {1, 2, 3, -1}}}), InvalidInput);
  Mesh flat;
  flat.V = Points::Zero(3, 3);
  flat.F.resize(1, 3);
  flat.F << 0, 1, 2;
  CHECK_THROWS_AS(unit_sphere_normalization(flat), InvalidInput);
}
