// --camera, --lens, --pixel-pitch-mm (alias --pixel-pitch), --focal: the camera and lens options of `plan` and `flat`
// (presets, TOML files, or names in Debian's lensfun database).
#pragma once

#include <optional>
#include <string>

#include "common.h"
#include "porthole/planning/focus.h"
#include "porthole/planning/lensfun.h"

namespace porthole::cli {

// The camera and lens options shared by `plan` and `flat`.
struct CameraLensOptions {
  std::string camera = "nikon-d300";
  std::string lens = "nikkor-24mm-f2.8d";
  std::optional<double> pixel_pitch_mm, focal_mm;

  void Add(CLI::App* cmd) {
    cmd->add_option("--camera", camera, "Camera: a preset, a TOML file, or a name in Debian's lensfun database")
        ->capture_default_str()->group("Camera");
    cmd->add_option("--lens", lens, "Lens: a preset, a TOML file, or a name in Debian's lensfun database")
        ->capture_default_str()->group("Camera");
    cmd->add_option("--pixel-pitch-mm,--pixel-pitch", pixel_pitch_mm, "Pixel pitch, mm (needed for a lensfun camera)")
        ->group("Camera");
    cmd->add_option("--focal", focal_mm, "Focal length, mm (needed for a lensfun zoom)")->group("Camera");
  }
  planning::Setup ToSetup(const PortOptions& port, const WaterOptions& water) const {
    planning::Setup s;
    s.camera = planning::FindCamera(camera, pixel_pitch_mm);
    // A preset or file body with another pitch: the same sensor (its size in mm), other pixels.
    if (pixel_pitch_mm && *pixel_pitch_mm != s.camera.sensor.pixel_pitch_mm) {
      s.camera = WithPixelPitch(s.camera, *pixel_pitch_mm);
    }
    s.lens = planning::FindLens(lens, focal_mm);
    WarnIfImplausible(pixel_pitch_mm ? "--pixel-pitch-mm" : camera + ": pixel_pitch_mm", s.camera.sensor.pixel_pitch_mm,
                      kPixelPitchRange);
    WarnIfImplausible(focal_mm ? "--focal" : lens + ": focal_length_mm", s.lens.focal_length_mm, kFocalLengthRange);
    s.port = port.Spec();
    s.env = water.ToEnvironment();
    s.ep_in_housing_mm = port.Ep();
    return s;
  }
};

}  // namespace porthole::cli
