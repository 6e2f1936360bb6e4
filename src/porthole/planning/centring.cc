#include "porthole/planning/centring.h"

#include <cmath>

#include "porthole/core/error.h"

namespace porthole::planning {
namespace {

// The port moved by dz along +Z (its frame's z: the housing's or, for a cam-frame port, the pupil's).
ports::PortSpec Moved(ports::PortSpec spec, double dz) {
  auto& d = std::get<ports::DomePort>(spec.shape);
  d.outer.center_mm.z() += dz;
  d.inner.center_mm.z() += dz;
  if (d.rim_z_mm) *d.rim_z_mm += dz;
  return spec;
}

}  // namespace

std::optional<PupilCentring> CentrePupil(const Setup& setup, const lens::Mount& mount,
                                         const std::function<double(const ports::PortSystem&)>& required) {
  if (!setup.port.IsDome()) return std::nullopt;
  auto offsets = [](const ports::PortSystem& sys) {
    const Vec3 d = sys.ep_in_housing_mm - sys.dome().outer.center_mm;
    return std::pair{d.z(), d.head<2>().norm()};
  };
  const Solved now = SolveFocus(setup, mount, required);
  PupilCentring c;
  std::tie(c.axial_offset_mm, c.lateral_offset_mm) = offsets(now.sys);
  c.focus_distance_mm = now.fd_mm;
  c.extension_mm = c.axial_offset_mm;
  Setup moved = setup;
  try {
    for (int it = 0; it < 50; ++it) {
      moved.port = Moved(setup.port, c.extension_mm);
      const Solved after = SolveFocus(moved, mount, required);
      c.residual_mm = offsets(after.sys).first;
      c.focus_distance_after_mm = after.fd_mm;
      if (std::abs(c.residual_mm) < 1e-9) break;
      c.extension_mm += c.residual_mm;  // contracts: the pupil moves far less than the port
    }
  } catch (const InvalidInput&) {
    c.extension_mm = c.axial_offset_mm;
    c.residual_mm = std::nan("");
    c.focus_distance_after_mm.reset();
  }
  return c;
}

}  // namespace porthole::planning
