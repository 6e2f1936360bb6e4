// Cameras and lenses by name: porthole's presets and TOML files first (io::LoadCamera/LoadLens),
// then Debian's lensfun database (liblensfun-data-v1, through its C API), which knows crop factors,
// mounts, focal lengths and f-number ranges but neither pixel pitch nor minimum focus nor the
// entrance pupil. What lensfun lacks is estimated and flagged (LensSpec::pupil_estimated, the
// description), and planning warns about it.
#pragma once

#include <optional>
#include <string>

#include "porthole/lens/lens.h"

namespace porthole::planning {

// A preset/file name, else the best lensfun match for `name` (maker and model, loose search).
// A lensfun body needs `pixel_pitch_mm`: its sensor is 43.27 mm / crop factor across the
// diagonal, 4:3 on Micro Four Thirds and 3:2 elsewhere. Throws InvalidInput("--camera") when
// nothing matches, the mount is not one porthole knows, or the pitch is missing.
lens::CameraBody FindCamera(const std::string& name, std::optional<double> pixel_pitch_mm = std::nullopt);

// A preset/file name, else the best lensfun match. A zoom needs `focal_mm` within its range.
// Estimated (docs/planning.md): minimum focus 10 f; the entrance pupil 68.1 mm / crop factor ahead
// of the sensor at infinity focus (the mean of the paper's two measured Nikkors, Table 2), moving
// forward with focus by the thin-lens extension f² / (FD − 2f). Throws InvalidInput("--lens").
lens::LensSpec FindLens(const std::string& name, std::optional<double> focal_mm = std::nullopt);

// The porthole mount name of a lensfun mount ("Nikon F AF" → "nikon-f"); nullopt if unknown.
std::optional<std::string> MountFromLensfun(const std::string& lensfun_mount);

}  // namespace porthole::planning
