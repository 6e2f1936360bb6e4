#include "porthole/pointcloud/synthetic.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "porthole/core/error.h"

namespace porthole::pointcloud {

SyntheticCap MakeSyntheticCap(const SyntheticCapOptions& o) {
  RequirePositive("radius_mm", o.radius_mm);
  RequirePositive("spacing_mm", o.spacing_mm);
  RequireNonNegative("noise_sigma_mm", o.noise_sigma_mm);
  RequireNonNegative("outlier_margin_mm", o.outlier_margin_mm);
  for (int k = 0; k < 3; ++k) RequireFinite("center_mm", o.center_mm[k]);
  for (int k = 0; k < 3; ++k) RequireFinite("axis", o.axis[k]);
  if (!(o.axis.norm() > 0)) throw InvalidInput("axis", "must be a non-zero vector");
  RequireFinite("half_angle_deg", o.half_angle_deg);
  if (!(o.half_angle_deg > 0 && o.half_angle_deg <= 180))
    throw InvalidInput("half_angle_deg", "must be in (0, 180]");
  RequireFinite("outlier_fraction", o.outlier_fraction);
  if (!(o.outlier_fraction >= 0 && o.outlier_fraction < 1))
    throw InvalidInput("outlier_fraction", "must be in [0, 1)");
  if (o.n_points < 0) throw InvalidInput("n_points", "must be >= 0 (0: from spacing_mm)");

  const double theta = o.half_angle_deg * M_PI / 180.0;
  const double one_minus_cos = 1.0 - std::cos(theta);
  const double area = 2.0 * M_PI * o.radius_mm * o.radius_mm * one_minus_cos;
  const double n_real = o.n_points > 0
                            ? static_cast<double>(o.n_points)
                            : std::max(1.0, std::round(area / (o.spacing_mm * o.spacing_mm)));
  if (n_real > 5e7) throw InvalidInput("n_points", "more than 50 million points requested");
  const auto n = static_cast<Eigen::Index>(n_real);

  // Orthonormal frame (u, v, a) with a along the axis.
  const Eigen::Vector3d a = o.axis.normalized();
  const Eigen::Vector3d u = a.unitOrthogonal();
  const Eigen::Vector3d v = a.cross(u);

  SyntheticCap cap;
  cap.points.resize(3, n);
  cap.is_outlier.assign(static_cast<size_t>(n), false);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (Eigen::Index i = 0; i < n; ++i) {
    // cos(polar angle) uniform in [cos θ, 1] gives equal area per point.
    const double z = 1.0 - one_minus_cos * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * static_cast<double>(i);
    cap.points.col(i) =
        o.center_mm + o.radius_mm * (s * std::cos(phi) * u + s * std::sin(phi) * v + z * a);
  }

  std::mt19937_64 rng(o.seed);
  if (o.noise_sigma_mm > 0) {
    std::normal_distribution<double> gauss(0.0, o.noise_sigma_mm);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) cap.points(k, i) += gauss(rng);
  }
  const auto n_out =
      static_cast<Eigen::Index>(std::round(o.outlier_fraction * static_cast<double>(n)));
  if (n_out > 0) {
    const Eigen::Vector3d lo = cap.points.rowwise().minCoeff().array() - o.outlier_margin_mm;
    const Eigen::Vector3d hi = cap.points.rowwise().maxCoeff().array() + o.outlier_margin_mm;
    std::vector<Eigen::Index> idx(static_cast<size_t>(n));
    std::iota(idx.begin(), idx.end(), 0);
    // Partial Fisher–Yates: the first n_out entries are a uniform random subset.
    for (Eigen::Index k = 0; k < n_out; ++k) {
      std::uniform_int_distribution<Eigen::Index> pick(k, n - 1);
      std::swap(idx[static_cast<size_t>(k)], idx[static_cast<size_t>(pick(rng))]);
    }
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (Eigen::Index k = 0; k < n_out; ++k) {
      const Eigen::Index i = idx[static_cast<size_t>(k)];
      for (int c = 0; c < 3; ++c) cap.points(c, i) = lo[c] + (hi[c] - lo[c]) * unit(rng);
      cap.is_outlier[static_cast<size_t>(i)] = true;
    }
  }
  return cap;
}

}  // namespace porthole::pointcloud
