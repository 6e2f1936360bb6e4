// Proves the refractive calibration recovers the port from synthetic images made by the exact
// forward projection (refraction::Project) with 0.3 px Gaussian noise, 20 views at two ranges:
// the paper's as-built NI320 pupil (Tables 3-4) to 0.1 mm laterally and 0.3 mm axially, a tilted
// flat port's normal to 0.02° and distance to 1 mm, chessboard and ChArUco; that its reported σ
// matches the Monte-Carlo spread; and that bad input is refused with InvalidInput.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "porthole/calib/refractive.h"
#include "porthole/calib/synthetic.h"
#include "porthole/calib/test_refractive.h"
#include "porthole/refraction/test_camera.h"
#include "porthole/core/error.h"
#include "porthole/simulate/simulate.h"

namespace porthole::calib {
namespace {

using ports::PortSystem;
using refraction::PortKind;

using refraction::testing::D300Brown;
using fixtures::AirCalibration;
using fixtures::AirViews;
using fixtures::AsBuiltNi320;
using fixtures::Displaced;
using fixtures::ExactLens;
using fixtures::RecordOf;
using fixtures::Options;
using fixtures::Print;
using fixtures::TiltedFlat;
using fixtures::Views;

// The paper's as-built NI320 (pupil 0.4, 1.0, 5.4 mm from the outer centre), predicted as the
// nominal (pupil at the centre), the in-air calibration as a prior (the default with one).
TEST(RefractiveCalibration, RecoversTheAsBuiltNi320Pupil) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  double sigma_z_prior = 0;
  for (const char* spec : {"chessboard:12x9:30", "charuco:12x9:30:22"}) {
    const TargetSpec target = ParseTarget(spec);
    const auto views = Views(cam, truth, target, 3);
    RefractiveOptions o = Options(Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
    o.air = AirCalibration(cam, target);
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kPrior;
    const auto r = CalibrateRefractive(views, target, o);
    Print(spec, r);
    EXPECT_LE(std::hypot(r.port[0] - 0.4, r.port[1] - 1.0), 0.1) << spec;
    EXPECT_LE(std::abs(r.port[2] - 5.4), 0.3) << spec;
    // Reprojection at the noise level: σ0 within 10 % of the 0.3 px simulated.
    EXPECT_NEAR(r.lens.sigma0_px, 0.3, 0.03) << spec;
    const auto t = refraction::ParamsOf(truth);
    for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(r.port[i] - t[i]), 3 * r.port_sigma[i]) << i;
    // The prediction (pupil at the centre, ±0.5 mm) is 5.5 mm off: the χ² test must say so, and
    // the central Brown model must lose on BIC.
    EXPECT_TRUE(r.port_differs);
    EXPECT_EQ(r.preferred, "refractive");
    // The simulate prediction of c, x0, y0 for that nominal port is off too (c by ~0.5 mm).
    EXPECT_TRUE(r.central_prediction.available);
    EXPECT_TRUE(r.central_prediction.differs);
    sigma_z_prior = r.port_sigma[2];
    if (std::string(spec).rfind("chessboard", 0) == 0) {
      // Without the air calibration the focal length and distortion absorb the pupil's axial
      // offset: its σ grows by more than an order of magnitude (docs/calibration.md).
      o.intrinsics = IntrinsicsMode::kFree;
      const auto f = CalibrateRefractive(views, target, o);
      Print("chessboard, lens free", f);
      EXPECT_GT(f.port_sigma[2], 10 * sigma_z_prior);
    }
  }
}

// The paper's protocol on synthetic views: the as-built NI320, water views (seed 3) and air views
// through it (seed 7) of a 12 × 9 chessboard at 0.3 px, the air views taken with the lens's c times
// `air_focal_scale` (a refocus); options with the port displaced to the origin (the search finds
// it) and the air views given.
struct AirAndWaterViews {
  camera::Camera cam = D300Brown();
  PortSystem truth = AsBuiltNi320();
  std::array<double, refraction::kPortNumParams> t = refraction::ParamsOf(truth);
  TargetSpec target = ParseTarget("chessboard:12x9:30");
  std::vector<ImageDetections> water, air;
  RefractiveOptions o;

  explicit AirAndWaterViews(double air_focal_scale = 1.0) {
    camera::Camera air_cam = cam;
    air_cam.params[camera::kBrownC] *= air_focal_scale;
    water = Views(cam, truth, target, 3);
    air = AirViews(air_cam, truth, target, 7);
    o = Options(Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
    o.air_detections = air;
  }
};

// The paper's protocol (issue 26): an air set through the same as-built NI320 in air (the housing
// on), a water set in water, one lens at one focus, adjusted together with the lens free: the
// pupil within 0.1 mm laterally and 0.3 mm axially, within 3σ, σ0 at the 0.3 px simulated. The
// central calibration of the air set — the "air calibration" a housed protocol gives — taken as
// made through the port (the default) gives the same port within σ; taken as the bare lens
// (kLensBare, said so) it puts the pupil millimetres off; held fixed it is refused.
TEST(RefractiveCalibration, AirAndWaterImagesThroughThePortTogether) {
  AirAndWaterViews views;
  auto& [cam, truth, t, target, water, air, o] = views;
  const auto r = CalibrateRefractive(water, target, o);
  Print("air + water", r);
  EXPECT_LE(std::hypot(r.port[0] - t[0], r.port[1] - t[1]), 0.1);
  EXPECT_LE(std::abs(r.port[2] - t[2]), 0.3);
  for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(r.port[i] - t[i]), 3 * r.port_sigma[i]) << i;
  EXPECT_NEAR(r.lens.sigma0_px, 0.3, 0.03);
  EXPECT_EQ(r.air_images.size(), air.size());
  EXPECT_EQ(r.lens.images.size(), water.size());
  EXPECT_EQ(r.lens.n_images, static_cast<int>(water.size() + air.size()));
  // RMS of the 2-D residual: √2 × the 0.3 px per coordinate.
  EXPECT_NEAR(r.air_rms_px, 0.3 * std::sqrt(2.0), 0.05);
  EXPECT_NEAR(r.water_rms_px, 0.3 * std::sqrt(2.0), 0.05);
  // The lens itself: c within 3σ of the truth.
  EXPECT_LE(std::abs(r.lens.camera.params[camera::kBrownC] - cam.params[camera::kBrownC]),
            3 * r.lens.sigma[camera::kBrownC]);
  EXPECT_FALSE(r.central_prediction.available);

