// Proves the bundle adjustment recovers a known camera of every model of the list from synthetic
// detections within 3σ, that its σ match the Monte-Carlo spread within a factor 1.5 (the Brown
// model and a Kannala–Brandt fisheye seen to 80° off axis), and that bad input is refused clearly.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/synthetic.h"
#include "porthole/coded/ellipse.h"
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

// Brown calibrations of `runs` noise draws (noise seeds first_seed, first_seed + 1, …): per
// adjusted parameter the mean estimate, the mean reported σ and the Monte-Carlo spread.
struct MonteCarlo {
  FreeMask free;
  std::array<double, kBrownNumParams> mean{}, mean_sigma{}, spread{};
};

MonteCarlo RunMonteCarlo(SyntheticOptions opts, const CalibrationOptions& c, int runs, uint64_t first_seed) {
  MonteCarlo mc;
  std::array<double, kBrownNumParams> sum{}, sum2{};
  for (int k = 0; k < runs; ++k) {
    opts.noise_seed = first_seed + k;
    const auto r = Calibrate(MakeSyntheticSet(opts).detections, opts.target, c);
    EXPECT_TRUE(r.covariance_ok) << r.message;
    mc.free = r.free;
    const auto& p = r.camera.params;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (!r.free[i]) continue;
      sum[i] += p[i];
      sum2[i] += p[i] * p[i];
      mc.mean_sigma[i] += r.sigma[i] / runs;
    }
  }
  for (int i = 0; i < kBrownNumParams; ++i) {
    mc.mean[i] = sum[i] / runs;
    mc.spread[i] = std::sqrt((sum2[i] - runs * mc.mean[i] * mc.mean[i]) / (runs - 1));
  }
  return mc;
}

TEST(CalibTest, SigmaMatchesMonteCarloSpread) {
  const MonteCarlo mc = RunMonteCarlo(PaperSet(), PaperOptions(), 30, 100);
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!mc.free[i]) continue;
    const double ratio = mc.mean_sigma[i] / mc.spread[i];
    EXPECT_GT(ratio, 1 / 1.5) << kBrownParamInfo[i].name;
    EXPECT_LT(ratio, 1.5) << kBrownParamInfo[i].name;
    std::printf("[brown] %s: mean sigma %.3g, Monte-Carlo spread %.3g, ratio %.2f\n",
                std::string(kBrownParamInfo[i].name).c_str(), mc.mean_sigma[i], mc.spread[i], ratio);
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
    EXPECT_EQ(e.field(), "images");
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


// ---------------------------------------------------------------------------------------------
// 3-D target fields (coded targets with a field file): the DLT start, degenerate fields.

// The paper's pool field in miniature: a 400 × 300 mm board with a 9 × 7 grid of targets (Z = 0,
// ids 1–63) and 16 targets raised on posts 40–120 mm toward the camera (Z < 0: 10–30 % of the
// board's width; ids 64–79). `raise` scales the heights.
TargetSpec RaisedField(double raise = 1.0) {
  TargetSpec t = ParseTarget("coded:14:2.5");
  int id = 1;
  for (int r = 0; r < 7; ++r) {
    for (int c = 0; c < 9; ++c) t.field.push_back({id++, Eigen::Vector3d(50.0 * c, 50.0 * r, 0)});
  }
  for (int k = 0; k < 16; ++k) {
    const double height_mm = 40 + 80 * ((k * 7) % 16) / 15.0;
    t.field.push_back({id++, Eigen::Vector3d(25 + 100 * (k % 4), 25 + 75 * (k / 4), -raise * height_mm)});
  }
  t.field_file = "raised-board";
  return t;
}

// The paper's in-water camera (PaperSet) seeing the raised board in 12 views, synthetic centres
// (images of the dots' centres: no centre correction).
SyntheticOptions RaisedSet(double raise = 1.0) {
  SyntheticOptions o = PaperSet();
  o.target = RaisedField(raise);
  return o;
}

