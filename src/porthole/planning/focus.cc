#include "porthole/planning/focus.h"

namespace porthole::planning {

std::optional<Vec3> WaterDirection(const ports::PortSystem& sys, const Vec3& air_dir) {
  optics::Ray out;
  const optics::Ray in{sys.ep_in_housing_mm, air_dir.normalized()};
  if (optics::TraceSequence<double>(sys.Outward(), in, &out) != optics::RayStatus::kOk) return std::nullopt;
  return out.dir.normalized();
}

}  // namespace porthole::planning