  // The housed air calibration: what a central calibration of the air images gives.
  CalibrationOptions co;
  co.pixel_pitch_mm = cam.sensor.pixel_pitch_mm;
  const CalibrationRecord rec = RecordOf(Calibrate(air, target, co));
  RefractiveOptions h = Options(Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
  h.air = rec;
  h.intrinsics = IntrinsicsMode::kPrior;
  const auto through = CalibrateRefractive(water, target, h);  // kThroughPort: the default
  Print("housed air calibration through the port", through);
  std::printf("housed central fit RMS %.4f px; port - (air + water) images: %.4f %.4f %.4f mm, "
              "in sigma %.2f %.2f %.2f\n", through.housed_fit_rms_px, through.port[0] - r.port[0],
              through.port[1] - r.port[1], through.port[2] - r.port[2],
              (through.port[0] - r.port[0]) / r.port_sigma[0], (through.port[1] - r.port[1]) / r.port_sigma[1],
              (through.port[2] - r.port[2]) / r.port_sigma[2]);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(through.port[i] - r.port[i]), r.port_sigma[i]) << i;  // the same port within σ
    EXPECT_LE(std::abs(through.port[i] - t[i]), 3 * through.port_sigma[i]) << i;
    EXPECT_NEAR(through.port_sigma[i] / r.port_sigma[i], 1, 0.3) << i;  // the same information
  }
  EXPECT_LE(std::hypot(through.port[0] - t[0], through.port[1] - t[1]), 0.1);
  EXPECT_LE(std::abs(through.port[2] - t[2]), 0.3);
  EXPECT_LT(through.housed_fit_rms_px, 0.05);  // the housed bundle in air is nearly central
  EXPECT_TRUE(through.air_images.empty());
  RefractiveOptions fixed = h;
  fixed.intrinsics = IntrinsicsMode::kFixed;  // a housed calibration is not the lens
  EXPECT_THROW(CalibrateRefractive(water, target, fixed), InvalidInput);
  h.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  const auto wrong = CalibrateRefractive(water, target, h);
  Print("housed air calibration taken as the bare lens", wrong);
  const double off = std::sqrt(std::pow(wrong.port[0] - t[0], 2) + std::pow(wrong.port[1] - t[1], 2) +
                               std::pow(wrong.port[2] - t[2], 2));
  EXPECT_GT(off, 1.0);  // millimetres off
  EXPECT_GT(std::abs(wrong.port[2] - t[2]), 10 * wrong.port_sigma[2]);  // and far beyond its σ

  // Both sources of the lens at once, or air images of another size: refused.
  RefractiveOptions both = o;
  both.air = rec;
  both.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  EXPECT_THROW(CalibrateRefractive(water, target, both), InvalidInput);
  RefractiveOptions other = o;
  for (auto& d : other.air_detections) d.width_px /= 2, d.height_px /= 2;
  EXPECT_THROW(CalibrateRefractive(water, target, other), InvalidInput);
  EXPECT_THROW(PlanRefractiveFromImages(water, target, o), InvalidInput);
}

