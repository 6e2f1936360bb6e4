// Proves the dome analysis recovers the paper's Table 3 shell (thickness 7.7 mm, centres 1.3 mm
// apart) from synthetic inner and outer scans, and that the housing-frame transform puts the
// flange at the origin with +Z toward the scene.
#include "porthole/fit/dome.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "porthole/core/error.h"
#include "porthole/pointcloud/synthetic.h"

namespace porthole::fit {
namespace {

pointcloud::SyntheticCapOptions Cap(const Eigen::Vector3d& c, double r, uint64_t seed) {
  pointcloud::SyntheticCapOptions o;
  o.center_mm = c;
  o.radius_mm = r;
  o.n_points = 20000;
  o.noise_sigma_mm = 0.05;
  o.seed = seed;
  return o;
}

TEST(Dome, PaperTable3Shell) {
  const Eigen::Vector3d co(-0.4, -1.0, 21.5), ci(-0.4, -1.5, 20.3);
  const auto outer = pointcloud::MakeSyntheticCap(Cap(co, 83.4, 1));
  const auto inner = pointcloud::MakeSyntheticCap(Cap(ci, 75.7, 2));
  DomeAnalysisOptions o;
  o.nominal_outer_radius_mm = 83.0;
  o.nominal_thickness_mm = 8.0;
  const DomeAnalysis d = AnalyzeDome(outer.points, inner.points, o);
  ASSERT_TRUE(d.IsUsable()) << d.Report();
  const double dist = (ci - co).norm();  // 1.3 mm
  EXPECT_NEAR(d.thickness_mm, 7.7, 4 * d.sigma_thickness_mm + 1e-4);
  EXPECT_NEAR(d.center_distance_mm, dist, 4 * d.sigma_center_distance_mm + 1e-4);
  EXPECT_NEAR(d.min_wall_mm, 7.7 - dist, 0.02);
  EXPECT_NEAR(d.max_wall_mm, 7.7 + dist, 0.02);
  EXPECT_NEAR(d.outer_radius_deviation_mm, 0.4, 0.01);
  EXPECT_NEAR(d.thickness_deviation_mm, -0.3, 0.01);
  EXPECT_LT((d.center_offset_mm - (ci - co)).norm(), 0.02);
}

TEST(Dome, HousingFromFlange) {
  // A housing frame placed in the scan frame by a known rotation and flange position.
  const Eigen::Matrix3d scan_from_housing_r =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  const Eigen::Vector3d flange_in_scan(10, -20, 5);
  const Eigen::Vector3d z_in_scan = scan_from_housing_r.col(2),
                        x_in_scan = scan_from_housing_r.col(0);
  const Eigen::Vector3d scene_in_scan = flange_in_scan + 100 * z_in_scan;
  // The normal is given with the wrong sign and the x hint off the plane: both are fixed.
  const RigidTransform h =
      HousingFromFlange(flange_in_scan, -z_in_scan, scene_in_scan, x_in_scan + 0.5 * z_in_scan);
  EXPECT_LT(h.Apply(flange_in_scan).norm(), 1e-12);
  EXPECT_LT((h.rotation - scan_from_housing_r.transpose()).norm(), 1e-12);
  EXPECT_NEAR(h.rotation.determinant(), 1.0, 1e-12);
  const Eigen::Vector3d p(1, 2, 3);
  EXPECT_LT((h.Inverse().Apply(h.Apply(p)) - p).norm(), 1e-12);
  EXPECT_LT(((h.Inverse() * h).rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_THROW(HousingFromFlange(flange_in_scan, z_in_scan, flange_in_scan + x_in_scan),
               InvalidInput);
  EXPECT_THROW(HousingFromFlange(flange_in_scan, z_in_scan, scene_in_scan, z_in_scan),
               InvalidInput);
  EXPECT_THROW(HousingFromFlange(flange_in_scan, Eigen::Vector3d::Zero(), scene_in_scan),
               InvalidInput);

  // Dome results move with the frame; sizes and σ magnitudes do not change.
  const auto outer = pointcloud::MakeSyntheticCap(Cap({0, 0, 0}, 83.4, 3));
  const auto inner = pointcloud::MakeSyntheticCap(Cap({0, 0.5, -1.2}, 75.7, 4));
  const DomeAnalysis d = AnalyzeDome(outer.points, inner.points);
  const DomeAnalysis t = TransformDome(d, h);
  EXPECT_LT((t.outer.sphere.center_mm - h.Apply(d.outer.sphere.center_mm)).norm(), 1e-12);
  EXPECT_LT((t.inner.sphere.center_mm - h.Apply(d.inner.sphere.center_mm)).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(t.thickness_mm, d.thickness_mm);
  EXPECT_NEAR(t.center_distance_mm, (t.inner.sphere.center_mm - t.outer.sphere.center_mm).norm(),
              1e-12);
  EXPECT_NEAR(t.outer.sigma_center_mm.norm(), d.outer.sigma_center_mm.norm(), 1e-12);
}

TEST(Dome, DegenerateSurfaceNamesIt) {
  const auto outer = pointcloud::MakeSyntheticCap(Cap({0, 0, 0}, 83.4, 3));
  try {
    AnalyzeDome(outer.points, Eigen::Matrix3Xd::Random(3, 3));
    ADD_FAILURE();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "inner_points");
  }
}

}  // namespace
}  // namespace porthole::fit
