// Proves synthetic caps lie on the requested sphere within the requested cap, with the requested
// point count, noise level and outlier share, and are reproducible from the seed.
#include "porthole/pointcloud/synthetic.h"

#include <gtest/gtest.h>

#include <cmath>

#include "porthole/core/error.h"

namespace porthole::pointcloud {
namespace {

TEST(SyntheticCap, NoiselessPointsLieOnTheCap) {
  SyntheticCapOptions o;
  o.radius_mm = 50;
  o.center_mm = {1, 2, 3};
  o.axis = {1, 1, 0};
  o.half_angle_deg = 30;
  o.spacing_mm = 1.0;
  const SyntheticCap cap = MakeSyntheticCap(o);
  // Area 2πR²(1 − cos 30°) / 1 mm² ≈ 2104 points.
  EXPECT_NEAR(cap.points.cols(), 2.0 * M_PI * 2500 * (1 - std::cos(M_PI / 6)), 1.0);
  const Eigen::Vector3d a = o.axis.normalized();
  double max_angle = 0;
  for (Eigen::Index i = 0; i < cap.points.cols(); ++i) {
    const Eigen::Vector3d d = cap.points.col(i) - o.center_mm;
    EXPECT_NEAR(d.norm(), 50, 1e-9);
    max_angle = std::max(max_angle, std::acos(std::clamp(d.normalized().dot(a), -1.0, 1.0)));
  }
  EXPECT_LE(max_angle, M_PI / 6 + 1e-12);
  EXPECT_GT(max_angle, M_PI / 6 - 0.01);
}

TEST(SyntheticCap, NoiseOutliersAndSeed) {
  SyntheticCapOptions o;
  o.n_points = 20000;
  o.noise_sigma_mm = 0.1;
  o.outlier_fraction = 0.2;
  const SyntheticCap a = MakeSyntheticCap(o);
  const SyntheticCap b = MakeSyntheticCap(o);
  EXPECT_EQ(a.points, b.points);
  o.seed = 2;
  EXPECT_NE(MakeSyntheticCap(o).points, a.points);
  ASSERT_EQ(a.points.cols(), 20000);
  int n_out = 0;
  double sum2 = 0;
  for (Eigen::Index i = 0; i < a.points.cols(); ++i) {
    if (a.is_outlier[static_cast<size_t>(i)]) {
      ++n_out;
      continue;
    }
    const double r = (a.points.col(i) - o.center_mm).norm() - o.radius_mm;
    sum2 += r * r;
  }
  EXPECT_EQ(n_out, 4000);
  // Radial residual of isotropic noise has σ ≈ σ_axis (tangential parts enter at second order).
  EXPECT_NEAR(std::sqrt(sum2 / (20000 - n_out)), 0.1, 0.005);
}

TEST(SyntheticCap, RejectsBadOptions) {
  SyntheticCapOptions o;
  o.radius_mm = -1;
  EXPECT_THROW(MakeSyntheticCap(o), InvalidInput);
  o = {};
  o.axis = {0, 0, 0};
  EXPECT_THROW(MakeSyntheticCap(o), InvalidInput);
  o = {};
  o.half_angle_deg = 181;
  EXPECT_THROW(MakeSyntheticCap(o), InvalidInput);
  o = {};
  o.outlier_fraction = 1;
  EXPECT_THROW(MakeSyntheticCap(o), InvalidInput);
}

}  // namespace
}  // namespace porthole::pointcloud