// The lens refocused between the sets (issue 26: an image set "its own focal length when the lens
// was refocused between sets"): the air images taken with c 1.5 % longer than the water images'.
// With air_refocused the air set gets its own focal length, a factor on the water images' adjusted
// with the rest: found within 3σ of 1.015, the port as with one focus. Taken as one focus, the air
// set pulls the one lens and the port off.
TEST(RefractiveCalibration, AirImagesAtAnotherFocusGetTheirOwnFocalLength) {
  AirAndWaterViews views(1.015);
  auto& [cam, truth, t, target, water, air, o] = views;
  const auto one_focus = CalibrateRefractive(water, target, o);
  Print("air at another focus, taken as one focus", one_focus);
  o.air_refocused = true;
  const auto r = CalibrateRefractive(water, target, o);
  Print("air at another focus, refocused", r);
  std::printf("air focal scale %.5f +- %.5f (truth 1.015); one focus: air RMS %.3f px, water RMS %.3f px; "
              "refocused: %.3f, %.3f px\n", r.air_focal_scale, r.air_focal_scale_sigma, one_focus.air_rms_px,
              one_focus.water_rms_px, r.air_rms_px, r.water_rms_px);
  EXPECT_LE(std::abs(r.air_focal_scale - 1.015), 3 * r.air_focal_scale_sigma);
  EXPECT_LT(r.air_focal_scale_sigma, 0.001);
  EXPECT_LE(std::hypot(r.port[0] - t[0], r.port[1] - t[1]), 0.1);
  EXPECT_LE(std::abs(r.port[2] - t[2]), 0.3);
  for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(r.port[i] - t[i]), 3 * r.port_sigma[i]) << i;
  EXPECT_LE(std::abs(r.lens.camera.params[camera::kBrownC] - cam.params[camera::kBrownC]),
            3 * r.lens.sigma[camera::kBrownC]);  // the water images' focus
  EXPECT_NEAR(r.air_rms_px, 0.3 * std::sqrt(2.0), 0.05);
  EXPECT_NEAR(r.water_rms_px, 0.3 * std::sqrt(2.0), 0.05);
  // One focus assumed: the one lens is a compromise, off by many σ.
  EXPECT_GT(std::abs(one_focus.lens.camera.params[camera::kBrownC] - cam.params[camera::kBrownC]),
            10 * one_focus.lens.sigma[camera::kBrownC]);
  // Without air images there is no second focus to adjust.
  RefractiveOptions alone = Options(Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
  alone.air_refocused = true;
  EXPECT_THROW(CalibrateRefractive(water, target, alone), InvalidInput);
}

// The errors of the three port parameters and c over Monte-Carlo runs, and their mean reported σ.
struct PortAndCSpread {
  std::array<double, 4> sum{}, sum2{}, sigma{};
  int runs = 0;

  void Add(const RefractiveResult& r, const std::array<double, refraction::kPortNumParams>& truth,
           const camera::Camera& cam, int n_runs) {
    runs = n_runs;
    for (int i = 0; i < 4; ++i) {
      const double e = i < 3 ? r.port[i] - truth[i] : r.lens.camera.params[camera::kBrownC] - cam.params[camera::kBrownC];
      sum[i] += e;
      sum2[i] += e * e;
      sigma[i] += (i < 3 ? r.port_sigma[i] : r.lens.sigma[camera::kBrownC]) / n_runs;
    }
  }
  // Prints `what`'s ratios and checks σ / spread within [1/1.5, 1.5] and no mean error beyond 3 spread/√runs.
  void Expect(const char* what) const {
    for (int i = 0; i < 4; ++i) {
      const double mean = sum[i] / runs;
      const double spread = std::sqrt((sum2[i] - runs * mean * mean) / (runs - 1));
      std::printf("%s %s: sigma %.4g, Monte-Carlo spread %.4g, ratio %.2f, mean error %.4g\n", what,
                  i == 0 ? "ep_x" : i == 1 ? "ep_y" : i == 2 ? "ep_z" : "c", sigma[i], spread, sigma[i] / spread, mean);
      EXPECT_GT(sigma[i] / spread, 1 / 1.5) << i;
      EXPECT_LT(sigma[i] / spread, 1.5) << i;
      EXPECT_LE(std::abs(mean), 3 * spread / std::sqrt(runs) + 1e-3) << i;  // no bias beyond the noise
    }
  }
};

// Air and water together: the reported σ of the port and of c against their spread over 30 noise
// draws (issue 26's acceptance: within [0.67, 1.5]).
TEST(RefractiveCalibration, AirAndWaterSigmaMatchesMonteCarloSpread) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  const auto t = refraction::ParamsOf(truth);
  const TargetSpec target = ParseTarget("chessboard:12x9:30");
  RefractiveOptions o = Options(Displaced(truth, {-0.2, 0.2, -0.5}), cam.sensor.pixel_pitch_mm);
  o.search = false;
  o.compare_central = false;
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  PortAndCSpread mc;
  for (int k = 0; k < runs; ++k) {
    o.air_detections = AirViews(cam, truth, target, 5000 + k);
    mc.Add(CalibrateRefractive(Views(cam, truth, target, 4000 + k), target, o), t, cam, runs);
  }
  mc.Expect("air + water");
}

// The paper's protocol with the air set reduced to its calibration (a central calibration of the
// air images, made through the port: what a housed in-air calibration is), taken as such (the
// default, housed_prior.h): the reported σ of the port and of c against their spread over 30 noise
// draws of both sets (issue 26: within [0.67, 1.5]), and no bias beyond the noise.
TEST(RefractiveCalibration, HousedAirCalibrationSigmaMatchesMonteCarloSpread) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  const auto t = refraction::ParamsOf(truth);
  const TargetSpec target = ParseTarget("chessboard:12x9:30");
  RefractiveOptions o = Options(Displaced(truth, {-0.2, 0.2, -0.5}), cam.sensor.pixel_pitch_mm);
  o.search = false;
  o.compare_central = false;
  o.intrinsics = IntrinsicsMode::kPrior;
  CalibrationOptions co;
  co.pixel_pitch_mm = cam.sensor.pixel_pitch_mm;
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  PortAndCSpread mc;
  double fit_rms = 0;
  for (int k = 0; k < runs; ++k) {
    o.air = RecordOf(Calibrate(AirViews(cam, truth, target, 5000 + k), target, co));
    const auto r = CalibrateRefractive(Views(cam, truth, target, 4000 + k), target, o);
    fit_rms = std::max(fit_rms, r.housed_fit_rms_px);
    mc.Add(r, t, cam, runs);
  }
  std::printf("housed air calibration: largest central fit RMS %.4f px\n", fit_rms);
  mc.Expect("housed air calibration");
}

