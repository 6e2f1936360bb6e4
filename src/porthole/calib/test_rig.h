// Test fixture shared by the rig calibration and the measurement tests (header only, tests only):
// two-camera rigs (in air; each camera behind its own as-built NI320 dome), synthetic synchronised
// frames of a chessboard, and the σ-against-spread check.
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"
#include "porthole/calib/test_refractive.h"
#include "porthole/camera/camera.h"
#include "porthole/refraction/refraction.h"
#include "porthole/refraction/test_camera.h"

namespace porthole::calib::fixtures {

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
inline Truth TwoCameraRig() {
  Truth t;
  const camera::Sensor s{4288, 2848, 0.0055};
  t.cams.push_back({camera::CameraModelId::kOpenCV, s, {2000, 2002, 2150, 1420, -0.08, 0.05, 2e-4, -1e-4, 0, 0, 0, 0}});
  t.cams.push_back({camera::CameraModelId::kOpenCV, s, {1990, 1991, 2130, 1430, -0.07, 0.04, -1e-4, 2e-4, 0, 0, 0, 0}});
  t.cam_from_rig.push_back(Eigen::Isometry3d::Identity());
  Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
  // Turned towards camera 0: its axis in the rig frame, Rᵀ·z = (−sin 5°, 0, cos 5°).
  x.linear() = Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  // Camera 1's centre 300 mm to the right of camera 0's: t = −R·c.
  x.translation() = -x.linear() * Eigen::Vector3d(300, 0, 0);
  t.cam_from_rig.push_back(x);
  return t;
}

// `n` frames of a 16 × 12 chessboard (50 mm) 0.8–1.8 m in front of the rig, tilted up to 35°; each
// camera sees the points that fall in its frame, σ noise_px; `only0`/`only1` frames seen by one
// camera alone. Image names f000.png …; detections per camera.
inline std::vector<std::vector<ImageDetections>> Frames(const Truth& truth, const TargetSpec& target, int n, uint64_t seed,
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

// The frames without id 0, which a coded field does not have (TargetPoints puts it at the origin).
inline void DropIdZero(std::vector<std::vector<ImageDetections>>* sets) {
  for (auto& camera : *sets) {
    for (auto& d : camera) {
      ImageDetections kept = d;
      kept.ids.clear();
      kept.points_px.clear();
      for (std::size_t i = 0; i < d.ids.size(); ++i) {
        if (d.ids[i] != 0) kept.ids.push_back(d.ids[i]), kept.points_px.push_back(d.points_px[i]);
      }
      d = kept;
    }
  }
}

// Two D300 + 24 mm cameras (TwoCameraRig's poses), each behind its own as-built NI320 dome with its
// own pupil offset ((0.4, 1.0, 5.4) and (−0.3, 0.5, 3.0) mm from the outer centre), in water.
inline Truth TwoDomeRig() {
  Truth t = TwoCameraRig();
  const camera::Camera lens = refraction::testing::D300Brown();
  t.cams = {lens, lens};
  t.cams[1].params[camera::kBrownC] += 0.2;  // another lens of the same kind
  const ports::PortSystem dome = AsBuiltNi320();
  t.ports = {dome, Displaced(dome, {-0.7, -0.5, -2.4})};
  return t;
}

// The sample standard deviation of `v`.
inline double Spread(const std::vector<double>& v) {
  double m = 0, s = 0;
  for (double x : v) m += x / v.size();
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / (v.size() - 1));
}

// Checks the mean reported σ of each quantity against its spread over the runs (sums of the
// errors, of their squares, and of the σ / runs): the ratio within [1/1.5, 1.5].
template <std::size_t K>
inline void ExpectSigmaMatchesSpread(const char* what, const std::array<const char*, K>& names, int runs,
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

}  // namespace porthole::calib::fixtures
