// The pieces planning shares between `plan` and `flat`: the port placed for a focus setting, focus
// and pupil solved together, and chief rays traced out of the housing. Frames and units as in
// plan.h (housing frame, mm; infinity is std::numeric_limits<double>::infinity()).
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "porthole/lens/lens.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/virtual_image.h"

namespace porthole::planning {

using ports::Vec3;

// The system being planned.
struct Setup {
  lens::CameraBody camera;
  lens::LensSpec lens;
  ports::PortSpec port;
  ports::Environment env;
  // Fixes the entrance pupil (housing frame) whatever the focus; unset: (x, y) of the port's
  // default pupil and z = D_EP2F(FD) from the lens.
  std::optional<Vec3> ep_in_housing_mm;
};

// The port in front of the pupil for focus-scale distance fd_mm (may be infinite).
ports::PortSystem SystemAtFocus(const Setup& s, double fd_mm);

struct Solved {
  ports::PortSystem sys;
  double d_s2ep_mm = 0;            // where the lens focuses, from the pupil
  std::optional<double> fd_mm;     // FD to set (Eq. 2); nullopt: closer than the lens goes
};

// Focus and pupil solved together: the pupil position depends on FD, the distance the lens must
// focus at (`required(sys)`) on the pupil position. Fixed-point iteration (the pupil moves a few
// mm while FD moves by hundreds, so it contracts fast); a focus closer than the lens goes leaves
// the pupil at the minimum focus. One pass when the pupil is fixed.
template <typename F>
Solved SolveFocus(const Setup& s, const lens::Mount& mount, F required) {
  double fd_used = std::numeric_limits<double>::infinity();
  Solved out{SystemAtFocus(s, fd_used), 0, std::nullopt};
  for (int it = 0; it < 100; ++it) {
    out.d_s2ep_mm = required(out.sys);
    out.fd_mm = lens::FocusForSubjectMm(s.lens, mount, out.d_s2ep_mm);
    const double next = out.fd_mm.value_or(s.lens.min_focus_mm);
    const double moved = std::abs(s.lens.PupilToFlangeMm(next) - s.lens.PupilToFlangeMm(fd_used));
    fd_used = next;
    out.sys = SystemAtFocus(s, fd_used);
    if (moved < 1e-10 || s.ep_in_housing_mm) break;
  }
  out.d_s2ep_mm = required(out.sys);
  out.fd_mm = lens::FocusForSubjectMm(s.lens, mount, out.d_s2ep_mm);
  return out;
}

// Direction in the water of the ray that leaves the entrance pupil centre along `air_dir`;
// nullopt when it cannot pass the port (misses, leaves the glass, total internal reflection).
std::optional<Vec3> WaterDirection(const ports::PortSystem& sys, const Vec3& air_dir);

// Distance from the entrance pupil to the port's outer vertex, along the axis.
double PupilToOuterMm(const ports::PortSystem& sys);

}  // namespace porthole::planning
