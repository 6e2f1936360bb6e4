// Synthetic calibration sets with known truth: a camera of any model of the list, views of a
// planar target from known poses, projected with the model's Project (what the calibration
// adjusts) plus Gaussian pixel noise. Used by the solver tests, the benchmark and the Python tests.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"
#include "porthole/camera/brown.h"
#include "porthole/camera/sensor.h"

namespace porthole::calib {

struct SyntheticOptions {
  camera::Camera camera;  // truth (model, sensor, parameters)
  TargetSpec target;
  int n_images = 15;
  // Largest tilt of the target normal from the optical axis, deg: 40° gives the convergent views
  // that decorrelate c from the distances.
  double max_tilt_deg = 40;
  // The target's extent covers about this fraction of the image width.
  double fill = 0.7;
  // Largest angle (deg) between the optical axis and the direction to the target centre: 0 keeps
  // the target centred; a fisheye calibration needs views that put it far off axis.
  double max_off_axis_deg = 0;
  double noise_px = 0.3;  // σ of the Gaussian noise per coordinate
  uint64_t pose_seed = 1;   // the views
  uint64_t noise_seed = 2;  // the noise (change it alone for Monte-Carlo runs)
  // The projection of a point in the camera frame (mm) to a pixel; unset: camera.Project. A
  // refractive calibration's tests project through a port here (refraction::Project).
  std::function<std::optional<Eigen::Vector2d>(const Eigen::Vector3d&)> project;
};

struct SyntheticSet {
  std::vector<ImageDetections> detections;  // points that fall inside the frame
  std::vector<ImageResult> poses;           // the true cam_from_target poses
};

SyntheticSet MakeSyntheticSet(const SyntheticOptions& options);

}  // namespace porthole::calib
