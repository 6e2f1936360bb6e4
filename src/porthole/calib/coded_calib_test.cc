// Proves `coded:BITS:RADIUS[:PROFILE]` works as a calibration target end to end: exact renders
// (coded/raster.h) of the default sheet seen by a known pinhole camera are detected through
// DetectInImage (ids = target IDs, positions from TargetPoints) and calibrated; the focal length
// comes back within 0.01 % (0.24 px of 2400; 0.057 px measured), the principal point within
// 0.1 px, residuals under 0.03 px. The error left is the uncorrected centre eccentricity (coded/
// ellipse.h): it is many σ of a noise-free adjustment, which is why the bound is not in σ.
#include <gtest/gtest.h>

#include <cstdio>
#include <opencv2/core.hpp>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/coded/raster.h"
#include "porthole/coded/sheet.h"

namespace porthole::calib {
namespace {

TEST(CodedCalib, SpecPointsAreTheDefaultSheet) {
  const TargetSpec t = ParseTarget("coded:14:2.5");
  EXPECT_EQ(t.ToString(), "coded:14:2.5:aicon");
  EXPECT_EQ(ParseTarget(t.ToString()).ToString(), t.ToString());
  const auto sheet = coded::LayoutSheet({});
  const auto pts = TargetPoints(t);
  ASSERT_EQ(static_cast<int>(pts.size()), t.NumPoints());
  ASSERT_EQ(pts.size(), sheet.targets.size() + 1);
  for (const auto& p : sheet.targets) EXPECT_EQ(pts[p.id], p.xyz_mm);
  EXPECT_EQ(ParseTarget("coded:12:3:Metashape").ToString(), "coded:12:3:metashape");
}

TEST(CodedCalib, RecoversARenderedPinholeCamera) {
  const TargetSpec t = ParseTarget("coded:14:2.5");
  coded::RasterOptions ro;
  ro.radius_mm = t.dot_radius_mm;
  ro.subrows = 16;
  const auto sheet = coded::LayoutSheet({});
  std::vector<ImageDetections> dets;
  const double tilts[][3] = {{0, 0, 0}, {25, 0, 10}, {25, 90, -15}, {35, 45, 30}, {35, 135, 60}, {30, 200, 90}, {20, 300, -60}, {40, 250, 5}};
  for (const auto& v : tilts) {
    const coded::SheetView view = coded::LookAtSheet(Eigen::Vector2d(105, 140), 560, v[0], v[1], v[2], 2400, 1200, 900);
    const auto cov = coded::RasterizeTargets(view.width, view.height, view.H(), sheet.targets, ro);
    cv::Mat img(view.height, view.width, CV_8U);
    for (int r = 0; r < view.height; ++r)
      for (int c = 0; c < view.width; ++c) img.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>(217 - 191 * cov[r * view.width + c]);
    ImageDetections d;
    d.image = "view" + std::to_string(dets.size());
    d.width_px = view.width;
    d.height_px = view.height;
    std::vector<cv::Point2f> pts;
    ASSERT_TRUE(DetectInImage(img, t, &d.ids, &pts)) << d.image;
    for (const auto& p : pts) d.points_px.emplace_back(p.x, p.y);
    dets.push_back(d);
  }
  CalibrationOptions o;  // Brown, pitch 1: millimetres are pixels; default free set c, x0, y0, K1, K2, P1, P2
  const CalibrationResult r = Calibrate(dets, t, o);
  std::printf("coded calibration: %d images, %d points, rms %.4f px; c %.3f (truth 2400, sigma %.3f), x0 %.3f, y0 %.3f "
              "(sigma %.3f, %.3f)\n", r.n_images, r.n_points, r.rms_px, r.camera.params[0], r.sigma[0], r.camera.params[1],
              r.camera.params[2], r.sigma[1], r.sigma[2]);
  EXPECT_LT(r.rms_px, 0.03);
  EXPECT_LT(std::abs(r.camera.params[0] - 2400), 1e-4 * 2400);
  EXPECT_LT(std::abs(r.camera.params[1]), 0.1);
  EXPECT_LT(std::abs(r.camera.params[2]), 0.1);
}

}  // namespace
}  // namespace porthole::calib
