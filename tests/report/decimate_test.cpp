// Vertex clustering (report/decimate.h): the face budget is met, the shape stays where it was, colours are averaged.
#include "core/primitives.h"
#include "report/decimate.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace sdfkit;

TEST_CASE("decimate_to: a fine sphere fits the budget and stays on the sphere") {
  const Mesh sphere = make_sphere(Vec3(0.25, 0, 0), 1.0, 96, 192);
  REQUIRE(sphere.num_faces() > 30000);
  for (const long budget : {5000L, 1000L, 200L}) {
    const Mesh d = decimate_to(sphere, budget);
    CHECK(d.num_faces() <= budget);
    CHECK(d.num_faces() > budget / 4);  // the finest grid that fits, not a far coarser one
    // A cluster's vertex is the mean of vertices on the sphere in one cell: inside the sphere, by at most the cell's
    // sagitta; the surface area stays close.
    for (Eigen::Index i = 0; i < d.V.rows(); ++i) {
      const double r = (d.V.row(i).transpose() - Vec3(0.25, 0, 0)).norm();
      CHECK(r <= 1.0 + 1e-9);
      CHECK(r > 0.8);
    }
    CHECK(surface_area(d) == doctest::Approx(4 * M_PI).epsilon(0.1));
  }
  CHECK(decimate_to(sphere, sphere.num_faces()).num_faces() == sphere.num_faces());
}

TEST_CASE("cluster_vertices: colours are the means of their cells, degenerate and repeated faces go") {
  // Two triangles sharing an edge, with a third vertex so close to vertex 0 that they share a cell.
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.01, 0.01, 0;
  m.F.resize(4, 3);
  m.F << 0, 1, 2, 1, 3, 2, 4, 1, 2, 0, 4, 1;  // face 2 repeats face 0 after clustering, face 3 collapses
  m.colors.resize(5, 3);
  m.colors << 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1, 0, 0, 0;
  const Mesh d = cluster_vertices(m, 4);
  REQUIRE(d.num_vertices() == 4);
  CHECK(d.num_faces() == 2);
  // Vertex 0 and 4 merged: position and colour are their means.
  CHECK(d.V(0, 0) == doctest::Approx(0.005));
  CHECK(d.colors(0, 0) == doctest::Approx(0.5));
  CHECK(d.colors(0, 1) == doctest::Approx(0.0));
}
