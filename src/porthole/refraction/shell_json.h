// A port's shell (refraction.h) as JSON and back: the `shell` block calibrate writes beside each
// port estimate and that measure/ reads from a rig file. The keys are the shell's fields (mm, cam
// frame); which keys a shape has is its kShellJsonKeys (ports/port.h).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "porthole/refraction/refraction.h"

namespace porthole::refraction {

// The shell's keys: "frame", "n_glass", "n_water" and the shape's (dome: outer_radius_mm,
// inner_radius_mm, inner_from_outer_mm, rim_from_outer_z_mm; flat: thickness_mm; cylinder:
// outer_radius_mm, inner_radius_mm, rim_from_axis_z_mm).
nlohmann::ordered_json ShellToJson(const Shell& s);

// The shell of a port of kind `kind` ("dome", "flat", "cylinder") from such a block; throws
// InvalidInput naming `field`.<key> where a key is missing or not a finite number, and `field` where
// the values are no shell (ValidateShellValues: an inner sphere or cylinder not inside the outer
// one, a thickness <= 0; an index < 1).
Shell ShellFromJson(const std::string& kind, const nlohmann::json& shell, const std::string& field);

}  // namespace porthole::refraction