CalibrationOptions FieldOptions() {
  CalibrationOptions c = PaperOptions();
  c.centre_correction = CalibrationOptions::CentreCorrection::kOff;  // synthetic centres
  return c;
}

TEST(CalibField, DltStartRecoversTheCameraFromARaisedField) {
  const auto opts = RaisedSet();
  const auto set = MakeSyntheticSet(opts);
  std::vector<std::string> said;
  auto c = FieldOptions();
  c.progress = [&](const std::string& m) { said.push_back(m); };
  const auto r = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  EXPECT_TRUE(std::any_of(said.begin(), said.end(), [](const std::string& m) { return m.find("DLT focal length") != std::string::npos; }));
  const double truth_f = opts.camera.FocalLengthPx();
  std::printf("[field] DLT start: f %.1f px (truth %.1f, %+.2f %%), start RMS %.2f px; final sigma0 %.3f px\n",
              r.start_focal_px, truth_f, 100 * (r.start_focal_px / truth_f - 1), r.start_rms_px, r.sigma0_px);
  EXPECT_NEAR(r.start_focal_px, truth_f, 0.02 * truth_f);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!r.free[i]) continue;
    const double z = std::abs(r.camera.params[i] - opts.camera.params[i]) / r.sigma[i];
    std::printf("[field] %s: sigma %.2g, |error| / sigma %.2f\n", std::string(kBrownParamInfo[i].name).c_str(), r.sigma[i], z);
    EXPECT_LT(z, 3.0) << kBrownParamInfo[i].name;
  }

  // The same images started as a planar field (X, Y; Z ignored): the homography start.
  c.planar_start = true;
  const auto h = Calibrate(set.detections, opts.target, c);
  std::printf("[field] homography start: f %.1f px (%+.1f %%), start RMS %.2f px; final sigma0 %.3f px, c %.4f mm "
              "(truth %.4f)\n", h.start_focal_px, 100 * (h.start_focal_px / truth_f - 1), h.start_rms_px,
              h.sigma0_px, h.camera.params[0], opts.camera.params[0]);
  EXPECT_GT(h.start_rms_px, 10 * r.start_rms_px);
}

// σ of the DLT-started calibration against the spread of 30 Monte-Carlo runs (noise only).
TEST(CalibField, RaisedFieldSigmaMatchesMonteCarloSpread) {
  const auto opts = RaisedSet();
  const MonteCarlo mc = RunMonteCarlo(opts, FieldOptions(), 30, 300);
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!mc.free[i]) continue;
    const double ratio = mc.mean_sigma[i] / mc.spread[i];
    std::printf("[field] %s: mean sigma %.3g, Monte-Carlo spread %.3g, ratio %.2f; mean error / sigma %.2f\n",
                std::string(kBrownParamInfo[i].name).c_str(), mc.mean_sigma[i], mc.spread[i], ratio,
                (mc.mean[i] - opts.camera.params[i]) / mc.mean_sigma[i]);
    EXPECT_GT(ratio, 0.7) << kBrownParamInfo[i].name;
    EXPECT_LT(ratio, 1.4) << kBrownParamInfo[i].name;
  }
}

// A Kannala–Brandt fisheye (FisheyeSet) seeing the raised field off axis: the candidates' poses
// by PnP of their rays (DLT off a plane), then the adjustment: every parameter within 3σ.
TEST(CalibField, FisheyeStartsFromRaysOfARaisedField) {
  auto opts = FisheyeSet();
  opts.target = RaisedField();
  const auto set = MakeSyntheticSet(opts);
  auto c = FisheyeOptions();
  c.centre_correction = CalibrationOptions::CentreCorrection::kOff;
  const auto r = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  std::printf("[field] fisheye: start f %.1f px (truth %.1f), start RMS %.2f px, sigma0 %.3f px, %d images\n",
              r.start_focal_px, opts.camera.params[0], r.start_rms_px, r.sigma0_px, r.n_images);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.1 * opts.noise_px);
  for (int i = 0; i < camera::KannalaBrandtModel::kNumParams; ++i) {
    EXPECT_LT(std::abs(r.camera.params[i] - opts.camera.params[i]), 3 * r.sigma[i])
        << camera::KannalaBrandtModel::kParams[i].name;
  }
}

