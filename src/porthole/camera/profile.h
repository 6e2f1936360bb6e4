// The distortion curves the paper plots (docs/conventions.md, last paragraph), from Brown
// parameters: radial profile δr(r) = K1 r³ + K2 r⁵ + K3 r⁷ and decentring profile
// P(r) = sqrt(P1² + P2²) r², both in mm for a radial distance r in image mm from the principal point.
// Positive δr is barrel (the correction moves points outward).
#pragma once

#include <cmath>

#include "porthole/camera/brown.h"

namespace porthole::camera {

inline double RadialProfileMm(const BrownParams& p, double r_mm) {
  const double r2 = r_mm * r_mm;
  return r_mm * r2 * (p.K1 + r2 * (p.K2 + r2 * p.K3));
}

inline double DecentringProfileMm(const BrownParams& p, double r_mm) {
  return std::hypot(p.P1, p.P2) * r_mm * r_mm;
}

}  // namespace porthole::camera
