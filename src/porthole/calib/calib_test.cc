// Proves the bundle adjustment recovers a known camera of every model of the list from synthetic
// detections within 3σ, that its σ match the Monte-Carlo spread within a factor 1.5 (the Brown
// model and a Kannala–Brandt fisheye seen to 80° off axis), and that bad input is refused clearly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

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
  o.camera = camera::FromBrown({26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0},
                              {4288, 2848, 0.0055});
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
  const auto brown = camera::CameraModelId::kBrown;
  EXPECT_THROW(ParseFreeParameters(brown, "c,k1"), InvalidInput);
  EXPECT_EQ(FreeParametersToString(brown, ParseFreeParameters(brown, "c,x0,y0,K1,K2,P1,P2")),
            "c,x0,y0,K1,K2,P1,P2");
  EXPECT_EQ(ParseFreeParameters(brown, "default"), DefaultFree(brown));
  const auto kb = camera::CameraModelId::kKannalaBrandt;
  EXPECT_EQ(FreeParametersToString(kb, ParseFreeParameters(kb, "fx,fy_px,k4")), "fx,fy,k4");
  EXPECT_EQ(FreeParametersToString(camera::CameraModelId::kOpenCV,
                                   DefaultFree(camera::CameraModelId::kOpenCV)),
            "fx,fy,cx,cy,k1,k2,p1,p2");
}

TEST(CalibTest, RecoversKnownCameraWithin3Sigma) {
  const auto opts = PaperSet();
  const auto set = MakeSyntheticSet(opts);
  const auto r = Calibrate(set.detections, opts.target, PaperOptions());
  ASSERT_TRUE(r.covariance_ok) << r.message;
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
  std::printf("[brown] sigma0 %.3f px\n", r.sigma0_px);  // the figures docs/calibration.md quotes
  const auto& truth = opts.camera.params;
  const auto& got = r.camera.params;
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!r.free[i]) continue;
    std::printf("[brown] %s: sigma %.2g, |error| / sigma %.2f\n", std::string(kBrownParamInfo[i].name).c_str(),
                r.sigma[i], std::abs(got[i] - truth[i]) / r.sigma[i]);
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
  FreeMask free;
  for (int k = 0; k < runs; ++k) {
    opts.noise_seed = 100 + k;
    const auto r = Calibrate(MakeSyntheticSet(opts).detections, opts.target, PaperOptions());
    ASSERT_TRUE(r.covariance_ok);
    free = r.free;
    const auto& p = r.camera.params;
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
    std::printf("[brown] %s: mean sigma %.3g, Monte-Carlo spread %.3g, ratio %.2f\n",
                std::string(kBrownParamInfo[i].name).c_str(), mean_sigma[i], spread, ratio);
  }
}

TEST(CalibTest, StepwiseDropsNonSignificantParameters) {
  auto opts = PaperSet();
  // The in-air case of Table 6: no decentring.
  opts.camera.params[camera::kBrownP1] = opts.camera.params[camera::kBrownP2] = 0;
  const auto set = MakeSyntheticSet(opts);
  auto c = PaperOptions();
  c.free = ParseFreeParameters(camera::CameraModelId::kBrown, "c,x0,y0,K1,K2,K3,P1,P2");
  c.drop_insignificant = true;
  const auto r = Calibrate(set.detections, opts.target, c);
  // K3 = P1 = P2 = 0 in truth: a t-test at 2 keeps a zero parameter with probability ~5 %;
  // at least two of the three must go, and K1, K2 must stay.
  EXPECT_GE(r.dropped.size(), 2u);
  EXPECT_TRUE(r.free[camera::kBrownK1] && r.free[camera::kBrownK2]);
  for (const auto& d : r.dropped) {  // the order docs/calibration.md quotes
    std::printf("[brown] dropped %s (t %.2f)\n", std::string(kBrownParamInfo[d.index].name).c_str(), d.t);
  }
  for (const auto& s : r.significance) EXPECT_TRUE(s.significant);
}