// The prediction of c, x0, y0 from the TRUE port (σ 0.5 mm per axis) with the in-air calibration:
// consistent with the estimate (χ² not rejected), and the estimate's equivalent central camera
// equals simulate's fit through the true port with the true lens within 3σ.
TEST(RefractiveCalibration, CentralPredictionFromTheTruePortIsConsistent) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  const TargetSpec target = ParseTarget("chessboard:12x9:30");
  RefractiveOptions o = Options(truth, cam.sensor.pixel_pitch_mm);
  o.air = AirCalibration(cam, target);
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  o.intrinsics = IntrinsicsMode::kPrior;
  const auto r = CalibrateRefractive(Views(cam, truth, target, 7), target, o);
  Print("true prediction", r);
  const auto& c = r.central_prediction;
  ASSERT_TRUE(c.available) << c.why_not;
  EXPECT_FALSE(c.differs);
  EXPECT_GT(c.p_value, 0.01);
  simulate::FitOptions fo;
  fo.grid_cols = 13;
  fo.grid_rows = 9;
  fo.distances_mm = c.distances_mm;
  const auto fit = simulate::SimulateFit(
      truth, {cam.sensor, camera::ToBrown(cam), truth.ep_in_housing_mm}, fo);
  const double t[3] = {fit.params.c_mm, fit.params.x0_mm, fit.params.y0_mm};
  for (int i = 0; i < 3; ++i) {
    std::printf("  truth %.4f, estimated %.4f +- %.4f\n", t[i], c.estimated[i], c.estimated_sigma[i]);
    EXPECT_LE(std::abs(c.estimated[i] - t[i]), 3 * c.estimated_sigma[i]) << i;
  }
}

// A flat port tilted 2°, its inner face 25 mm from the pupil, predicted square at 20 mm, the
// in-air calibration as a prior.
TEST(RefractiveCalibration, RecoversATiltedFlatPort) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = TiltedFlat(2.0, 25.0);
  for (const char* spec : {"charuco:12x9:40:30", "chessboard:16x12:30"}) {
    const TargetSpec target = ParseTarget(spec);
    const auto views = Views(cam, truth, target, 5);
    const auto t = refraction::ParamsOf(truth);
    RefractiveOptions o = Options(Displaced(truth, {-t[0], -t[1], -5.0}), cam.sensor.pixel_pitch_mm);
    o.air = AirCalibration(cam, target);
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kPrior;
    const auto r = CalibrateRefractive(views, target, o);
    Print(spec, r);
    const auto g = refraction::MakeGeometry<double>(refraction::ShellOf(truth), r.port.data());
    const double angle_deg = std::acos(std::min(1.0, g.normal.dot(truth.flat().normal))) * 180 / M_PI;
    std::printf("%s: normal off by %.4f deg, distance off by %.3f mm\n", spec, angle_deg, r.port[2] - 25.0);
    EXPECT_LE(angle_deg, 0.02) << spec;
    EXPECT_LE(std::abs(r.port[2] - 25.0), 1.0) << spec;
    EXPECT_NEAR(r.lens.sigma0_px, 0.3, 0.03) << spec;
    EXPECT_NEAR(r.normal_tilt_from_predicted_deg, 2.0, 0.05);
    EXPECT_EQ(r.preferred, "refractive");
  }
}

