// The value part of a scalar of the templated camera and optics maths: itself for double, the
// (recursive) real part for a ceres::Jet. Used where a branch or an iteration must look at the
// value only (the derivative then comes from one final step in the Jet type).
#pragma once

#include <ceres/jet.h>

namespace porthole::camera {

inline double ScalarValue(double v) { return v; }
template <typename S, int N>
double ScalarValue(const ceres::Jet<S, N>& v) {
  return ScalarValue(v.a);
}

}  // namespace porthole::camera
