// Synthetic scans of a spherical cap (a dome port's surface) with known ground truth, for tests,
// benchmarks and `porthole synth-scan`.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace porthole::pointcloud {

struct SyntheticCapOptions {
  double radius_mm = 83.4;                      // paper Table 3, outer sphere
  Eigen::Vector3d center_mm{-0.4, -1.0, 21.5};  // paper Table 3, outer sphere centre
  Eigen::Vector3d axis{0, 0, 1};                // cap pole direction from the centre (normalised)
  double half_angle_deg = 90;                   // 90 = hemisphere; angle from the axis, (0, 180]
  double spacing_mm = 0.25;                     // point spacing: one point per spacing² of area
  int64_t n_points = 0;                         // > 0 overrides spacing_mm (total incl. outliers)
  double noise_sigma_mm = 0;                    // isotropic Gaussian noise, σ per axis
  double outlier_fraction = 0;                  // share of points replaced by gross outliers
  double outlier_margin_mm = 10;                // outliers: uniform in the cap's bounding box
                                                // grown by this margin on every side
  uint64_t seed = 1;                            // std::mt19937_64 seed: same seed, same cloud
};

struct SyntheticCap {
  Eigen::Matrix3Xd points;       // mm, 3×N
  std::vector<bool> is_outlier;  // N flags: true for the gross outliers
};

// Equal-area (Fibonacci spiral) samples of the cap {c + R·u : angle(u, axis) ≤ half_angle}, then
// noise, then a random subset of outlier_fraction·N points replaced by outliers. Throws
// InvalidInput naming the option for non-positive radius/spacing, a zero axis, a half angle
// outside (0, 180], a negative σ, a fraction outside [0, 1) or more than 50 million points.
SyntheticCap MakeSyntheticCap(const SyntheticCapOptions& options);

}  // namespace porthole::pointcloud
