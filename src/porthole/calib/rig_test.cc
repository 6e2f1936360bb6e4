// Proves CalibrateRig (rig.h) recovers a two-camera rig from synthetic synchronised frames: the
// relative pose within 3σ (translation within issue 26's 0.2 mm) and each camera's intrinsics within
// 3σ, with σ matching the Monte-Carlo spread of 30 noise draws within [1/1.5, 1.5] (the dome rig's
// Monte-Carlo run is in measure/triangulate_test.cc, with the lengths measured through it); frames
// seen by one camera count; a camera sharing no frame, or option counts that match neither 1 nor the
// cameras, are refused.
#include "porthole/calib/rig.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "porthole/calib/test_refractive.h"
#include "porthole/calib/test_fields.h"
#include "porthole/calib/test_rig.h"
#include "porthole/core/error.h"
#include "porthole/refraction/test_camera.h"

namespace porthole::calib {
namespace {

using namespace fixtures;  // test_rig.h: Truth, TwoCameraRig, TwoDomeRig, Frames, ExpectSigmaMatchesSpread

RigOptions Options() {
  RigOptions o;
  CalibrationOptions c;
  c.model = camera::CameraModelId::kOpenCV;
  o.cameras = {c};
  return o;
}

double AngleDeg(const Eigen::Vector3d& rotation_rad, const Eigen::Matrix3d& truth) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(rotation_rad.norm(), rotation_rad.normalized()).toRotationMatrix();
  return Eigen::AngleAxisd(r * truth.transpose()).angle() * 180 / M_PI;
}

TEST(Rig, RecoversATwoCameraRig) {
  const Truth truth = TwoCameraRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  // 15 synchronised frames, 3 seen by camera 0 alone and 2 by camera 1 alone.
  const auto sets = Frames(truth, target, 15, 5, 0.3, 3, 2);
  const RigResult r = CalibrateRig(sets, target, Options());
  ASSERT_EQ(r.cameras.size(), 2u);
  EXPECT_EQ(r.frames.size(), 20u);
  const RigCamera& c1 = r.cameras[1];
  const double dt = (c1.translation_mm - truth.cam_from_rig[1].translation()).norm();
  const double dr = AngleDeg(c1.rotation_rad, truth.cam_from_rig[1].linear());
  std::printf("rig: translation %.3f %.3f %.3f mm (error %.4f mm, sigma %.4f %.4f %.4f), rotation error %.5f deg, "
              "baseline %.3f +- %.3f mm, convergence %.3f deg, sigma0 %.4f px\n",
              c1.translation_mm.x(), c1.translation_mm.y(), c1.translation_mm.z(), dt, c1.pose_sigma(3),
              c1.pose_sigma(4), c1.pose_sigma(5), dr, c1.baseline_mm, c1.baseline_sigma_mm, c1.convergence_deg,
              r.sigma0_px);
  // Each of the six within 3σ, and the bounds: 0.2 mm, 0.01°.
  const Eigen::AngleAxisd true_r(truth.cam_from_rig[1].linear());
  const Eigen::Vector3d true_w = true_r.angle() * true_r.axis();
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(c1.rotation_rad(i) - true_w(i)), 3 * c1.pose_sigma(i)) << i;
    EXPECT_LE(std::abs(c1.translation_mm(i) - truth.cam_from_rig[1].translation()(i)), 3 * c1.pose_sigma(3 + i)) << i;
  }
  std::printf("rig: rotation sigma %.5f %.5f %.5f deg\n", c1.pose_sigma(0) * 180 / M_PI, c1.pose_sigma(1) * 180 / M_PI,
              c1.pose_sigma(2) * 180 / M_PI);
  // The 0.2 mm holds; its 0.01° is below this network's own σ of the rotation about x
  // and y (0.011°, 0.015°: the pose angles of 15 views at f = 2000 px), so the rotation is held
  // to 3σ above and to 0.05° here.
  EXPECT_LT(dt, 0.2);
  EXPECT_LT(dr, 0.05);
  EXPECT_NEAR(c1.baseline_mm, 300, 3 * c1.baseline_sigma_mm);
  EXPECT_NEAR(c1.convergence_deg, 5, 3 * c1.pose_sigma(1) * 180 / M_PI);
  EXPECT_NEAR(r.sigma0_px, 0.3, 0.03);
  for (int k = 0; k < 2; ++k) {
    const auto& cal = r.cameras[k].calibration;
    for (int i = 0; i < 8; ++i) {
      EXPECT_LE(std::abs(cal.camera.params[i] - truth.cams[k].params[i]), 3.5 * cal.sigma[i]) << k << " " << i;
    }
  }
  EXPECT_EQ(r.cameras[0].n_frames, 18);  // 15 shared + 3 alone
  EXPECT_EQ(r.cameras[1].n_frames, 17);
  EXPECT_EQ(r.message, "ok");
}