// A field off its plane by less than 2 % of its extent keeps the homography start.
TEST(CalibField, MostlyPlanarFieldKeepsTheHomographyStart) {
  const auto opts = RaisedSet(0.05);  // posts 2–6 mm: at most 1.2 % of the extent off the plane
  std::vector<std::string> said;
  auto c = FieldOptions();
  c.progress = [&](const std::string& m) { said.push_back(m); };
  const auto r = Calibrate(MakeSyntheticSet(opts).detections, opts.target, c);
  EXPECT_TRUE(std::any_of(said.begin(), said.end(), [](const std::string& m) { return m.find("Zhang focal length") != std::string::npos; }));
  EXPECT_LT(std::abs(r.camera.params[0] - opts.camera.params[0]), 3 * r.sigma[0]);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
}

// Degenerate fields: all points on one line; fewer than 6 points in every image of a 3-D field.
TEST(CalibField, DegenerateFieldsAreOneInvalidInput) {
  SyntheticOptions o = PaperSet();
  o.target = ParseTarget("coded:14:2.5");
  for (int k = 0; k < 20; ++k) o.target.field.push_back({k + 1, Eigen::Vector3d(20.0 * k, 10.0 * k, -5.0 * k)});
  try {
    Calibrate(MakeSyntheticSet(o).detections, o.target, FieldOptions());
    ADD_FAILURE() << "a field on one line was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "images") << e.what();
  }
  o.target.field = {{1, Eigen::Vector3d(0, 0, 0)}, {2, Eigen::Vector3d(400, 0, 0)}, {3, Eigen::Vector3d(0, 300, 0)},
                    {4, Eigen::Vector3d(400, 300, -100)}, {5, Eigen::Vector3d(200, 150, -60)}};
  try {
    Calibrate(MakeSyntheticSet(o).detections, o.target, FieldOptions());
    ADD_FAILURE() << "a 3-D field of 5 points was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "images") << e.what();
    std::printf("[field] 5 points: %s\n", e.what());
  }
}

// A cage: targets on the floor (Z = 0) and the four walls (to 200 mm toward the camera) of a
// 300 × 300 mm box, 4 × 4 per face: no dominant plane. The DLT start recovers the camera; the
// homography start (Z ignored: the walls collapse onto the floor's edges) is printed beside it.
TEST(CalibField, DltStartRecoversTheCameraFromACage) {
  SyntheticOptions opts = PaperSet();
  opts.target = ParseTarget("coded:14:2.5");
  int id = 1;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      const double u = 30 + 80 * i, v = 30 + 80 * j, h = -(20 + 50 * j);
      opts.target.field.push_back({id++, Eigen::Vector3d(u, v, 0)});
      opts.target.field.push_back({id++, Eigen::Vector3d(0, u, h)});
      opts.target.field.push_back({id++, Eigen::Vector3d(300, u, h)});
      opts.target.field.push_back({id++, Eigen::Vector3d(u, 0, h)});
      opts.target.field.push_back({id++, Eigen::Vector3d(u, 300, h)});
    }
  }
  const auto set = MakeSyntheticSet(opts);
  auto c = FieldOptions();
  const auto r = Calibrate(set.detections, opts.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  const double truth_f = opts.camera.FocalLengthPx();
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (r.free[i]) EXPECT_LT(std::abs(r.camera.params[i] - opts.camera.params[i]), 3 * r.sigma[i]) << kBrownParamInfo[i].name;
  }
  c.planar_start = true;
  const auto h = Calibrate(set.detections, opts.target, c);
  std::printf("[field] cage: DLT start f %+.2f %%, start RMS %.2f px, final sigma0 %.3f px; homography start f %+.1f %%, "
              "start RMS %.1f px, final sigma0 %.3f px, c %.4f mm (truth %.4f, sigma %.4f)\n",
              100 * (r.start_focal_px / truth_f - 1), r.start_rms_px, r.sigma0_px, 100 * (h.start_focal_px / truth_f - 1),
              h.start_rms_px, h.sigma0_px, h.camera.params[0], opts.camera.params[0], r.sigma[0]);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
  EXPECT_GT(h.start_rms_px, 10 * r.start_rms_px);
}