TEST(CalibTest, SelfCalibrationWithFreeTarget) {
  auto opts = PaperSet();
  const auto set = MakeSyntheticSet(opts);
  auto c = PaperOptions();
  c.target_free = true;
  const auto r = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  EXPECT_LT(std::abs(r.camera.params[camera::kBrownC] - opts.camera.params[camera::kBrownC]),
            3 * r.sigma[camera::kBrownC]);
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

// ---------------------------------------------------------------------------------------------
// Every other model of the list, by automatic differentiation.

// A Kannala–Brandt fisheye close to the Nikkor 10.5 mm DX on a D300 (f = 10.5 mm / 5.5 µm ≈ 1909 px,
// an equisolid lens: 2 sin(θ/2) = θ(1 − θ²/24 + θ⁴/1920 …), so k1 ≈ −1/24; the frame corner
// ≈ 85° off axis), seen in 20 views that put the target up to 80° off axis.
SyntheticOptions FisheyeSet() {
  SyntheticOptions o;
  o.camera = {camera::CameraModelId::kKannalaBrandt, {4288, 2848, 0.0055},
              {1909, 1911, 2150, 1418, -0.0405, 0.0006, -0.0001, 0.00002}};
  o.target = ParseTarget("chessboard:13x9:40");
  o.n_images = 20;
  o.noise_px = 0.3;
  o.fill = 0.35;
  o.max_tilt_deg = 50;
  o.max_off_axis_deg = 85;
  return o;
}

CalibrationOptions FisheyeOptions() {
  CalibrationOptions c;
  c.model = camera::CameraModelId::kKannalaBrandt;
  c.reject_k = 0;
  return c;
}

// The largest angle off axis of any detected point (deg), through the true camera.
double MaxOffAxisDeg(const SyntheticOptions& o, const SyntheticSet& set) {
  double worst = 0;
  for (const auto& d : set.detections) {
    for (const auto& uv : d.points_px) {
      worst = std::max(worst, std::acos((*o.camera.Unproject(uv))(2)) * 180 / M_PI);
    }
  }
  return worst;
}

TEST(CalibModels, KannalaBrandtFisheyeWithin3SigmaAndSigmaMatchesMonteCarlo) {
  auto opts = FisheyeSet();
  const auto first = MakeSyntheticSet(opts);
  EXPECT_GE(MaxOffAxisDeg(opts, first), 80.0);
  const int runs = 30;
  const int n = camera::KannalaBrandtModel::kNumParams;
  std::vector<double> sum(n), sum2(n), mean_sigma(n);
  for (int k = 0; k < runs; ++k) {
    opts.noise_seed = 200 + k;
    const auto r = Calibrate(MakeSyntheticSet(opts).detections, opts.target, FisheyeOptions());
    ASSERT_TRUE(r.covariance_ok) << r.message;
    EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.1 * opts.noise_px);
    for (int i = 0; i < n; ++i) {
      ASSERT_TRUE(r.free[i]);
      if (k == 0) {
        EXPECT_LT(std::abs(r.camera.params[i] - opts.camera.params[i]), 3 * r.sigma[i])
            << camera::KannalaBrandtModel::kParams[i].name;
      }
      sum[i] += r.camera.params[i];
      sum2[i] += r.camera.params[i] * r.camera.params[i];
      mean_sigma[i] += r.sigma[i] / runs;
    }
  }
  for (int i = 0; i < n; ++i) {
    const double mean = sum[i] / runs;
    const double spread = std::sqrt((sum2[i] - runs * mean * mean) / (runs - 1));
    const double ratio = mean_sigma[i] / spread;
    EXPECT_GT(ratio, 1 / 1.5) << camera::KannalaBrandtModel::kParams[i].name;
    EXPECT_LT(ratio, 1.5) << camera::KannalaBrandtModel::kParams[i].name;
    std::printf("[kannala-brandt] %s: mean sigma %.3g, Monte-Carlo spread %.3g, ratio %.2f\n",
                std::string(camera::KannalaBrandtModel::kParams[i].name).c_str(), mean_sigma[i],
                spread, ratio);
  }
}