TEST(Rig, SigmaMatchesMonteCarloSpread) {
  const Truth truth = TwoCameraRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  // tx, ty, tz, baseline, fx of camera 1.
  std::array<double, 5> sum{}, sum2{}, sigma{};
  for (int k = 0; k < runs; ++k) {
    const RigResult r = CalibrateRig(Frames(truth, target, 15, 100 + k), target, Options());
    const RigCamera& c = r.cameras[1];
    const std::array<double, 5> e = {c.translation_mm.x() - truth.cam_from_rig[1].translation().x(),
                                     c.translation_mm.y() - truth.cam_from_rig[1].translation().y(),
                                     c.translation_mm.z() - truth.cam_from_rig[1].translation().z(),
                                     c.baseline_mm - 300, c.calibration.camera.params[0] - truth.cams[1].params[0]};
    const std::array<double, 5> s = {c.pose_sigma(3), c.pose_sigma(4), c.pose_sigma(5), c.baseline_sigma_mm,
                                     c.calibration.sigma[0]};
    for (int i = 0; i < 5; ++i) sum[i] += e[i], sum2[i] += e[i] * e[i], sigma[i] += s[i] / runs;
  }
  ExpectSigmaMatchesSpread<5>("rig", {"tx", "ty", "tz", "baseline", "fx1"}, runs, sum, sum2, sigma);
}

// The dome rig's options (TwoDomeRig): one set of camera options, each port predicted at its
// dome's centre (the pupils millimetres off).
RigOptions DomeRigOptions(const Truth& truth) {
  RigOptions o;
  CalibrationOptions c;
  c.pixel_pitch_mm = truth.cams[0].sensor.pixel_pitch_mm;
  o.cameras = {c};
  for (int k = 0; k < 2; ++k) {
    const auto t = refraction::ParamsOf(truth.ports[k]);
    o.ports.push_back(fixtures::Displaced(truth.ports[k], {-t[0], -t[1], -t[2]}));
  }
  return o;
}

// Prints the dome rig's errors (`what`) and checks the single-camera bounds: σ0 at the 0.3 px
// simulated, the translation within 0.2 mm and 3σ per axis, each pupil within 3σ per axis, 0.1 mm
// laterally and 0.3 mm axially. Returns the rotation error, deg.
double ExpectDomeRigRecovered(const RigResult& r, const Truth& truth, const char* what) {
  const RigCamera& c1 = r.cameras[1];
  const double dt = (c1.translation_mm - truth.cam_from_rig[1].translation()).norm();
  const double dr = AngleDeg(c1.rotation_rad, truth.cam_from_rig[1].linear());
  std::printf("%s: translation error %.4f mm (sigma %.4f %.4f %.4f), rotation error %.5f deg (sigma %.5f %.5f %.5f), "
              "sigma0 %.4f px\n", what, dt, c1.pose_sigma(3), c1.pose_sigma(4), c1.pose_sigma(5), dr,
              c1.pose_sigma(0) * 180 / M_PI, c1.pose_sigma(1) * 180 / M_PI, c1.pose_sigma(2) * 180 / M_PI, r.sigma0_px);
  EXPECT_LT(dt, 0.2);
  EXPECT_NEAR(r.sigma0_px, 0.3, 0.03);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(c1.translation_mm(i) - truth.cam_from_rig[1].translation()(i)), 3 * c1.pose_sigma(3 + i)) << i;
  }
  for (int k = 0; k < 2; ++k) {
    const auto& cam = r.cameras[k];
    EXPECT_TRUE(cam.has_port);
    const auto t = refraction::ParamsOf(truth.ports[k]);
    std::printf("%s, camera %d: pupil %.3f %.3f %.3f +- %.3f %.3f %.3f (true %.1f %.1f %.1f)\n", what, k, cam.port[0],
                cam.port[1], cam.port[2], cam.port_sigma[0], cam.port_sigma[1], cam.port_sigma[2], t[0], t[1], t[2]);
    for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(cam.port[i] - t[i]), 3 * cam.port_sigma[i]) << k << " " << i;
    EXPECT_LE(std::hypot(cam.port[0] - t[0], cam.port[1] - t[1]), 0.1) << k;
    EXPECT_LE(std::abs(cam.port[2] - t[2]), 0.3) << k;
  }
  return dr;
}

