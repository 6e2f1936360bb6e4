// Fixtures shared by the refractive-calibration tests (refractive_test, coded_calib_test): the
// paper's as-built NI320 and a tilted flat port, synthetic views through a port, the in-air
// calibration. Header only, tests only.
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "porthole/calib/refractive.h"
#include "porthole/calib/synthetic.h"

namespace porthole::calib::fixtures {

using ports::PortSystem;

inline PortSystem AsBuiltNi320() {
  ports::PortSpec s;
  s.name = "nimar-ni320";
  ports::DomePort d;
  d.outer = {Eigen::Vector3d(-0.4, -1.0, 21.5), 83.4};
  d.inner = {Eigen::Vector3d(-0.4, -1.5, 20.3), 75.7};
  s.shape = d;
  return ports::Place(s, Eigen::Vector3d(0, 0, 26.9), 1.5168, 1.341);
}

inline PortSystem TiltedFlat(double tilt_deg, double distance_mm) {
  ports::PortSpec s;
  s.name = "flat";
  ports::FlatPort f;
  const double t = tilt_deg * M_PI / 180;
  f.normal = Eigen::Vector3d(std::sin(t) * std::cos(0.5), std::sin(t) * std::sin(0.5), std::cos(t));
  const Eigen::Vector3d ep(0, 0, 26.9);
  f.inner_point_mm = ep + distance_mm * f.normal;
  f.thickness_mm = 10;
  s.shape = f;
  return ports::Place(s, ep, 1.49, 1.341);
}

// 20 views at three ranges (the target fills 90 %, 40 % and 15 % of the width), projected through
// the port `truth` by the lens `cam`, with noise σ = noise_px (0.3 px).
// `poses` (optional) receives the true cam_from_target poses; `fill_list` replaces the three.
inline std::vector<ImageDetections> Views(const camera::Camera& cam, const PortSystem& truth,
                                          const TargetSpec& target, uint64_t noise_seed,
                                          std::vector<ImageResult>* poses = nullptr,
                                          std::vector<double> fill_list = {0.9, 0.4, 0.15},
                                          double noise_px = 0.3) {
  const refraction::Shell shell = refraction::ShellOf(truth);
  const auto port = refraction::ParamsOf(truth);
  std::vector<ImageDetections> all;
  int k = 0;
  const int n_ranges = static_cast<int>(fill_list.size());
  for (int range = 0; range < n_ranges; ++range) {
    SyntheticOptions so;
    so.camera = cam;
    so.target = target;
    so.n_images = 20 / n_ranges + (range < 20 % n_ranges ? 1 : 0);
    so.fill = fill_list[range];
    so.noise_px = noise_px;
    so.pose_seed = 11 + range;
    so.noise_seed = noise_seed * 3 + range;
    so.project = [&](const Eigen::Vector3d& p) -> std::optional<Eigen::Vector2d> {
      return refraction::Project<camera::BrownModel, double>(cam.sensor, cam.params.data(), shell,
                                                             port.data(), p);
    };
    auto set = MakeSyntheticSet(so);
    for (auto& d : set.detections) {
      d.image = "view" + std::to_string(k++);
      all.push_back(std::move(d));
    }
    if (poses) poses->insert(poses->end(), set.poses.begin(), set.poses.end());
  }
  return all;
}

// The same port with air outside: a calibration set taken in air with the housing on (the
// paper's protocol).
inline PortSystem InAir(const PortSystem& water) {
  return ports::Place(water.spec, water.ep_in_housing_mm, water.n_glass, 1.0);
}

// Views in air through `truth` (InAir), named air0, air1, … (other poses than Views' by the seed).
inline std::vector<ImageDetections> AirViews(const camera::Camera& cam, const PortSystem& truth,
                                             const TargetSpec& target, uint64_t noise_seed,
                                             double noise_px = 0.3) {
  auto views = Views(cam, InAir(truth), target, noise_seed, nullptr, {0.9, 0.5}, noise_px);
  for (auto& v : views) v.image = "air" + v.image.substr(4);
  return views;
}

inline RefractiveOptions Options(const PortSystem& predicted, double pitch_mm) {
  RefractiveOptions o;
  o.lens.model = camera::CameraModelId::kBrown;
  o.lens.pixel_pitch_mm = pitch_mm;
  o.port = predicted;
  if (std::getenv("PORTHOLE_TEST_VERBOSE")) {
    o.lens.progress = [t0 = std::chrono::steady_clock::now()](const std::string& m) {
      std::printf("%8.3f s %s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), m.c_str());
    };
  }
  return o;
}

// A calibration as the record a calibration file holds (its camera, free set and covariance).
inline CalibrationRecord RecordOf(const CalibrationResult& r) {
  CalibrationRecord rec;
  rec.camera = r.camera;
  rec.free = r.free;
  rec.covariance = r.covariance;
  rec.has_covariance = true;
  return rec;
}

// The in-air calibration of the lens: 20 synthetic views of the target in air, σ noise_px (0.3 px).
inline CalibrationRecord AirCalibration(const camera::Camera& cam, const TargetSpec& target,
                                        double noise_px = 0.3, uint64_t noise_seed = 22) {
  SyntheticOptions so;
  so.camera = cam;
  so.target = target;
  so.n_images = 20;
  so.noise_px = noise_px;
  so.pose_seed = 21;
  so.noise_seed = noise_seed;
  CalibrationOptions co;
  co.pixel_pitch_mm = cam.sensor.pixel_pitch_mm;
  const CalibrationResult r = Calibrate(MakeSyntheticSet(so).detections, target, co);
  CalibrationRecord rec;
  rec.camera = r.camera;
  rec.free = r.free;
  rec.covariance = r.covariance;
  rec.has_covariance = true;
  rec.sigma0_px = r.sigma0_px;
  return rec;
}

// The exact lens as an in-air calibration without σ: for --intrinsics fixed, the port alone.
inline CalibrationRecord ExactLens(const camera::Camera& cam) {
  CalibrationRecord air;
  air.camera = cam;
  air.free = DefaultFree(cam.model);
  air.covariance = Eigen::MatrixXd::Zero(cam.info().num_params, cam.info().num_params);
  return air;
}

// A predicted port off the truth, as a datasheet and a flange survey would give it.
inline PortSystem Displaced(const PortSystem& truth, const std::array<double, 3>& delta) {
  auto p = refraction::ParamsOf(truth);
  for (int i = 0; i < 3; ++i) p[i] += delta[i];
  return ports::Place(refraction::SpecWithParams(truth, p), truth.ep_in_housing_mm, truth.n_glass,
                      truth.n_water);
}

inline void Print(const char* what, const RefractiveResult& r) {
  std::printf("%s: port %.4f %.4f %.4f (sigma %.4f %.4f %.4f), sigma0 %.4f px, RMS %.4f px, "
              "chi2 %.2f (p %.3f), BIC %.1f vs central %.1f (RMS %.4f): %s, %.2f s\n",
              what, r.port[0], r.port[1], r.port[2], r.port_sigma[0], r.port_sigma[1],
              r.port_sigma[2], r.lens.sigma0_px, r.lens.rms_px, r.chi2, r.p_value, r.bic,
              r.central_bic, r.central_rms_px, r.preferred.c_str(), r.lens.seconds);
  const auto& c = r.central_prediction;
  if (c.available) {
    std::printf("  c x0 y0 predicted %.4f %.4f %.4f (%.2g %.2g %.2g), estimated %.4f %.4f %.4f "
                "(%.2g %.2g %.2g), central %.4f %.4f %.4f (%.2g %.2g %.2g): chi2 %.2f p %.3f\n",
                c.predicted[0], c.predicted[1], c.predicted[2], c.predicted_sigma[0],
                c.predicted_sigma[1], c.predicted_sigma[2], c.estimated[0], c.estimated[1],
                c.estimated[2], c.estimated_sigma[0], c.estimated_sigma[1], c.estimated_sigma[2],
                c.central[0], c.central[1], c.central[2], c.central_sigma[0], c.central_sigma[1],
                c.central_sigma[2], c.chi2, c.p_value);
  } else {
    std::printf("  c x0 y0: %s\n", c.why_not.c_str());
  }
}

}  // namespace porthole::calib::fixtures