// Every model of the list recovers its own synthetic truth (no noise: RMS below 1e-3 px, the focal
// length to 1e-5 relative and the principal point to 1e-2 px; the solver stops at 1e-8 relative
// changes of the cost).
class CalibEveryModel : public ::testing::TestWithParam<camera::CameraModelId> {};

TEST_P(CalibEveryModel, RecoversItsOwnTruthWithoutNoise) {
  const camera::CameraModelId id = GetParam();
  const camera::ModelInfo& info = camera::Info(id);
  SyntheticOptions o;
  o.camera = camera::Camera::Ideal(id, {4288, 2848, 0.0055}, info.caps.fisheye ? 1900 : 4700);
  // A little distortion of each kind the model adjusts by default.
  const FreeMask free = DefaultFree(id);
  for (int i = info.first_distortion; i < info.num_params; ++i) {
    if (!free[i]) continue;
    o.camera.params[i] = (i % 2 ? -1 : 1) * (id == camera::CameraModelId::kBrown ? 1e-6 : 0.004);
  }
  o.camera.params[info.num_focal] += 7;  // principal point off centre
  o.target = ParseTarget("chessboard:13x9:40");
  o.n_images = 15;
  o.noise_px = 0;
  if (info.caps.fisheye) {
    o.fill = 0.4;
    o.max_off_axis_deg = 50;
  }
  const auto set = MakeSyntheticSet(o);
  CalibrationOptions c;
  c.model = id;
  c.pixel_pitch_mm = 0.0055;
  c.free = free;
  c.reject_k = 0;
  const auto r = Calibrate(set.detections, o.target, c);
  EXPECT_LT(r.rms_px, 1e-3) << info.name;
  EXPECT_NEAR(r.camera.FocalLengthPx(), o.camera.FocalLengthPx(), 1e-5 * o.camera.FocalLengthPx())
      << info.name;
  EXPECT_LT((r.camera.PrincipalPointPx() - o.camera.PrincipalPointPx()).norm(), 1e-2) << info.name;
}

INSTANTIATE_TEST_SUITE_P(AllModels, CalibEveryModel,
                         ::testing::ValuesIn([] {
                           std::vector<camera::CameraModelId> ids;
                           for (const auto& m : camera::CameraModels()) ids.push_back(m.id);
                           return ids;
                         }()),
                         [](const auto& info) {
                           std::string n(camera::Info(info.param).name);
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

TEST(CalibModels, ReducedCameraCovarianceEqualsCeresForAutodiffModels) {
  const auto opts = FisheyeSet();
  const auto set = MakeSyntheticSet(opts);
  auto c = FisheyeOptions();
  const auto fast = Calibrate(set.detections, opts.target, c);
  c.ceres_covariance = true;
  const auto ref = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(fast.covariance_ok && ref.covariance_ok) << fast.message << ref.message;
  for (int i = 0; i < camera::KannalaBrandtModel::kNumParams; ++i) {
    EXPECT_NEAR(fast.sigma[i] / ref.sigma[i], 1, 1e-6) << camera::KannalaBrandtModel::kParams[i].name;
    for (int j = 0; j < camera::KannalaBrandtModel::kNumParams; ++j) {
      EXPECT_NEAR(fast.correlation(i, j), ref.correlation(i, j), 1e-6);
    }
  }
}

TEST(CalibModels, WrongModelNamesAndMismatchedStartAreRefused) {
  auto opts = PaperSet();
  const auto set = MakeSyntheticSet(opts);
  CalibrationOptions c = PaperOptions();
  c.initial = camera::Camera::Ideal(camera::CameraModelId::kOpenCV, opts.camera.sensor, 4700);
  EXPECT_THROW(Calibrate(set.detections, opts.target, c), InvalidInput);
  c = PaperOptions();
  c.free = FreeMask(3, true);
  EXPECT_THROW(Calibrate(set.detections, opts.target, c), InvalidInput);
  EXPECT_THROW(camera::ModelFromName("pinhole2"), InvalidInput);
}

}  // namespace
}  // namespace porthole::calib