// Two D300 + 24 mm cameras, each behind its own as-built NI320 dome with its own pupil offset
// ((0.4, 1.0, 5.4) and (−0.3, 0.5, 3.0) mm from the outer centre), 300 mm apart with 5°
// convergence, 15 synchronised frames in water at 0.3 px, the ports predicted at the domes'
// centres (millimetres off), each lens's calibration in air (without the housing) as a prior: the
// relative pose and each camera's port within 3σ, the translation within 0.2 mm, each pupil within
// the single-camera bounds (0.1 mm laterally, 0.3 mm axially).
TEST(Rig, CamerasBehindTheirOwnDomes) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  RigOptions o = DomeRigOptions(truth);
  for (int k = 0; k < 2; ++k) o.air_lens.push_back(fixtures::AirCalibration(truth.cams[k], target));  // each lens alone
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  ExpectDomeRigRecovered(CalibrateRig(Frames(truth, target, 15, 9), target, o), truth, "dome rig");
}

// The same rig with each camera's in-air calibration made through its own dome (the housing on:
// a central calibration of 20 air views through the dome in air), taken as such (the default,
// housed_prior.h): the relative pose within 0.01° and the bounds above; taken as the bare lens
// (kLensBare, said so) the same calibrations put the pupils millimetres off.
TEST(Rig, CamerasBehindTheirOwnDomesWithHousedAirCalibrations) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  const TargetSpec small = ParseTarget("chessboard:12x9:30");
  const auto sets = Frames(truth, target, 15, 9);
  RigOptions o = DomeRigOptions(truth);
  for (int k = 0; k < 2; ++k) {
    o.air_lens.push_back(fixtures::RecordOf(
        Calibrate(fixtures::AirViews(truth.cams[k], truth.ports[k], small, 70 + k), small, o.cameras[0])));
  }
  ASSERT_EQ(o.air_of, RefractiveOptions::AirCalibrationOf::kThroughPort);  // the default reading
  EXPECT_LT(ExpectDomeRigRecovered(CalibrateRig(sets, target, o), truth, "dome rig, housed air calibrations"), 0.01);
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  const RigResult wrong = CalibrateRig(sets, target, o);
  for (int k = 0; k < 2; ++k) {
    const auto t = refraction::ParamsOf(truth.ports[k]);
    const double off = std::sqrt(std::pow(wrong.cameras[k].port[0] - t[0], 2) +
                                 std::pow(wrong.cameras[k].port[1] - t[1], 2) + std::pow(wrong.cameras[k].port[2] - t[2], 2));
    std::printf("dome rig, housed air calibrations taken as the bare lens, camera %d: pupil %.2f mm off\n", k, off);
    EXPECT_GT(off, 1.0) << k;
  }
}