// With the in-air calibration fixed (the exact lens), the port alone: the reported σ of each port
// parameter against its spread over 30 noise draws.
TEST(RefractiveCalibration, SigmaMatchesMonteCarloSpread) {
  const camera::Camera cam = D300Brown();
  const TargetSpec target = ParseTarget("chessboard:6x5:60");
  const CalibrationRecord air = ExactLens(cam);
  for (const PortSystem& truth : {AsBuiltNi320(), TiltedFlat(2.0, 25.0)}) {
    const auto t = refraction::ParamsOf(truth);
    RefractiveOptions o = Options(Displaced(truth, truth.IsDome() ? std::array<double, 3>{0.2, -0.2, 0.5}
                                                                  : std::array<double, 3>{0.002, -0.002, 1.0}),
                                  cam.sensor.pixel_pitch_mm);
    o.intrinsics = IntrinsicsMode::kFixed;
    o.air = air;
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.search = false;
    const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
    std::array<double, 3> sum{}, sum2{}, sigma{};
    // The equivalent central c, x0, y0 (CentralPrediction) and their propagated σ, alike.
    std::array<double, 3> csum{}, csum2{}, csigma{};
    for (int k = 0; k < runs; ++k) {
      const auto r = CalibrateRefractive(Views(cam, truth, target, 1000 + k), target, o);
      if (std::getenv("PORTHOLE_TEST_VERBOSE")) Print("run", r);
      ASSERT_TRUE(r.central_prediction.available) << r.central_prediction.why_not;
      for (int i = 0; i < 3; ++i) {
        sum[i] += r.port[i] - t[i];
        sum2[i] += (r.port[i] - t[i]) * (r.port[i] - t[i]);
        sigma[i] += r.port_sigma[i] / runs;
        const double e = r.central_prediction.estimated[i] - r.central_prediction.predicted[i];
        csum[i] += e;
        csum2[i] += e * e;
        csigma[i] += r.central_prediction.estimated_sigma[i] / runs;
      }
    }
    for (int i = 0; i < 3; ++i) {
      const double mean = csum[i] / runs;
      const double spread = std::sqrt((csum2[i] - runs * mean * mean) / (runs - 1));
      std::printf("%s equivalent central %s: sigma %.4g, Monte-Carlo spread %.4g, ratio %.2f\n",
                  truth.IsDome() ? "dome" : "flat", i == 0 ? "c" : i == 1 ? "x0" : "y0",
                  csigma[i], spread, csigma[i] / spread);
      EXPECT_GT(csigma[i] / spread, 1 / 1.5);
      EXPECT_LT(csigma[i] / spread, 1.5);
    }
    // Network advice: the σ the design (true poses, predicted port, σ0 0.3 px) promises.
    std::vector<ImageResult> poses;
    Views(cam, truth, target, 1000, &poses);
    const RefractivePlan plan = PlanRefractive(poses, target, cam, o, 0.3);
    ASSERT_TRUE(plan.determined);
    EXPECT_EQ(plan.warning, "");
    for (int i = 0; i < 3; ++i) {
      const double mean = sum[i] / runs;
      const double spread = std::sqrt((sum2[i] - runs * mean * mean) / (runs - 1));
      const double ratio = sigma[i] / spread;
      std::printf("%s parameter %d: planned sigma %.4g, Monte-Carlo spread %.4g, ratio %.2f\n",
                  truth.IsDome() ? "dome" : "flat", i, plan.port_sigma[i], spread,
                  plan.port_sigma[i] / spread);
      EXPECT_GT(plan.port_sigma[i] / spread, 1 / 1.5);
      EXPECT_LT(plan.port_sigma[i] / spread, 1.5);
      std::printf("%s parameter %d: sigma %.4g, Monte-Carlo spread %.4g, ratio %.2f\n",
                  truth.IsDome() ? "dome" : "flat", i, sigma[i], spread, ratio);
      // 30 runs: the spread itself is uncertain by ~13 % (1σ); 1.5 is beyond 3σ of that.
      EXPECT_GT(ratio, 1 / 1.5);
      EXPECT_LT(ratio, 1.5);
    }
  }
}

// Network advice from the images: the planned σ agree with the calibration's own (σ0 ≈ 0.3 px);
// with every target at one range the axial parameter's σ grows and the plan warns.
TEST(RefractiveCalibration, PlanFromImagesAndOneRangeWarning) {
  const camera::Camera cam = D300Brown();
  const TargetSpec target = ParseTarget("chessboard:12x9:30");
  for (const PortSystem& truth : {AsBuiltNi320(), TiltedFlat(2.0, 25.0)}) {
    const char* what = truth.IsDome() ? "dome" : "flat";
    RefractiveOptions o = Options(truth, cam.sensor.pixel_pitch_mm);
    o.air = AirCalibration(cam, target);
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kPrior;
    const auto views = Views(cam, truth, target, 9);
    const RefractivePlan from_images = PlanRefractiveFromImages(views, target, o, 0.3);
    const RefractiveResult r = CalibrateRefractive(views, target, o);
    for (int i = 0; i < 3; ++i) {
      const double ratio = from_images.port_sigma[i] / (r.port_sigma[i] * 0.3 / r.lens.sigma0_px);
      std::printf("%s parameter %d: planned from images %.4g, calibration %.4g (sigma0 %.4f), "
                  "ratio %.2f\n", what, i, from_images.port_sigma[i], r.port_sigma[i],
                  r.lens.sigma0_px, ratio);
      EXPECT_GT(ratio, 1 / 1.5);
      EXPECT_LT(ratio, 1.5);
    }
    // The same 20 views' design, all at one range (the target filling 40 % of the width).
    std::vector<ImageResult> three, one;
    Views(cam, truth, target, 9, &three);
    Views(cam, truth, target, 9, &one, {0.4});
    const RefractivePlan p3 = PlanRefractive(three, target, o.air->camera, o, 0.3);
    const RefractivePlan p1 = PlanRefractive(one, target, o.air->camera, o, 0.3);
    std::printf("%s axial sigma: three ranges %.4g (%.0f-%.0f mm), one range %.4g (%.0f-%.0f mm): "
                "%s\n", what, p3.port_sigma[2], p3.min_range_mm, p3.max_range_mm,
                p1.port_sigma[2], p1.min_range_mm, p1.max_range_mm, p1.warning.c_str());
    EXPECT_EQ(p3.warning, "");
    EXPECT_NE(p1.warning.find("all targets at one range"), std::string::npos);
    EXPECT_GT(p1.port_sigma[2], 1.5 * p3.port_sigma[2]);
  }
  // Bad input.
  RefractiveOptions o = Options(AsBuiltNi320(), cam.sensor.pixel_pitch_mm);
  EXPECT_THROW(PlanRefractive({}, target, cam, o, 0.3), InvalidInput);
  std::vector<ImageResult> poses;
  Views(cam, AsBuiltNi320(), target, 9, &poses);
  EXPECT_THROW(PlanRefractive(poses, target, cam, o, 0.0), InvalidInput);
}

// The same port system in another water (index relative to air).
PortSystem InWater(const PortSystem& sys, double n_water) {
  return ports::Place(sys.spec, sys.ep_in_housing_mm, sys.n_glass, n_water);
}