// The same physical field in another frame gives the same calibration: a flat board surveyed with
// Z up (its targets in the X–Z plane, as a wall of a pool field would be) is started from its
// plane's homography, and with a free target the datum fixes its Y (the direction the rotation
// about a–b moves the third point; fixing Z there, the earlier rule, leaves that rotation free:
// a singular covariance).
TEST(CalibField, FlatFieldInAnyFrameGivesTheSameCalibration) {
  const auto opts = RaisedSet(0);  // the board alone (posts of height 0)
  const auto set = MakeSyntheticSet(opts);
  TargetSpec wall = opts.target;
  for (auto& p : wall.field) p.xyz_mm = Eigen::Vector3d(p.xyz_mm.x(), -p.xyz_mm.z(), p.xyz_mm.y());  // 90° about X
  auto c = FieldOptions();
  c.target_free = true;
  const auto flat = Calibrate(set.detections, opts.target, c);
  const auto turned = Calibrate(set.detections, wall, c);
  ASSERT_TRUE(flat.covariance_ok && turned.covariance_ok) << turned.message;
  EXPECT_EQ(flat.datum.axis, 2);
  EXPECT_EQ(turned.datum.axis, 1);
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!flat.free[i]) continue;
    EXPECT_NEAR(turned.camera.params[i], flat.camera.params[i], 1e-4 * flat.sigma[i]) << kBrownParamInfo[i].name;
    EXPECT_NEAR(turned.sigma[i], flat.sigma[i], 1e-4 * flat.sigma[i]) << kBrownParamInfo[i].name;
  }
  std::printf("[field] wall frame: datum %d, %d, %c of %d; c %.6f vs %.6f mm\n", turned.datum.a, turned.datum.b,
              "XYZ"[turned.datum.axis], turned.datum.c, turned.camera.params[0], flat.camera.params[0]);
}

