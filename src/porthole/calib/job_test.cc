// Proves CalibrateJob (calib/job.h) recovers a known camera from synthetic detections within 3σ
// (the paper's Table 6 lens), gives what Calibrate gives on the same input, says the pitch's
// plausibility warning in the library's words, checks the outputs only once the options hold
// together, and refuses combinations that cannot be made naming the field, never a CLI flag.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "porthole/calib/job.h"
#include "porthole/calib/synthetic.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

// The paper's in-water 24 mm calibration (Table 6, UW column) on a Nikon D300 (4288×2848 px,
// 5.5 µm), seen in 12 views of a 13×9 chessboard with 0.3 px noise.
std::vector<ImageDetections> PaperImages() {
  SyntheticOptions o;
  o.camera = camera::FromBrown({26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0},
                              {4288, 2848, 0.0055});
  o.target = ParseTarget("chessboard:13x9:40");
  o.n_images = 12;
  o.noise_px = 0.3;
  return MakeSyntheticSet(o).detections;
}

CalibrateJobOptions PaperJob() {
  CalibrateJobOptions o;
  o.given = PaperImages();
  o.target = "chessboard:13x9:40";
  o.pixel_pitch_mm = 0.0055;
  o.lens.reject_k = 0;  // Gaussian data: no outliers to reject
  return o;
}

TEST(CalibrateJob, RecoversThePaperLensAsCalibrateDoes) {
  const CalibrateJobResult r = CalibrateJob(PaperJob());
  ASSERT_TRUE(r.central);
  EXPECT_FALSE(r.refractive || r.plan);
  const CalibrationResult& c = *r.central;
  const double truth[] = {26.208, -0.058, -0.207};  // c, x0, y0 (mm)
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(c.camera.params[k] - truth[k]), 3 * c.sigma[k]) << k;
  EXPECT_NEAR(c.sigma0_px, 0.3, 0.03);
  EXPECT_TRUE(r.warnings.empty());  // 5.5 µm is a camera's pitch
  // The same adjustment as Calibrate's on the same detections and options.
  CalibrationOptions direct;
  direct.pixel_pitch_mm = 0.0055;
  direct.reject_k = 0;
  const CalibrationResult d = Calibrate(PaperImages(), ParseTarget("chessboard:13x9:40"), direct);
  for (int k = 0; k < camera::kBrownNumParams; ++k) EXPECT_DOUBLE_EQ(c.camera.params[k], d.camera.params[k]) << k;
  const auto j = CalibrateJobJson(r);
  EXPECT_EQ(j["sigma0_px"].get<double>(), c.sigma0_px);
  EXPECT_TRUE(j["skipped"].is_array() && j["skipped"].empty());
}

TEST(CalibrateJob, SaysAnImplausiblePitchInTheLibrarysWords) {
  CalibrateJobOptions o = PaperJob();
  o.pixel_pitch_mm = 5.5;  // µm given as mm
  std::vector<std::string> said;
  o.warn = [&](const std::string& w) { said.push_back(w); };
  o.check_outputs = [] { throw InvalidInput("out", "stop before the work"); };
  EXPECT_THROW(CalibrateJob(o), InvalidInput);
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0].rfind("`pixel_pitch_mm`: 5.5 mm", 0), 0u) << said[0];
}

TEST(CalibrateJob, ChecksTheOutputsOnceTheOptionsHoldTogether) {
  int checks = 0;
  CalibrateJobOptions o = PaperJob();
  o.check_outputs = [&] { ++checks; };
  o.field_out = true;  // no free target: refused before the outputs are checked
  EXPECT_THROW(CalibrateJob(o), InvalidInput);
  EXPECT_EQ(checks, 0);
  o.field_out = false;
  CalibrateJob(o);
  EXPECT_EQ(checks, 1);
}

// Each case: what is set, and the field the refusal must name.
TEST(CalibrateJob, RefusesWhatCannotBeMadeNamingTheField) {
  const auto field_of = [](CalibrateJobOptions o) -> std::string {
    try {
      CalibrateJob(o);
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << e.what();
      return e.field();
    }
    return "(accepted)";
  };
  CalibrateJobOptions none;
  EXPECT_EQ(field_of(none), "images");
  CalibrateJobOptions o = PaperJob();
  o.air_calibration = "air.json";  // without a port
  EXPECT_EQ(field_of(o), "air_calibration");
  o = PaperJob();
  o.datum = "control";  // without a free target
  EXPECT_EQ(field_of(o), "datum");
  o = PaperJob();
  o.port = "nimar-ni320";
  o.opencv_yaml = true;
  EXPECT_EQ(field_of(o), "opencv_yaml");
  o = PaperJob();
  o.port = "nimar-ni320";
  o.plan_only = true;
  o.air_given_detections = PaperImages();
  EXPECT_EQ(field_of(o), "plan_only");
  o = PaperJob();
  o.pixel_pitch_mm = -1;
  EXPECT_EQ(field_of(o), "pixel_pitch_mm");
  o = PaperJob();
  o.loss = "tukey";
  EXPECT_EQ(field_of(o), "loss");
  o = PaperJob();
  o.images = "frames/";
  o.given.reset();
  o.target.clear();
  EXPECT_EQ(field_of(o), "target");
}

}  // namespace
}  // namespace porthole::calib
