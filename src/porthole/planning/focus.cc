#include "porthole/planning/focus.h"

namespace porthole::planning {

ports::PortSystem SystemAtFocus(const Setup& s, double fd_mm) {
  Vec3 ep = s.ep_in_housing_mm.value_or(s.port.default_ep_in_housing_mm);
  if (!s.ep_in_housing_mm) ep.z() = s.lens.PupilToFlangeMm(fd_mm);
  return ports::MakeSystem(s.port, s.env, ep);
}

std::optional<Vec3> WaterDirection(const ports::PortSystem& sys, const Vec3& air_dir) {
  optics::Ray out;
  const optics::Ray in{sys.ep_in_housing_mm, air_dir.normalized()};
  if (optics::TraceSequence<double>(sys.Outward(), in, &out) != optics::RayStatus::kOk) return std::nullopt;
  return out.dir.normalized();
}

double PupilToOuterMm(const ports::PortSystem& sys) { return sys.OuterVertexZ() - sys.ep_in_housing_mm.z(); }

}  // namespace porthole::planning
