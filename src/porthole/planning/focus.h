// The pieces planning shares between `plan` and `flat`: the housed camera (housing/housed.h) and
// its one focus solver, and chief rays traced out of the housing. Frames and units as in plan.h
// (housing frame, mm; infinity is std::numeric_limits<double>::infinity()).
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "porthole/housing/housed.h"
#include "porthole/lens/lens.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/virtual_image.h"

namespace porthole::planning {

using ports::Vec3;

// The system being planned: camera body, lens, port, water, pupil (housing::HousedCamera).
using Setup = housing::HousedCamera;

using housing::PupilToOuterMm;
using housing::SystemAtFocus;

struct Solved {
  ports::PortSystem sys;
  double d_s2ep_mm = 0;            // where the lens focuses, from the pupil
  std::optional<double> fd_mm;     // FD to set (Eq. 2); nullopt: closer than the lens goes
};

// housing::SolveFocus in planning's shape (`mount` is the body's, kept for the callers' sake).
template <typename F>
Solved SolveFocus(const Setup& s, const lens::Mount& /*mount*/, F required) {
  const housing::Focused f = housing::SolveFocus(s, required);
  return {f.sys, f.focus.d_s2ep_mm, f.focus.focus_distance_mm};
}

// Direction in the water of the ray that leaves the entrance pupil centre along `air_dir`;
// nullopt when it cannot pass the port (misses, leaves the glass, total internal reflection).
std::optional<Vec3> WaterDirection(const ports::PortSystem& sys, const Vec3& air_dir);

}  // namespace porthole::planning
