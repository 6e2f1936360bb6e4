// Hartley's normalisation (Hartley & Zisserman, "Multiple View Geometry", §4.4.4) for the linear
// fits (homographies, DLT camera matrices) of calib and coded: the similarity that moves a point
// set's centroid to the origin and its mean distance from it to √D, so that the fit's equations
// are well conditioned whatever the units.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

namespace porthole {

// The similarity (homogeneous, (D+1)×(D+1)) normalising `p`: x ↦ s·(x − centroid), s = √D / mean
// distance (1 when every point is the centroid).
template <int D>
Eigen::Matrix<double, D + 1, D + 1> HartleyNormaliser(const std::vector<Eigen::Matrix<double, D, 1>>& p) {
  Eigen::Matrix<double, D, 1> mean = Eigen::Matrix<double, D, 1>::Zero();
  for (const auto& q : p) mean += q;
  mean /= static_cast<double>(p.size());
  double d = 0;
  for (const auto& q : p) d += (q - mean).norm();
  d /= static_cast<double>(p.size());
  const double s = d > 0 ? std::sqrt(static_cast<double>(D)) / d : 1.0;
  Eigen::Matrix<double, D + 1, D + 1> t = Eigen::Matrix<double, D + 1, D + 1>::Identity() * s;
  t(D, D) = 1;
  t.template topRightCorner<D, 1>() = -s * mean;
  return t;
}

}  // namespace porthole
