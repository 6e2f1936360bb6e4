// Proves the bundle adjustment recovers a known camera from synthetic detections within 3σ, that
// its σ match the Monte-Carlo spread within a factor 1.5, and that bad input is refused clearly.
#include <gtest/gtest.h>

#include <cmath>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/synthetic.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using camera::kBrownNumParams;
using camera::kBrownParamInfo;

// The paper's in-water 24 mm calibration (Table 6, UW column) on a Nikon D300 (4288×2848 px,
// 5.5 µm): the truth of the synthetic sets.
SyntheticOptions PaperSet() {
  SyntheticOptions o;
  o.camera = {26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0};
  o.sensor = {4288, 2848, 0.0055};
  o.target = ParseTarget("chessboard:13x9:40");
  o.n_images = 12;
  o.noise_px = 0.3;
  return o;
}

CalibrationOptions PaperOptions() {
  CalibrationOptions c;
  c.pixel_pitch_mm = 0.0055;
  c.reject_k = 0;  // Gaussian data: no outliers to reject
  return c;
}

TEST(CalibTest, TargetSpecs) {
  const auto t = ParseTarget("chessboard:9x6:25");
  EXPECT_EQ(t.NumPoints(), 54);
  EXPECT_EQ(TargetPoints(t)[10], Eigen::Vector3d(25, 25, 0));
  EXPECT_EQ(ParseTarget(t.ToString()).ToString(), t.ToString());
  const auto a = ParseTarget("acircles:4x11:20");
  EXPECT_EQ(TargetPoints(a)[4], Eigen::Vector3d(20, 20, 0));  // row 1 shifted by one spacing
  const auto ch = ParseTarget("charuco:5x7:30:22");
  EXPECT_EQ(ch.NumPoints(), 24);
  EXPECT_EQ(TargetPoints(ch)[0], Eigen::Vector3d(30, 30, 0));
  EXPECT_THROW(ParseTarget("chessboard:9x6"), InvalidInput);
  EXPECT_THROW(ParseTarget("board:9x6:25"), InvalidInput);
  EXPECT_THROW(ParseTarget("chessboard:9x6:-1"), InvalidInput);
  EXPECT_THROW(ParseFreeParameters("c,k1"), InvalidInput);
  EXPECT_EQ(FreeParametersToString(ParseFreeParameters("c,x0,y0,K1,K2,P1,P2")),
            "c,x0,y0,K1,K2,P1,P2");
}

TEST(CalibTest, RecoversKnownCameraWithin3Sigma) {
  const auto opts = PaperSet();
  const auto set = MakeSyntheticSet(opts);
  const auto r = Calibrate(set.detections, opts.target, PaperOptions());
  ASSERT_TRUE(r.covariance_ok) << r.message;
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
  const auto truth = opts.camera.ToArray();
  const auto got = r.camera.ToArray();
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!r.free[i]) continue;
    EXPECT_LT(std::abs(got[i] - truth[i]), 3 * r.sigma[i])
        << kBrownParamInfo[i].name << " " << got[i] << " vs " << truth[i] << " σ " << r.sigma[i];
    EXPECT_GT(r.sigma[i], 0);
    EXPECT_NEAR(r.correlation(i, i), 1.0, 1e-12);
  }
  for (const auto& im : r.images) EXPECT_NEAR(im.rms_px, opts.noise_px * std::sqrt(2.0), 0.1);
}

TEST(CalibTest, SigmaMatchesMonteCarloSpread) {
  auto opts = PaperSet();
  const int runs = 30;
  std::array<double, kBrownNumParams> sum{}, sum2{}, mean_sigma{};
  FreeMask free{};
  for (int k = 0; k < runs; ++k) {
    opts.noise_seed = 100 + k;
    const auto r = Calibrate(MakeSyntheticSet(opts).detections, opts.target, PaperOptions());
    ASSERT_TRUE(r.covariance_ok);
    free = r.free;
    const auto p = r.camera.ToArray();
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (!r.free[i]) continue;
      sum[i] += p[i];
      sum2[i] += p[i] * p[i];
      mean_sigma[i] += r.sigma[i] / runs;
    }
  }
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!free[i]) continue;
    const double mean = sum[i] / runs;
    const double spread = std::sqrt((sum2[i] - runs * mean * mean) / (runs - 1));
    const double ratio = mean_sigma[i] / spread;
    EXPECT_GT(ratio, 1 / 1.5) << kBrownParamInfo[i].name;
    EXPECT_LT(ratio, 1.5) << kBrownParamInfo[i].name;
  }
}

TEST(CalibTest, StepwiseDropsNonSignificantParameters) {
  auto opts = PaperSet();
  opts.camera.P1 = opts.camera.P2 = 0;  // the in-air case of Table 6: no decentring
  const auto set = MakeSyntheticSet(opts);
  auto c = PaperOptions();
  c.free = ParseFreeParameters("c,x0,y0,K1,K2,K3,P1,P2");
  c.drop_insignificant = true;
  const auto r = Calibrate(set.detections, opts.target, c);
  // K3 = P1 = P2 = 0 in truth: a t-test at 2 keeps a zero parameter with probability ~5 %;
  // at least two of the three must go, and K1, K2 must stay.
  EXPECT_GE(r.dropped.size(), 2u);
  EXPECT_TRUE(r.free[camera::kBrownK1] && r.free[camera::kBrownK2]);
  for (const auto& s : r.significance) EXPECT_TRUE(s.significant);
}

TEST(CalibTest, SelfCalibrationWithFreeTarget) {
  auto opts = PaperSet();
  const auto set = MakeSyntheticSet(opts);
  auto c = PaperOptions();
  c.target_free = true;
  const auto r = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  EXPECT_LT(std::abs(r.camera.c_mm - opts.camera.c_mm), 3 * r.sigma[camera::kBrownC]);
  EXPECT_EQ(r.n_unknowns, 7 + 6 * r.n_images + 3 * opts.target.NumPoints() - 7);
}

TEST(CalibTest, OutliersAreRejected) {
  auto opts = PaperSet();
  auto set = MakeSyntheticSet(opts);
  for (int i = 0; i < 10; ++i) set.detections[i].points_px[i * 3] += Eigen::Vector2d(15, -10);
  auto c = PaperOptions();
  c.reject_k = 5;
  const auto r = Calibrate(set.detections, opts.target, c);
  EXPECT_GE(r.n_rejected, 10);
  EXPECT_LT(r.n_rejected, 14);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
}

TEST(CalibTest, TooFewImagesIsRefused) {
  auto opts = PaperSet();
  opts.n_images = 2;
  const auto set = MakeSyntheticSet(opts);
  try {
    Calibrate(set.detections, opts.target, PaperOptions());
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "--images");
    EXPECT_NE(std::string(e.what()).find("at least 3"), std::string::npos);
  }
}

}  // namespace
}  // namespace porthole::calib
