#include "metrics/sampling.h"

#include "core/error.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace sdfkit {

void require_finite_points(const Points& points, const std::string& what) {
  require(points.rows() > 0, what + ": no points");
  require(points.allFinite(), what + ": non-finite (NaN or infinite) coordinate");
}

SurfaceSamples sample_surface(const Mesh& mesh, long n, uint64_t seed, const std::string& what) {
  require(n > 0, what + ": number of surface samples must be positive");
  require(!mesh.empty(), what + ": empty mesh (no faces or no vertices)");
  require(mesh.V.allFinite(), what + ": non-finite (NaN or infinite) vertex coordinate");
  const Eigen::Index nv = mesh.V.rows(), nf = mesh.F.rows();
  require(mesh.F.minCoeff() >= 0 && mesh.F.maxCoeff() < nv, what + ": face index out of range");
  // Cumulative areas (sequential sum: deterministic).
  std::vector<double> cumulative(static_cast<size_t>(nf));
  double total = 0;
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    total += 0.5 * (b - a).cross(c - a).norm();
    cumulative[static_cast<size_t>(f)] = total;
  }
  require(total > 0 && std::isfinite(total), what + ": surface has zero area");
  Rng rng(seed);
  SurfaceSamples s;
  s.points.resize(n, 3);
  s.normals.resize(n, 3);
  s.faces.resize(n);
  for (long i = 0; i < n; ++i) {
    const double t = rng.uniform() * total;
    // First face whose cumulative area exceeds t: zero-area faces (equal cumulative values) are skipped.
    auto it = std::upper_bound(cumulative.begin(), cumulative.end(), t);
    if (it == cumulative.end()) --it;  // t rounds up to total
    const auto f = static_cast<Eigen::Index>(it - cumulative.begin());
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
    s.points.row(i) = ((1 - r1) * a + r1 * (1 - r2) * b + r1 * r2 * c).transpose();
    s.normals.row(i) = (b - a).cross(c - a).normalized().transpose();
    s.faces(i) = static_cast<int>(f);
  }
  return s;
}

Points sample_with_replacement(const Points& points, long n, uint64_t seed, const std::string& what) {
  require(n > 0, what + ": number of samples must be positive");
  require_finite_points(points, what);
  Rng rng(seed);
  Points out(n, 3);
  for (long i = 0; i < n; ++i) out.row(i) = points.row(static_cast<Eigen::Index>(rng.below(points.rows())));
  return out;
}

Points sample_without_replacement(const Points& points, long n, uint64_t seed, const std::string& what) {
  require_finite_points(points, what);
  require(n > 0 && n <= points.rows(), what + ": cannot draw " + std::to_string(n) + " distinct points of " +
                                           std::to_string(points.rows()));
  Rng rng(seed);
  std::vector<Eigen::Index> index(static_cast<size_t>(points.rows()));
  std::iota(index.begin(), index.end(), Eigen::Index(0));
  for (long i = 0; i < n; ++i) {  // partial Fisher-Yates: index[0, n) is a uniform n-subset
    const auto j = static_cast<size_t>(i) + static_cast<size_t>(rng.below(static_cast<uint64_t>(points.rows() - i)));
    std::swap(index[static_cast<size_t>(i)], index[j]);
  }
  std::sort(index.begin(), index.begin() + n);
  Points out(n, 3);
  for (long i = 0; i < n; ++i) out.row(i) = points.row(index[static_cast<size_t>(i)]);
  return out;
}

std::string to_string(CloudSampling s) {
  switch (s) {
    case CloudSampling::kAsGiven: return "as_given";
    case CloudSampling::kSubsampled: return "subsampled";
    case CloudSampling::kPadded: return "padded";
  }
  return "?";
}

Points sample_cloud(const Points& points, long n, uint64_t seed, CloudSampling* how, const std::string& what) {
  require(n > 0, what + ": number of samples must be positive");
  require_finite_points(points, what);
  CloudSampling mode = CloudSampling::kAsGiven;
  Points out;
  if (points.rows() == n) {
    out = points;
  } else if (points.rows() > n) {
    mode = CloudSampling::kSubsampled;
    out = sample_without_replacement(points, n, seed, what);
  } else {
    mode = CloudSampling::kPadded;
    out.resize(n, 3);
    out.topRows(points.rows()) = points;
    out.bottomRows(n - points.rows()) = sample_with_replacement(points, n - points.rows(), seed, what);
  }
  if (how) *how = mode;
  return out;
}

}  // namespace sdfkit
