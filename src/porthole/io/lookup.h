// Cameras and lenses by name, for every command (plan, flat, simulate, report) and Python alike:
// porthole's presets and TOML files first (LoadCamera/LoadLens), then Debian's lensfun
// database (liblensfun-data-v1, through its C API), which knows crop factors, mounts, focal lengths and f-number ranges but neither pixel pitch nor minimum focus nor the
// entrance pupil. What lensfun lacks is estimated and flagged (LensSpec::pupil_estimated, the
// description), and planning warns about it. lensfun's recorded lens type gives the projection
// (rectilinear; fisheye = equidistant, fisheye_equisolid, fisheye_stereographic,
// fisheye_orthographic; Thoby's fisheye is taken as equisolid and flagged as an estimate;
// panoramic and equirectangular lenses are refused).
//
// Errors name the library field ("camera", "lens", "pixel_pitch_mm", "focal_length_mm"); the CLI
// and Python map them to their own flags and keywords.
#pragma once

#include <optional>
#include <string>

#include "porthole/lens/lens.h"

namespace porthole::io {

// A preset/file name, else the best lensfun match for `name` (maker and model, loose search).
// A preset or file body given another `pixel_pitch_mm` keeps its sensor size (mm) with other pixels
// (WithPixelPitch). A lensfun body needs `pixel_pitch_mm`: its sensor is 43.27 mm / crop factor across the
// diagonal, 4:3 on Micro Four Thirds and 3:2 elsewhere. Throws InvalidInput("camera") when
// nothing matches, the mount is not one porthole knows, or the pitch is missing
// (InvalidInput("pixel_pitch_mm")).
lens::CameraBody FindCamera(const std::string& name, std::optional<double> pixel_pitch_mm = std::nullopt);

// The body's sensor (its size in mm) divided into pixels of `pitch_mm`. Throws
// InvalidInput("pixel_pitch_mm") for a pitch that is not > 0 or gives a million pixels a side.
lens::CameraBody WithPixelPitch(lens::CameraBody body, double pitch_mm);

// A preset/file name, else the best lensfun match. A zoom needs `focal_mm` within its range.
// Estimated (docs/planning.md): minimum focus 10 f; the entrance pupil 68.1 mm / crop factor ahead
// of the sensor at infinity focus (the mean of the paper's two measured Nikkors, Table 2), moving
// forward with focus by the thin-lens extension f² / (FD − 2f). Throws InvalidInput("lens"),
// InvalidInput("focal_length_mm") for a zoom without or outside its range.
lens::LensSpec FindLens(const std::string& name, std::optional<double> focal_mm = std::nullopt);

// What a command asks for: a camera and a lens by name or file. An empty lens takes the camera's
// own (a fixed-lens camera), or default_lens on an interchangeable-lens body; allow_adapter lets a
// lens for a longer flange sit on an adapter.
struct CameraLensQuery {
  std::string camera = "nikon-d300";
  std::string lens;
  std::string default_lens = "nikkor-24mm-f2.8d";  // the paper's lens
  std::optional<double> pixel_pitch_mm, focal_length_mm;
  bool allow_adapter = false;
};
struct CameraAndLens {
  lens::CameraBody camera;
  lens::LensSpec lens;  // as mounted on the camera (lens::MountOn)
};
// Finds both and mounts the lens on the body. A fixed-lens camera takes no other lens: `lens`
// empty or its own lens's name.
CameraAndLens FindCameraAndLens(const CameraLensQuery& query);

// The porthole projection of a lensfun lens type (LF_* value); nullopt for the types porthole
// cannot plan (panoramic, equirectangular). `estimated` is set when the mapping is approximate.
std::optional<camera::Projection> ProjectionFromLensfunType(int lf_type, bool* estimated);

// The porthole mount name of a lensfun mount ("Nikon F AF" → "nikon-f"); nullopt if unknown.
std::optional<std::string> MountFromLensfun(const std::string& lensfun_mount);

}  // namespace porthole::io
