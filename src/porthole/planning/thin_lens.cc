#include "porthole/planning/thin_lens.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace porthole::planning {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

DofLimits ThinLensDof(double s, double f, double n, double c) {
  const double f2 = f * f, k = n * c;
  if (std::isinf(s)) return {f2 / k, kInf};
  const double far_den = f2 - k * (s - f);
  return {s * f2 / (f2 + k * (s - f)), far_den <= 0 ? kInf : s * f2 / far_den};
}

double FocusForFarLimitMm(double d, double f, double n, double c) {
  const double f2 = f * f, k = n * c;
  if (std::isinf(d)) return f + f2 / k;
  return d * (f2 + k * f) / (f2 + k * d);
}

double BlurDiameterMm(double s, double d, double f, double n) {
  const double f2 = f * f;
  if (std::isinf(s) && std::isinf(d)) return 0;
  if (std::isinf(s)) return f2 / (n * d);            // limit s → ∞ of the general form
  if (std::isinf(d)) return f2 / (n * (s - f));      // limit d → ∞
  return f2 * std::abs(s - d) / (n * d * (s - f));
}

double ApparentDistanceWithCloseupMm(double d, double p) {
  const double v = (std::isinf(d) ? 0.0 : 1.0 / d) - p / 1000.0;
  if (v < 0) return std::nan("");
  return v == 0 ? kInf : 1.0 / v;
}

double CloseupDioptreNeeded(double d, double d_min) {
  if (std::isinf(d)) return 0;
  return std::max(0.0, 1000.0 / d - 1000.0 / d_min);
}

}  // namespace porthole::planning
