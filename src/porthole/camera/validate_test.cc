// Proves the one calibration check (camera/validate.h): realistic cameras of every kind pass; a
// negative fy, a principal point off the image, a pitch of 0, a distortion that folds the frame are
// refused naming the key; a calibration of another image size, pitch or lens is refused naming both
// values; an impossible result (fx −875.9, RMS inf) is an error.
#include "porthole/camera/validate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace porthole::camera {
namespace {

const Sensor kD300{4288, 2848, 0.0055};
const Sensor kVga{640, 480, 0.0055};
const ExpectedCamera kD300With24mm{.name = "Nikon D300 + 24mm", .sensor = kD300, .focal_length_mm = 24.0, .max_principal_distance_mm = 27.3};

// The InvalidInput's field (and "" when nothing is thrown).
template <typename F>
std::string FieldOf(F f, std::string* message = nullptr) {
  try {
    f();
  } catch (const InvalidInput& e) {
    if (message != nullptr) *message = e.what();
    return e.field();
  }
  return "";
}

Camera Paper() {  // the paper's Table 6, in air
  return {CameraModelId::kBrown, kD300, {25.801, -0.026, -0.144, 1.842e-4, -3.030e-7, 0, 6.582e-6, 1.620e-5, 0, 0}};
}

Camera Vga(double fx, double fy, double k1 = 0) {
  return {CameraModelId::kOpenCV, kVga, {fx, fy, 319.5, 239.5, k1, 0, 0, 0, 0, 0, 0, 0}};
}

TEST(ValidateCalibration, RealisticCamerasOfEveryKindPass) {
  EXPECT_NO_THROW(ValidateCalibration(Paper(), "air"));
  EXPECT_NO_THROW(ValidateCalibration(Vga(531, 531, -0.2), "a"));
  EXPECT_NO_THROW(ValidateCalibration({CameraModelId::kOpenCV, kD300,
                                       {4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4, -0.01, 0.02, 0.005, 0.001}}));
  EXPECT_NO_THROW(ValidateCalibration({CameraModelId::kKannalaBrandt, kD300,
                                       {1909, 1910, 2144, 1424, 0.02, -0.005, 0.001, -0.0002}}));
  // A circular fisheye (180° equidistant, image circle inside the frame): corners without a ray.
  EXPECT_NO_THROW(ValidateCalibration({CameraModelId::kKannalaBrandt, kD300, {900, 900, 2143.5, 1423.5, 0, 0, 0, 0}}));
  EXPECT_NO_THROW(ValidateCalibration({CameraModelId::kEquisolid, kD300, {1909, 2146, 1422, 0.005, 0.0}}));
}

TEST(ValidateCalibration, NegativeFocalLengthsAndAPrincipalPointOffTheImageAreRefused) {
  std::string msg;
  // COLMAP "PINHOLE 640 480 3000 -1000 ...": fy −1000 (the average focal length is still > 0).
  EXPECT_EQ(FieldOf([] { ValidateCalibration(Vga(3000, -1000), "IN 'cameras.txt'"); }, &msg), "IN 'cameras.txt'.fy_px");
  EXPECT_NE(msg.find("-1000"), std::string::npos) << msg;
  EXPECT_EQ(FieldOf([] { ValidateCalibration(Vga(-531, 531), "a"); }), "a.fx_px");
  Camera p = Paper();
  p.params[0] = -25.8;
  EXPECT_EQ(FieldOf([&] { ValidateCalibration(p, "air"); }), "air.c_mm");
  Camera off = Vga(531, 531);
  off.params[2] = 700;  // cx beyond the 640 px width
  EXPECT_EQ(FieldOf([&] { ValidateCalibration(off, "a"); }, &msg), "a.cx_px");
  EXPECT_NE(msg.find("outside the 640 x 480 px image"), std::string::npos) << msg;
  Camera bad_sensor = Vga(531, 531);
  bad_sensor.sensor.pixel_pitch_mm = 0;
  EXPECT_EQ(FieldOf([&] { ValidateCalibration(bad_sensor, "a"); }), "a.sensor.pixel_pitch_mm");
  Camera nan = Vga(531, 531);
  nan.params[5] = NAN;
  EXPECT_EQ(FieldOf([&] { ValidateCalibration(nan, "a"); }), "a.k2");
}

TEST(ValidateCalibration, ADistortionThatFoldsTheFrameIsRefused) {
  // k1 = −0.5 at fx 500: x(1 + k1 x²) peaks at x = 0.816 (0.544) while the corner needs 0.8.
  std::string msg;
  EXPECT_EQ(FieldOf([] { ValidateCalibration(Vga(500, 500, -0.5), "a"); }, &msg), "a.k1");
  EXPECT_NE(msg.find("folds the frame"), std::string::npos) << msg;
  // The same lens on a frame it covers (fx 1500: corner at 0.27) passes.
  EXPECT_NO_THROW(ValidateCalibration(Vga(1500, 1500, -0.5), "a"));
  // A Brown barrel K1 so strong that the correction turns back inside the frame.
  Camera b = Paper();
  b.params[3] = -2e-3;  // K1 < 0 strong: x̄(1 + K1 r²) folds at r = 12.9 mm < the 14.5 mm corner
  EXPECT_EQ(FieldOf([&] { ValidateCalibration(b, "air"); }), "air.K1");
}

TEST(CheckCalibrationFits, AnotherImageSizePitchOrLensIsRefusedNamingBoth) {
  std::string msg;
  // The reproducer: a 640 × 480 OpenCV calibration (fx 531 px) for the D300 + 24 mm.
  EXPECT_EQ(FieldOf([] { CheckCalibrationFits(Vga(531, 531), false, kD300With24mm, "--air-calibration"); }, &msg),
            "--air-calibration");
  EXPECT_NE(msg.find("640 x 480"), std::string::npos) << msg;
  EXPECT_NE(msg.find("4288 x 2848"), std::string::npos) << msg;
  // A calibration in pixels (pitch 1: c_mm 4454.5).
  Camera px = Paper();
  px.sensor.pixel_pitch_mm = 1;
  px.params[0] = 4454.5;
  EXPECT_EQ(FieldOf([&] { CheckCalibrationFits(px, true, kD300With24mm, "--air-calibration"); }, &msg),
            "--air-calibration");
  EXPECT_NE(msg.find("pixel pitch 1 mm"), std::string::npos) << msg;
  EXPECT_NE(msg.find("0.0055 mm"), std::string::npos) << msg;
  // Another pitch by 5 %.
  Camera pitch = Paper();
  pitch.sensor.pixel_pitch_mm = 0.00578;
  EXPECT_EQ(FieldOf([&] { CheckCalibrationFits(pitch, true, kD300With24mm, "x"); }), "x");
  // A focal length of 1e-300 mm, and one of another lens (50 mm), and the upper bound.
  for (double c : {1e-300, 2.92, 20.3, 31.5, 50.0}) {
    Camera other = Paper();
    other.params[0] = c;
    EXPECT_EQ(FieldOf([&] { CheckCalibrationFits(other, false, kD300With24mm, "x"); }, &msg), "x") << c;
  }
  EXPECT_NE(msg.find("20.4 to 31.39 mm"), std::string::npos) << msg;
  // Inside [24 × 0.85, 27.3 × 1.15] = [20.4, 31.395]: accepted (the paper's 25.801, and both ends).
  for (double c : {20.5, 25.801, 31.3}) {
    Camera ok = Paper();
    ok.params[0] = c;
    EXPECT_NO_THROW(CheckCalibrationFits(ok, true, kD300With24mm, "x")) << c;
  }
  // A pitch within 2 % (5.51 µm against 5.5) is the same body.
  Camera close = Paper();
  close.sensor.pixel_pitch_mm = 0.00551;
  EXPECT_NO_THROW(CheckCalibrationFits(close, true, kD300With24mm, "x"));
}

TEST(RequirePossibleResult, NonPositiveFocalLengthOrNonFiniteRmsIsAnError) {
  std::string msg;
  // convert's Brown → OpenCV refit that ended at fx −875.9.
  EXPECT_EQ(FieldOf([] { RequirePossibleResult(Vga(-875.9, 531), 181.5, "OUT", "the refit to opencv"); }, &msg), "OUT");
  EXPECT_NE(msg.find("fx_px = -875.9"), std::string::npos) << msg;
  EXPECT_EQ(FieldOf([] { RequirePossibleResult(Vga(531, 531), INFINITY, "fit", "the fit"); }, &msg), "fit");
  EXPECT_NE(msg.find("RMS is inf"), std::string::npos) << msg;
  EXPECT_EQ(FieldOf([] { RequirePossibleResult(Vga(531, NAN), std::nullopt, "fit", "the fit"); }), "fit");
  EXPECT_NO_THROW(RequirePossibleResult(Vga(531, 531), 0.2, "fit", "the fit"));
  EXPECT_NO_THROW(RequirePossibleResult(Paper(), std::nullopt, "fit", "the fit"));
}

}  // namespace
}  // namespace porthole::camera
