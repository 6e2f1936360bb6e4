// The advice a photographer asks for behind a dome (the paper's Sections 2.3 and 6): how far the
// lens's entrance pupil is from the dome's centre, and which extension ring would put it there.
//
// Frames and units as in plan.h (housing frame, mm, +Z toward the scene). The dome's centre is its
// outer sphere's (the paper's Table 4 measures the pupil against it). An extension ring between
// the housing and the port moves the port along +Z by its length; the pupil stays with the lens,
// but the focus on the virtual image changes with the port's position and the pupil moves with the
// focus, so the length is solved as a fixed point.
#pragma once

#include <functional>
#include <optional>

#include "porthole/planning/focus.h"

namespace porthole::planning {

struct PupilCentring {
  // Now (at the focus `required` gives): the pupil ahead (+, toward the glass) of the centre along
  // +Z, and its distance from the line through the centre parallel to +Z (a ring cannot change it).
  double axial_offset_mm = 0;
  double lateral_offset_mm = 0;
  std::optional<double> focus_distance_mm;  // FD now
  // The length by which to move the port forward (+: add a ring this long; −: shorten the
  // extension by that much) so that the pupil lies at the centre once refocused.
  double extension_mm = 0;
  std::optional<double> focus_distance_after_mm;  // FD with the ring
  double residual_mm = 0;  // axial offset left after the ring (the fixed point's accuracy)
};

// nullopt for a flat port. `required(sys)` is the distance from the pupil at which the lens must
// focus for the port placed as `sys` (as in SolveFocus). When the moved port cannot hold the pupil
// (Place throws), the extension is the first-order one and residual_mm is NaN.
std::optional<PupilCentring> CentrePupil(const Setup& setup, const lens::Mount& mount,
                                         const std::function<double(const ports::PortSystem&)>& required);

}  // namespace porthole::planning