// The same rig with each camera's air images through its own dome (the housing on, the focus
// unchanged: the paper's protocol, 20 views each of the chessboard) adjusted with the rig
// (RigOptions::air_images): the translation and each port within the bounds above, the rotation
// within 3σ (its σ about y is ≈ 0.006° here: 0.01° is 1.6σ), each air set at its noise; air
// images with in-air calibrations too, or without ports, are refused.
TEST(Rig, CamerasBehindTheirOwnDomesWithAirImages) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  const auto sets = Frames(truth, target, 15, 9);
  RigOptions o = DomeRigOptions(truth);
  for (int k = 0; k < 2; ++k) o.air_images.push_back(fixtures::AirViews(truth.cams[k], truth.ports[k], target, 80 + k));
  const RigResult r = CalibrateRig(sets, target, o);
  ExpectDomeRigRecovered(r, truth, "dome rig with air images");
  const RigCamera& c1 = r.cameras[1];
  const Eigen::AngleAxisd true_r(truth.cam_from_rig[1].linear());
  const Eigen::Vector3d rotation_error = c1.rotation_rad - true_r.axis() * true_r.angle();
  constexpr double kDeg = 180 / M_PI;
  for (int i = 0; i < 3; ++i) {
    std::printf("dome rig with air images, rotation error about %c: %.5f deg, sigma %.5f deg (%.2f sigma)\n", "xyz"[i],
                rotation_error(i) * kDeg, c1.pose_sigma(i) * kDeg, std::abs(rotation_error(i)) / c1.pose_sigma(i));
    EXPECT_LE(std::abs(rotation_error(i)), 3 * c1.pose_sigma(i)) << i;
  }
  for (int k = 0; k < 2; ++k) {
    const auto& cam = r.cameras[k];
    std::printf("dome rig with air images, camera %d: %zu air images at RMS %.4f px\n", k, cam.air_images.size(),
                cam.air_rms_px);
    EXPECT_EQ(cam.air_images.size(), o.air_images[k].size());
    EXPECT_NEAR(cam.air_rms_px, 0.3 * std::sqrt(2.0), 0.05);
  }
  RigOptions both = o;
  both.air_lens = {fixtures::AirCalibration(truth.cams[0], target), fixtures::AirCalibration(truth.cams[1], target)};
  EXPECT_THROW(CalibrateRig(sets, target, both), InvalidInput);
  RigOptions no_port = o;
  no_port.ports.clear();
  EXPECT_THROW(CalibrateRig(sets, target, no_port), InvalidInput);
  RigOptions one = o;
  one.air_images.pop_back();
  EXPECT_THROW(CalibrateRig(sets, target, one), InvalidInput);
}

// The same rig with each camera's air images taken at another focus (its lens refocused between
// the sets: c 1.2 % longer for camera 0, 0.8 % shorter for camera 1), RigOptions::air_refocused:
// each camera's factor within 3σ of its truth, the rig and the ports within the bounds above. Taken
// as one focus the same images put a pupil millimetres off. Without air images refused.
TEST(Rig, CamerasBehindTheirOwnDomesWithRefocusedAirImages) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  const auto sets = Frames(truth, target, 15, 9);
  const double factor[] = {1.012, 0.992};
  RigOptions o = DomeRigOptions(truth);
  for (int k = 0; k < 2; ++k) {
    camera::Camera refocused = truth.cams[k];
    for (int i = 0; i < refocused.info().num_focal; ++i) refocused.params[i] *= factor[k];
    o.air_images.push_back(fixtures::AirViews(refocused, truth.ports[k], target, 80 + k));
  }
  o.air_refocused = true;
  const RigResult r = CalibrateRig(sets, target, o);
  ExpectDomeRigRecovered(r, truth, "dome rig with refocused air images");
  for (int k = 0; k < 2; ++k) {
    const RigCamera& c = r.cameras[k];
    std::printf("dome rig with refocused air images, camera %d: focal scale %.5f +- %.5f (truth %.3f), air RMS %.4f px\n",
                k, c.air_focal_scale, c.air_focal_scale_sigma, factor[k], c.air_rms_px);
    EXPECT_LE(std::abs(c.air_focal_scale - factor[k]), 3 * c.air_focal_scale_sigma) << k;
    EXPECT_LT(c.air_focal_scale_sigma, 0.002) << k;
  }
  // Taken as one focus: the pupils are off.
  o.air_refocused = false;
  const RigResult one = CalibrateRig(sets, target, o);
  double worst = 0;
  for (int k = 0; k < 2; ++k) {
    const auto t = refraction::ParamsOf(truth.ports[k]);
    worst = std::max(worst, std::abs(one.cameras[k].port[2] - t[2]));
  }
  std::printf("dome rig with refocused air images taken as one focus: a pupil %.2f mm off axially\n", worst);
  EXPECT_GT(worst, 1.0);
  RigOptions none = DomeRigOptions(truth);
  none.air_refocused = true;
  EXPECT_THROW(CalibrateRig(sets, target, none), InvalidInput);
}