// Self-calibration of a 3-D field, as the paper measured its pool field: the raised targets'
// heights given wrong by 3–4 mm are measured from the images. The datum lies on the board (exact),
// so every raised point is free and its adjusted coordinates are comparable with the truth: within
// 3σ in the first run, and the σ against the spread of 30 Monte-Carlo runs (noise only), pooled
// over the raised points' coordinates, within 0.7–1.4.
TEST(CalibField, SelfCalibrationRecoversRaisedHeights) {
  auto opts = RaisedSet();
  TargetSpec given = opts.target;
  for (auto& p : given.field) {
    if (p.xyz_mm.z() != 0) p.xyz_mm.z() += p.id % 2 ? 3.0 : -4.0;
  }
  const auto truth = TargetPoints(opts.target);
  auto c = FieldOptions();
  c.target_free = true;
  const int runs = 30;
  const int first_raised = 64, n = static_cast<int>(truth.size());
  std::vector<Eigen::Vector3d> sum(n, Eigen::Vector3d::Zero()), sum2 = sum, sigma2 = sum;
  for (int k = 0; k < runs; ++k) {
    opts.noise_seed = 400 + k;
    const auto r = Calibrate(MakeSyntheticSet(opts).detections, given, c);
    ASSERT_TRUE(r.covariance_ok) << r.message;
    ASSERT_EQ(r.target_sigma_mm.size(), truth.size());
    if (k == 0) {
      for (int id : {r.datum.a, r.datum.b, r.datum.c}) EXPECT_EQ(truth[id].z(), 0) << "datum point " << id << " is raised";
      EXPECT_EQ(r.datum.axis, 2);
      std::printf("[field] free target: datum %d, %d (all), %d (Z); %d unknowns, sigma0 %.3f px\n", r.datum.a,
                  r.datum.b, r.datum.c, r.n_unknowns, r.sigma0_px);
      double worst = 0, worst_given = 0;
      for (int id = first_raised; id < n; ++id) {
        const double z = std::abs(r.target_points_mm[id].z() - truth[id].z()) / r.target_sigma_mm[id].z();
        worst = std::max(worst, z);
        worst_given = std::max(worst_given, std::abs(TargetPoints(given)[id].z() - truth[id].z()) / r.target_sigma_mm[id].z());
        EXPECT_LT(z, 3.0) << "raised point " << id;
      }
      std::printf("[field] raised heights: worst |error| / sigma %.2f (the given heights: %.0f sigma off), "
                  "sigma Z %.3f-%.3f mm\n", worst, worst_given, r.target_sigma_mm[first_raised].z(),
                  r.target_sigma_mm[n - 1].z());
    }
    for (int id = first_raised; id < n; ++id) {
      sum[id] += r.target_points_mm[id];
      sum2[id] += r.target_points_mm[id].cwiseProduct(r.target_points_mm[id]);
      sigma2[id] += r.target_sigma_mm[id].cwiseProduct(r.target_sigma_mm[id]) / runs;
    }
  }
  // Pooled over the raised points: mean σ² against the Monte-Carlo variance, per coordinate.
  for (int axis = 0; axis < 3; ++axis) {
    double var = 0, s2 = 0, bias2 = 0;
    for (int id = first_raised; id < n; ++id) {
      const double mean = sum[id](axis) / runs;
      var += (sum2[id](axis) - runs * mean * mean) / (runs - 1);
      s2 += sigma2[id](axis);
      bias2 += (mean - truth[id](axis)) * (mean - truth[id](axis)) / sigma2[id](axis) * runs;
    }
    const double ratio = std::sqrt(s2 / var);
    std::printf("[field] raised points %c: RMS sigma %.4f mm, Monte-Carlo spread %.4f mm, ratio %.2f; "
                "chi2 of the means %.1f on %d\n", "XYZ"[axis], std::sqrt(s2 / (n - first_raised)),
                std::sqrt(var / (n - first_raised)), ratio, bias2, n - first_raised);
    EXPECT_GT(ratio, 0.7);
    EXPECT_LT(ratio, 1.4);
  }
}

// Detections of IDs the field does not hold are ignored, not placed at the origin.
TEST(CalibField, IdsOutsideTheFieldAreIgnored) {
  const auto opts = RaisedSet();
  auto set = MakeSyntheticSet(opts);
  for (auto& d : set.detections) {
    d.ids.push_back(200);  // on the default sheet, not in the field
    d.points_px.emplace_back(10, 10);
  }
  auto dets = set.detections;
  EXPECT_EQ(KeepTargetPoints(opts.target, &dets), static_cast<int>(set.detections.size()));
  const auto r = Calibrate(set.detections, opts.target, FieldOptions());
  EXPECT_EQ(r.n_rejected, 0);
  EXPECT_NEAR(r.sigma0_px, opts.noise_px, 0.05 * opts.noise_px);
}

}  // namespace
}  // namespace porthole::calib