// Mean of the reported σ over the spread of the estimates about the truth, and the largest
// |estimate − truth| / σ, over Monte-Carlo runs.
struct Spread {
  double sum = 0, sum2 = 0, sigma = 0, worst_z = 0;
  int n = 0;
  void Add(double error, double s) {
    sum += error;
    sum2 += error * error;
    sigma += s;
    worst_z = std::max(worst_z, std::abs(error) / s);
    ++n;
  }
  double Mean() const { return sum / n; }
  double Sd() const { return std::sqrt((sum2 - n * Mean() * Mean()) / (n - 1)); }
  double Ratio() const { return sigma / n / Sd(); }
};

// A free water index factor (free_water_index): the flat port tilted 2° in water whose index is
// 0.5 % above the materials model's (1.341), the lens fixed (the exact lens): the factor is
// recovered within 3σ in every run and its σ matches the spread of 30 Monte-Carlo runs within 1.5.
// Its identifiability with the lens a prior (c free) and with a dome is printed (the correlations
// docs/calibration.md states) and checked to be worse than with the lens fixed.
TEST(RefractiveCalibration, FreeWaterIndexIsRecoveredWithHonestSigma) {
  const camera::Camera cam = D300Brown();
  const TargetSpec target = ParseTarget("chessboard:6x5:60");
  const double factor = 1.005;
  const PortSystem truth = InWater(TiltedFlat(2.0, 25.0), 1.341 * factor);
  const CalibrationRecord air = ExactLens(cam);
  RefractiveOptions o = Options(Displaced(InWater(truth, 1.341), {0.002, -0.002, 1.0}),
                                cam.sensor.pixel_pitch_mm);
  o.intrinsics = IntrinsicsMode::kFixed;
  o.air = air;
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  o.search = false;
  o.compare_central = false;
  o.free_water_index = true;
  const auto t = refraction::ParamsOf(truth);
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  Spread index, distance;
  for (int k = 0; k < runs; ++k) {
    const auto r = CalibrateRefractive(Views(cam, truth, target, 2000 + k), target, o);
    ASSERT_TRUE(r.shell_free[0]);
    EXPECT_LE(std::abs(r.shell[0] - factor), 3 * r.shell_sigma[0]) << k;
    EXPECT_NEAR(r.n_water, 1.341 * r.shell[0], 1e-12);
    index.Add(r.shell[0] - factor, r.shell_sigma[0]);
    distance.Add(r.port[2] - t[2], r.port_sigma[2]);
  }
  std::printf("water index factor (flat, lens fixed): mean error %.2e, sigma %.3e, Monte-Carlo "
              "spread %.3e, ratio %.2f, worst |error|/sigma %.2f; distance ratio %.2f\n",
              index.Mean(), index.sigma / runs, index.Sd(), index.Ratio(), index.worst_z,
              distance.Ratio());
  EXPECT_GT(index.Ratio(), 1 / 1.5);
  EXPECT_LT(index.Ratio(), 1.5);
  EXPECT_GT(distance.Ratio(), 1 / 1.5);
  EXPECT_LT(distance.Ratio(), 1.5);
  // 30 runs: the mean error within 3 standard errors of 0 (no bias).
  EXPECT_LE(std::abs(index.Mean()), 3 * index.Sd() / std::sqrt(runs));

  // Identifiability: with the in-air lens a prior (c free to refocus), on the 12×9 chessboard, the
  // flat port and the as-built dome.
  const TargetSpec board = ParseTarget("chessboard:12x9:30");
  for (const PortSystem& sys : {truth, InWater(AsBuiltNi320(), 1.341 * factor)}) {
    RefractiveOptions p = Options(InWater(sys, 1.341), cam.sensor.pixel_pitch_mm);
    p.air = AirCalibration(cam, board);
    p.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    p.intrinsics = IntrinsicsMode::kPrior;
    p.compare_central = false;
    p.free_water_index = true;
    const auto r = CalibrateRefractive(Views(cam, sys, board, 5), board, p);
    const int n = camera::kBrownNumParams, w = n + refraction::kPortNumParams;
    std::printf("%s, lens prior: water index factor %.5f +- %.5f (truth %.3f), correlation with c "
                "%+.3f, with %s %+.3f; sigma0 %.4f px\n",
                sys.IsDome() ? "dome" : "flat", r.shell[0], r.shell_sigma[0], factor,
                r.correlation(w, 0), sys.IsDome() ? "ep_z" : "distance", r.correlation(w, n + 2),
                r.lens.sigma0_px);
    EXPECT_LE(std::abs(r.shell[0] - factor), 3 * r.shell_sigma[0]);
    EXPECT_GT(r.shell_sigma[0], index.sigma / runs);
    EXPECT_NEAR(r.lens.sigma0_px, 0.3, 0.03);
  }
}

// A water index factor with the pupil at the centre of a concentric dome: no ray is bent, the
// images say nothing of the index — a degenerate network, refused (InvalidInput), not a σ.
TEST(RefractiveCalibration, AnIndexTheImagesCannotSeeIsRefused) {
  const camera::Camera cam = D300Brown();
  const TargetSpec target = ParseTarget("chessboard:8x6:60");
  ports::PortSpec s;
  s.name = "concentric";
  ports::DomePort d;
  const Eigen::Vector3d ep(0, 0, 26.9);
  d.outer = {ep, 83.4};
  d.inner = {ep, 75.7};
  s.shape = d;
  const PortSystem centred = ports::Place(s, ep, 1.5168, 1.341);
  RefractiveOptions o = Options(centred, cam.sensor.pixel_pitch_mm);
  o.air = ExactLens(cam);
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  o.intrinsics = IntrinsicsMode::kFixed;
  o.port_free = {false, false, false};
  o.free_water_index = true;
  o.compare_central = false;
  try {
    CalibrateRefractive(Views(cam, centred, target, 1), target, o);
    FAIL() << "a singular network was not refused";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "images");
    EXPECT_NE(std::string(e.what()).find("not determined"), std::string::npos) << e.what();
  }
}

