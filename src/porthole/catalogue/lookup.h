// Cameras and lenses by name, for every command (plan, flat, simulate, report) and Python alike:
// porthole's presets and TOML files first (LoadCamera/LoadLens), then Debian's lensfun
// database (liblensfun-data-v1, through its C API), which knows crop factors, mounts, focal lengths
// and f-number ranges but neither pixel pitch nor minimum focus nor the entrance pupil. What lensfun
// lacks is given (LensData) or else assumed and flagged (LensSpec::min_focus_assumed,
// pupil_estimated, the description), and planning says so where its advice depends on it. lensfun's recorded lens type gives the projection
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

namespace porthole::catalogue {

// Names match exactly, never loosely: a TOML file (a path), else a preset id, else a lensfun
// camera's maker + model (any of its spellings: "Sony ILCE-7M4" or "Sony Alpha 7 IV"), compared
// without case, spaces, hyphens and underscores ("NIKON D850", "nikon-d850" and "Nikon_D850" are
// one name). Anything else is refused with InvalidInput naming the three closest names across
// presets and lensfun ("did you mean ..."). The result's `lookup` says which source answered.
//
// A preset or file body given another `pixel_pitch_mm` keeps its sensor size (mm) with other pixels
// (WithPixelPitch). A lensfun body needs `pixel_pitch_mm`: its sensor is 43.27 mm / crop factor across the
// diagonal, 4:3 on Micro Four Thirds and 3:2 elsewhere. Throws InvalidInput("camera") when
// nothing matches, the mount is not one porthole knows, or the pitch is missing
// (InvalidInput("pixel_pitch_mm")).
lens::CameraBody FindCamera(const std::string& name, std::optional<double> pixel_pitch_mm = std::nullopt);

// The body's sensor (its size in mm) divided into pixels of `pitch_mm`. Throws
// InvalidInput("pixel_pitch_mm") for a pitch that is not > 0 or gives a million pixels a side.
lens::CameraBody WithPixelPitch(lens::CameraBody body, double pitch_mm);

// What the user knows of a lens that its data lacks (lensfun records neither): the CLI's
// --min-focus-mm and --pupil-mm, Python's min_focus_mm= and pupil_mm=.
struct LensData {
  std::optional<double> min_focus_mm;  // closest focus-scale distance FD (sensor to subject), mm
  // The entrance pupil's distance ahead of the sensor plane at infinity focus, mm, with the lens on
  // its own mount (an adapter, --allow-adapter, adds its length). D_EP2F(inf) = pupil_mm − FFD.
  std::optional<double> pupil_mm;
};

// `lens` with the given data: the minimum focus replaced (InvalidInput("min_focus_mm") unless
// finite and > 2 f) and no longer assumed; the pupil table shifted so that the pupil sits
// pupil_mm ahead of the sensor at infinity (its movement with focus kept; InvalidInput("pupil_mm")
// unless > 0) and no longer estimated.
lens::LensSpec WithLensData(lens::LensSpec lens, const LensData& given);

// A file, a preset id or a lensfun lens's maker + model, matched exactly as FindCamera does (a
// lens calibrated on several bodies appears in lensfun once per crop factor: the smallest stands
// for it). A zoom needs `focal_mm` within its range. What lensfun lacks is the given LensData,
// else assumed (docs/planning.md) and flagged (min_focus_assumed, pupil_estimated): minimum focus
// 10 f; the entrance pupil 68.1 mm / crop factor ahead of the sensor at infinity focus (the mean of
// the paper's two measured Nikkors, Table 2). The pupil moves forward with focus by the thin-lens
// extension f² / (FD − 2f). Throws InvalidInput("lens"), InvalidInput("focal_length_mm") for a zoom
// without or outside its range.
lens::LensSpec FindLens(const std::string& name, std::optional<double> focal_mm = std::nullopt,
                        const LensData& given = {});

// What a command asks for: a camera and a lens by name or file. An empty lens takes the camera's
// own (a fixed-lens camera), or default_lens on an interchangeable-lens body; allow_adapter lets a
// lens for a longer flange sit on an adapter.
struct CameraLensQuery {
  std::string camera = "nikon-d300";
  std::string lens;
  std::string default_lens = "nikkor-24mm-f2.8d";  // the paper's lens
  std::optional<double> pixel_pitch_mm, focal_length_mm;
  LensData lens_data;  // applied to the named lens, the default lens or a fixed lens alike
  bool allow_adapter = false;
};
struct CameraAndLens {
  lens::CameraBody camera;
  lens::LensSpec lens;  // as mounted on the camera (lens::MountOn)
};
// Finds both and mounts the lens on the body. A fixed-lens camera takes no other lens: `lens`
// empty or its own lens's name.
CameraAndLens FindCameraAndLens(const CameraLensQuery& query);

// Where a camera or lens was found, for the text of every command: "porthole preset", "file",
// "lensfun database", "built in" when not looked up.
std::string FoundIn(const std::string& lookup);
// Two lines (each ending in '\n') naming the camera and the lens, where each was found and what of
// the lens is assumed: "camera  Sony Alpha 7 IV (lensfun database)\nlens    Sony FE 16-35mm f/4 ZA OSS
// (lensfun database; minimum focus assumed: 160 mm; entrance pupil assumed)\n".
std::string DescribeCameraAndLens(const lens::CameraBody& camera, const lens::LensSpec& lens);

// The porthole projection of a lensfun lens type (LF_* value); nullopt for the types porthole
// cannot plan (panoramic, equirectangular). `estimated` is set when the mapping is approximate.
std::optional<camera::Projection> ProjectionFromLensfunType(int lf_type, bool* estimated);

// The porthole mount name of a lensfun mount ("Nikon F AF" → "nikon-f"); nullopt if unknown.
std::optional<std::string> MountFromLensfun(const std::string& lensfun_mount);

}  // namespace porthole::catalogue