namespace porthole::calib {
namespace {

// A cage whose wall targets face inward (their normals in the field: +X, −X, +Y, −Y) and whose
// floor targets face up (−Z), seen from above through its opening by the paper's in-air D300:
// the observations are the exact centres of the dots' image ellipses (coded::ImagedCircleCentre in
// each dot's own plane, radius 5 mm) plus 0.02 px of noise. With the field's normals the centre
// correction recovers the camera within 3σ; told that every dot faces −Z (the walls' dots lying in
// planes parallel to the floor) it does not.
struct CageSet {
  TargetSpec target;
  std::vector<ImageDetections> detections;
  camera::Camera camera;
};
CageSet InwardFacingCage() {
  CageSet set;
  set.camera = PaperSet().camera;
  set.target = ParseTarget("coded:14:5");
  int id = 1;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      const double u = 45 + 70 * i, v = 45 + 70 * j, h = -(30 + 45 * j);
      set.target.field.push_back({id++, Eigen::Vector3d(u, v, 0), -Eigen::Vector3d::UnitZ()});
      set.target.field.push_back({id++, Eigen::Vector3d(0, u, h), Eigen::Vector3d::UnitX()});
      set.target.field.push_back({id++, Eigen::Vector3d(300, u, h), -Eigen::Vector3d::UnitX()});
      set.target.field.push_back({id++, Eigen::Vector3d(u, 0, h), Eigen::Vector3d::UnitY()});
      set.target.field.push_back({id++, Eigen::Vector3d(u, 300, h), -Eigen::Vector3d::UnitY()});
    }
  }
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0, 0.02);
  const camera::Sensor& sensor = set.camera.sensor;
  const Eigen::Vector3d aim(150, 150, -60);
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * M_PI * k / 12, off = k % 2 ? 90 : 40;
    const Eigen::Vector3d eye(150 + off * std::cos(a), 150 + off * std::sin(a), -650 - 8 * k);
    const Eigen::Vector3d z = (aim - eye).normalized();
    const Eigen::Vector3d x0 = Eigen::AngleAxisd(0.3 * std::sin(a), z) * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d y = z.cross(x0).normalized(), x = y.cross(z);
    Eigen::Matrix3d r;  // cam_from_target: rows are the camera's axes in the target frame
    r.row(0) = x.transpose();
    r.row(1) = y.transpose();
    r.row(2) = z.transpose();
    const Eigen::Vector3d t = -r * eye;
    const auto project = [&](const Eigen::Vector3d& p) { return set.camera.Project(r * p + t); };
    ImageDetections d;
    d.image = "cage" + std::to_string(k);
    d.width_px = sensor.width_px;
    d.height_px = sensor.height_px;
    for (const auto& p : set.target.field) {
      if ((eye - p.xyz_mm).normalized().dot(p.normal) < 0.3) continue;  // seen edge-on or from behind
      const auto [u, v] = coded::DotAxes(p.normal);
      const auto c = coded::ImagedCircleCentre(project, p.xyz_mm, u, v, 5.0);
      if (!c || c->x() < 0 || c->y() < 0 || c->x() > sensor.width_px - 1 || c->y() > sensor.height_px - 1) continue;
      d.ids.push_back(p.id);
      d.points_px.emplace_back(c->x() + noise(rng), c->y() + noise(rng));
    }
    set.detections.push_back(d);
  }
  return set;
}

TEST(CalibField, CentreCorrectionUsesEachDotsPlane) {
  const CageSet set = InwardFacingCage();
  CalibrationOptions c = PaperOptions();
  c.centre_correction = CalibrationOptions::CentreCorrection::kOn;
  const auto r = Calibrate(set.detections, set.target, c);
  ASSERT_TRUE(r.covariance_ok) << r.message;
  TargetSpec flat = set.target;  // the same points, every dot taken to face −Z
  for (auto& p : flat.field) p.normal = -Eigen::Vector3d::UnitZ();
  const auto w = Calibrate(set.detections, flat, c);
  double worst = 0, worst_flat = 0;
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!r.free[i]) continue;
    const double z = std::abs(r.camera.params[i] - set.camera.params[i]) / r.sigma[i];
    const double zf = std::abs(w.camera.params[i] - set.camera.params[i]) / w.sigma[i];
    worst = std::max(worst, z), worst_flat = std::max(worst_flat, zf);
    EXPECT_LT(z, 3.0) << kBrownParamInfo[i].name;
  }
  std::printf("[field] inward-facing cage, %d points, offsets up to %.3f px: with the dots' normals every parameter "
              "within %.2f sigma, sigma0 %.4f px; every dot taken to face -Z: worst %.1f sigma, sigma0 %.4f px\n",
              r.n_points, r.max_centre_offset_px, worst, r.sigma0_px, worst_flat, w.sigma0_px);
  EXPECT_NEAR(r.sigma0_px, 0.02, 0.003);
  EXPECT_GT(worst_flat, 5.0);
}

}  // namespace
}  // namespace porthole::calib
