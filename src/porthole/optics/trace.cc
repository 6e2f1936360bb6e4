#include "porthole/optics/trace.h"

namespace porthole::optics {

std::string_view ToString(RayStatus s) {
  switch (s) {
    case RayStatus::kOk: return "ok";
    case RayStatus::kMissed: return "missed";
    case RayStatus::kOutsideAperture: return "outside_aperture";
    case RayStatus::kTotalInternalReflection: return "total_internal_reflection";
  }
  return "unknown";
}

std::vector<Interface> Reversed(const std::vector<Interface>& seq) {
  std::vector<Interface> r(seq.rbegin(), seq.rend());
  for (Interface& f : r) std::swap(f.n_before, f.n_after);
  return r;
}

}  // namespace porthole::optics
