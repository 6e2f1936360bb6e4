// Test fixture shared by the refraction and refractive-calibration tests (header only, tests only):
// the camera the paper's Table 6 describes, as a Brown camera of the list.
#pragma once

#include "porthole/camera/camera.h"

namespace porthole::refraction::testing {

// A Nikon D300 (4288 × 2848 px, 5.5 µm) with a 24 mm lens: Brown model, barrel distortion and a
// little decentring, principal point slightly off centre.
inline camera::Camera D300Brown() {
  camera::BrownParams b;
  b.c_mm = 24.6;
  b.x0_mm = 0.05;
  b.y0_mm = -0.03;
  b.K1 = 1.8e-4;
  b.K2 = -3e-7;
  b.P1 = 2e-6;
  b.P2 = -1e-6;
  return camera::FromBrown(b, camera::Sensor{4288, 2848, 0.0055});
}

}  // namespace porthole::refraction::testing
