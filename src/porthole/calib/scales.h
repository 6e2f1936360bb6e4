// Scales of the camera parameters inside the adjustments (camera[i] = scale[i]·scaled[i],
// residual.h): every parameter gets a comparable effect at the image corner, so that the Jacobian's
// columns are comparable and the covariance is not numerically singular. Shared by the central
// calibration (calibrate.cc) and the refractive one (refractive.cc).
#pragma once

#include <array>
#include <cmath>

#include "porthole/camera/models.h"

namespace porthole::calib {

// Scales of the camera parameters in the adjustment (camera[i] = scale[i]·scaled[i], residual.h):
// every parameter gets a comparable effect at the image corner (K_n by R^-2n, P by R^-1, for R
// the half-diagonal in mm). Without them the Jacobian columns of c and K2 differ by ~R⁵ and the
// covariance is numerically singular in pixel units.
inline std::array<double, camera::kBrownNumParams> ParameterScales(const camera::Sensor& s) {
  const double r = 0.5 * std::hypot(s.width_px, s.height_px) * s.pixel_pitch_mm;
  return {r, r, r, std::pow(r, -2), std::pow(r, -4), std::pow(r, -6), 1 / r, 1 / r, 1, 1};
}

// Scales of the parameters of a pixel model: px parameters by the half-diagonal in px, the
// dimensionless distortion coefficients (on normalised radii or angles of order 1) by 1.
template <typename M>
std::array<double, M::kNumParams> ModelScales(const camera::Sensor& s) {
  if constexpr (M::kId == camera::CameraModelId::kBrown) {
    return ParameterScales(s);
  } else {
    std::array<double, M::kNumParams> scale;
    const double r = 0.5 * std::hypot(s.width_px, s.height_px);
    for (int i = 0; i < M::kNumParams; ++i) scale[i] = M::kParams[i].unit == "px" ? r : 1.0;
    return scale;
  }
}

}  // namespace porthole::calib