// Shell priors (free_shell, the port file's σ) on the as-built NI320, the lens fixed (the exact
// in-air lens), 12×9 chessboard. The images see the inner sphere's lateral offset from the outer
// one well when the pupil is known (a flange survey: --free-port none), and only with σ of 2–3 mm
// when the pupil is adjusted too (the two trade off); the radii hardly, unless the pupil is known.
// A file stating the lateral offset 1 mm off on both axes (σ 1 mm) and the radii right (σ 0.5 mm),
// the pupil known: the offset is pulled to the truth (error below a quarter of the file's, σ below
// half the prior's); the truth within 3σ everywhere. σ honest, the pupil adjusted (6×5 board): over
// 30 Monte-Carlo runs in which the file's values are drawn about the truth with their σ (what a
// stated σ means) and the pixels are noisy, the reported σ of each shell value matches the spread
// of its error within 1.5.
TEST(RefractiveCalibration, ShellPriorsPullTowardTruthWithHonestSigma) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  const TargetSpec target = ParseTarget("chessboard:12x9:30");
  const refraction::ShellArray t = refraction::ShellValues(refraction::ShellOf(truth));
  // The port file: the inner centre moved by (dx, dy) from the truth, the radii by dr_o, dr_i.
  const auto file = [&](double dx, double dy, double dr_o, double dr_i) {
    ports::PortSpec spec = truth.spec;
    auto& dome = std::get<ports::DomePort>(spec.shape);
    dome.inner.center_mm += Eigen::Vector3d(dx, dy, 0);
    dome.outer.radius_mm += dr_o;
    dome.inner.radius_mm += dr_i;
    spec.sigma.inner_offset_mm = Eigen::Vector3d(1.0, 1.0, 0.0);
    spec.sigma.outer_radius_mm = 0.5;
    spec.sigma.inner_radius_mm = 0.5;
    return ports::Place(spec, truth.ep_in_housing_mm, truth.n_glass, truth.n_water);
  };
  const CalibrationRecord air = ExactLens(cam);
  const auto options = [&](const PortSystem& predicted) {
    RefractiveOptions o = Options(predicted, cam.sensor.pixel_pitch_mm);
    o.air = air;
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kFixed;
    o.compare_central = false;
    o.free_shell = true;
    return o;
  };
  const char* names[] = {"", "outer radius", "inner radius", "offset x", "offset y"};
  {
    RefractiveOptions o = options(file(1.0, -1.0, 0, 0));
    o.port_free = {false, false, false};
    const auto r = CalibrateRefractive(Views(cam, truth, target, 5), target, o);
    const refraction::ShellArray f = refraction::ShellValues(refraction::ShellOf(o.port));
    ASSERT_TRUE(r.shell_free[1] && r.shell_free[2] && r.shell_free[3] && r.shell_free[4]);
    EXPECT_FALSE(r.shell_free[0] || r.shell_free[5]);
    for (int i = 1; i <= 4; ++i) {
      std::printf("shell prior: %s file %.4f, estimate %.4f +- %.4f, truth %.4f\n", names[i], f[i],
                  r.shell[i], r.shell_sigma[i], t[i]);
      EXPECT_LE(std::abs(r.shell[i] - t[i]), 3 * r.shell_sigma[i]) << names[i];
      EXPECT_LE(r.shell_sigma[i], (i <= 2 ? 0.5 : 1.0) * 1.0001) << names[i];
    }
    for (int i = 3; i <= 4; ++i) {  // the lateral offset: pulled to the truth
      EXPECT_LT(std::abs(r.shell[i] - t[i]), 0.25 * std::abs(f[i] - t[i])) << names[i];
      EXPECT_LT(r.shell_sigma[i], 0.5 * 1.0) << names[i];
    }
    EXPECT_NEAR(r.lens.sigma0_px, 0.3, 0.03);
    // The as-calibrated port carries the estimate, not the prior's σ (it would count twice).
    const auto& d = std::get<ports::DomePort>(r.estimated_port.shape);
    EXPECT_NEAR(d.inner.radius_mm, r.shell[2], 1e-12);
    EXPECT_NEAR((d.inner.center_mm - d.outer.center_mm).x(), r.shell[3], 1e-12);
    EXPECT_TRUE(r.estimated_port.sigma.Empty());
  }
  // What the images alone say of the shell (the plan of these views, every value with a 100 mm
  // prior, the pupil adjusted): the radii nothing (σ near the prior's), the lateral offset a few mm,
  // a flat port's thickness tens of mm (it trades with the distance).
  for (const PortSystem& base : {truth, TiltedFlat(2.0, 25.0)}) {
    ports::PortSpec spec = base.spec;
    spec.sigma.thickness_mm = 100;
    if (base.IsDome()) {
      spec.sigma = {};
      spec.sigma.outer_radius_mm = spec.sigma.inner_radius_mm = 100;
      spec.sigma.inner_offset_mm = Eigen::Vector3d(100, 100, 100);
    }
    const PortSystem sys = ports::Place(spec, base.ep_in_housing_mm, base.n_glass, base.n_water);
    std::vector<ImageResult> poses;
    Views(cam, sys, target, 9, &poses);
    RefractiveOptions o = options(sys);
    const RefractivePlan plan = PlanRefractive(poses, target, cam, o, 0.3);
    o.free_shell = false;
    const RefractivePlan fixed = PlanRefractive(poses, target, cam, o, 0.3);
    ASSERT_TRUE(plan.determined);
    std::printf("%s shell from the images alone (prior sigma 100 mm):", sys.IsDome() ? "dome" : "flat");
    for (int i = 1; i < refraction::kShellNumParams; ++i) {
      if (plan.shell_free[i]) std::printf(" %s %.3g", refraction::ShellParams(plan.kind)[i].name.data(), plan.shell_sigma[i]);
    }
    std::printf("; axial port parameter sigma %.3g (shell fixed: %.3g)\n", plan.port_sigma[2],
                fixed.port_sigma[2]);
    if (sys.IsDome()) {
      EXPECT_GT(plan.shell_sigma[1], 50);  // the radii: not seen
      EXPECT_GT(plan.shell_sigma[2], 50);
      EXPECT_LT(plan.shell_sigma[3], 5);   // the lateral offset: seen, a few mm
      EXPECT_LT(plan.shell_sigma[4], 5);
    } else {
      EXPECT_GT(plan.shell_sigma[1], 10);  // the thickness: hardly
      EXPECT_GT(plan.port_sigma[2], 10 * fixed.port_sigma[2]);
    }
  }

  const TargetSpec small = ParseTarget("chessboard:6x5:60");
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  std::mt19937_64 rng(77);
  std::normal_distribution<double> normal;
  std::array<Spread, 5> spread;
  for (int k = 0; k < runs; ++k) {
    const double dx = 1.0 * normal(rng), dy = 1.0 * normal(rng);
    const double dro = 0.5 * normal(rng), dri = 0.5 * normal(rng);
    RefractiveOptions o = options(file(dx, dy, dro, dri));
    o.search = false;
    const auto r = CalibrateRefractive(Views(cam, truth, small, 3000 + k), small, o);
    for (int i = 1; i <= 4; ++i) spread[i].Add(r.shell[i] - t[i], r.shell_sigma[i]);
  }
  for (int i = 1; i <= 4; ++i) {
    std::printf("shell prior Monte Carlo, %s: sigma %.4f, spread %.4f, ratio %.2f\n", names[i],
                spread[i].sigma / runs, spread[i].Sd(), spread[i].Ratio());
    EXPECT_GT(spread[i].Ratio(), 1 / 1.5) << names[i];
    EXPECT_LT(spread[i].Ratio(), 1.5) << names[i];
  }
}