// A free target in a rig (issue 26): the dome rig above with each camera's air images, the target
// the raised board known only to millimetres (calib/test_fields.h): held at those values the fit is
// poor (σ0 over 1 px); adjusted with the rig (the first camera's datum, the board's plane), σ0 the
// 0.3 px simulated, the relative pose, the ports and every raised point within 3σ of the truth.
TEST(Rig, AFreeTargetInARigBehindDomes) {
  const Truth truth = TwoDomeRig();
  const TargetSpec field = fixtures::RaisedBoard();
  const TargetSpec given = fixtures::MeasuredByHand(field);
  auto sets = Frames(truth, field, 15, 9);
  DropIdZero(&sets);  // id 0 is no target of the field
  RigOptions o = DomeRigOptions(truth);
  o.cameras[0].centre_correction = CalibrationOptions::CentreCorrection::kOff;  // synthetic centres
  for (int k = 0; k < 2; ++k) o.air_images.push_back(fixtures::AirViews(truth.cams[k], truth.ports[k], field, 80 + k));
  const RigResult held = CalibrateRig(sets, given, o);
  std::printf("dome rig, field held at the hand-measured values: sigma0 %.4f px\n", held.sigma0_px);
  o.cameras[0].target_free = true;
  const RigResult r = CalibrateRig(sets, given, o);
  // The board is small in these frames (350 × 250 mm at 0.8–1.8 m): σ of a pupil ≈ 0.07 mm laterally,
  // so the bounds are the estimate's own 3σ.
  const RigCamera& c1 = r.cameras[1];
  const Eigen::AngleAxisd true_r(truth.cam_from_rig[1].linear());
  const Eigen::Vector3d rotation_error = c1.rotation_rad - true_r.axis() * true_r.angle();
  std::printf("dome rig, free target: translation error %.4f mm, rotation error %.5f deg, sigma0 %.4f px\n",
              (c1.translation_mm - truth.cam_from_rig[1].translation()).norm(),
              AngleDeg(c1.rotation_rad, truth.cam_from_rig[1].linear()), r.sigma0_px);
  EXPECT_NEAR(r.sigma0_px, 0.3, 0.03);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(c1.translation_mm(i) - truth.cam_from_rig[1].translation()(i)), 3 * c1.pose_sigma(3 + i)) << i;
    EXPECT_LE(std::abs(rotation_error(i)), 3 * c1.pose_sigma(i)) << i;
  }
  for (int k = 0; k < 2; ++k) {
    const auto t = refraction::ParamsOf(truth.ports[k]);
    const RigCamera& c = r.cameras[k];
    std::printf("dome rig, free target, camera %d: pupil %.3f %.3f %.3f +- %.3f %.3f %.3f (true %.1f %.1f %.1f)\n", k,
                c.port[0], c.port[1], c.port[2], c.port_sigma[0], c.port_sigma[1], c.port_sigma[2], t[0], t[1], t[2]);
    for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(c.port[i] - t[i]), 3 * c.port_sigma[i]) << k << " " << i;
  }
  EXPECT_GT(held.sigma0_px, 2 * r.sigma0_px);
  ASSERT_TRUE(r.datum.Set());
  const std::vector<Eigen::Vector3d> truth_points = TargetPoints(field);
  double worst = 0;
  for (int id = fixtures::kFirstRaisedTarget; id < fixtures::kFirstRaisedTarget + 12; ++id) {
    for (int a = 0; a < 3; ++a) {
      const double e = r.target_points_mm[id](a) - truth_points[id](a);
      worst = std::max(worst, std::abs(e));
      EXPECT_GT(r.target_sigma_mm[id](a), 0) << id << " " << a;
      EXPECT_LE(std::abs(e), 3 * r.target_sigma_mm[id](a)) << "point " << id << " coordinate " << a;
    }
  }
  std::printf("dome rig, free target: raised points within %.4f mm of the truth (given up to 2 mm off)\n", worst);
  const auto j = RigToJson(r, given, o);
  EXPECT_EQ(j["rig"]["target_adjusted"]["points"].size(), 60u);
}

TEST(Rig, BadInputIsRefused) {
  const Truth truth = TwoCameraRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  auto sets = Frames(truth, target, 10, 7);
  RigOptions o = Options();
  EXPECT_THROW(CalibrateRig({sets[0]}, target, o), InvalidInput);  // one camera
  RigOptions three = o;
  three.cameras.resize(3, o.cameras[0]);
  EXPECT_THROW(CalibrateRig(sets, target, three), InvalidInput);  // 3 option sets for 2 cameras
  auto apart = sets;
  for (auto& d : apart[1]) d.image = "other_" + d.image;  // no frame name in common
  try {
    CalibrateRig(apart, target, o);
    ADD_FAILURE() << "a rig without a shared frame was calibrated";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("shares no frame"), std::string::npos) << e.what();
  }
  auto twice = sets;
  twice[0][1].image = "f000.jpg";  // two images of camera 0 are frame f000
  EXPECT_THROW(CalibrateRig(twice, target, o), InvalidInput);
}

}  // namespace
}  // namespace porthole::calib
