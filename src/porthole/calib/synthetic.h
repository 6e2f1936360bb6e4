// Synthetic calibration sets with known truth: a camera, views of a planar target from known
// poses, projected with camera::Project (the model the calibration adjusts) plus Gaussian pixel
// noise. Used by the solver tests, the benchmark and the Python tests.
#pragma once

#include <cstdint>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"
#include "porthole/camera/brown.h"
#include "porthole/camera/sensor.h"

namespace porthole::calib {

struct SyntheticOptions {
  camera::BrownParams camera;  // truth
  camera::Sensor sensor;
  TargetSpec target;
  int n_images = 15;
  // Largest tilt of the target normal from the optical axis, deg: 40° gives the convergent views
  // that decorrelate c from the distances.
  double max_tilt_deg = 40;
  // The target's extent covers about this fraction of the image width.
  double fill = 0.7;
  double noise_px = 0.3;  // σ of the Gaussian noise per coordinate
  uint64_t pose_seed = 1;   // the views
  uint64_t noise_seed = 2;  // the noise (change it alone for Monte-Carlo runs)
};

struct SyntheticSet {
  std::vector<ImageDetections> detections;  // points that fall inside the frame
  std::vector<ImageResult> poses;           // the true cam_from_target poses
};

SyntheticSet MakeSyntheticSet(const SyntheticOptions& options);

}  // namespace porthole::calib