// A port the rays cannot cross to the targets (a flat port 50 m ahead: every target point is in
// the air behind it) and a shell prior without σ in the port file: refused, naming the field.
TEST(RefractiveCalibration, UntraceablePortAndMissingSigmaAreRefused) {
  const camera::Camera cam = D300Brown();
  const TargetSpec target = ParseTarget("chessboard:8x6:60");
  const PortSystem truth = TiltedFlat(2.0, 25.0);
  const auto views = Views(cam, truth, target, 1);
  RefractiveOptions o = Options(TiltedFlat(0.0, 50000.0), cam.sensor.pixel_pitch_mm);
  o.compare_central = false;
  try {
    CalibrateRefractive(views, target, o);
    FAIL() << "an untraceable port was not refused";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "port") << e.what();
  }
  RefractiveOptions s = Options(truth, cam.sensor.pixel_pitch_mm);
  s.free_shell = true;
  try {
    CalibrateRefractive(views, target, s);
    FAIL() << "--free-shell without sigma was not refused";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "free_shell") << e.what();
  }
}

TEST(RefractiveCalibration, BadInputIsRefused) {
  const camera::Camera cam = D300Brown();
  const PortSystem truth = AsBuiltNi320();
  const TargetSpec target = ParseTarget("chessboard:8x6:60");
  RefractiveOptions o = Options(truth, cam.sensor.pixel_pitch_mm);
  // No images.
  EXPECT_THROW(CalibrateRefractive({}, target, o), InvalidInput);
  // An intrinsics mode that needs an air calibration without one.
  o.intrinsics = IntrinsicsMode::kFixed;
  EXPECT_THROW(CalibrateRefractive(Views(cam, truth, target, 1), target, o), InvalidInput);
  // An air calibration of another model.
  o.intrinsics = IntrinsicsMode::kPrior;
  CalibrationRecord air;
  air.camera = camera::Camera::Ideal(camera::CameraModelId::kOpenCV, cam.sensor, 4400);
  air.free = DefaultFree(camera::CameraModelId::kOpenCV);
  air.has_covariance = true;
  air.covariance = Eigen::MatrixXd::Identity(12, 12);
  o.air = air;
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  EXPECT_THROW(CalibrateRefractive(Views(cam, truth, target, 1), target, o), InvalidInput);
  EXPECT_THROW(ParseIntrinsicsMode("loose", "--intrinsics"), InvalidInput);
}

}  // namespace
}  // namespace porthole::calib
