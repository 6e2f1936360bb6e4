// --camera, --lens, --pixel-pitch-mm (alias --pixel-pitch), --focal, --min-focus-mm, --pupil-mm,
// --allow-adapter: the camera and lens options of every command that takes a housed camera (plan,
// flat, simulate, report, render):
// presets, TOML files, or names in Debian's lensfun database (io/lookup.h), and the library fields
// they stand for.
#pragma once

#include <optional>
#include <string>

#include "common.h"
#include "porthole/core/field_names.h"
#include "porthole/housing/housed.h"
#include "porthole/catalogue/lookup.h"

namespace porthole::cli {

// The library's field names for the camera, lens and port options, as this CLI's flags.
#define PORTHOLE_CAMERA_FLAGS                                                                       \
  {"camera", "--camera"}, {"lens", "--lens"}, {"pixel_pitch_mm", "--pixel-pitch-mm"},                \
      {"focal_length_mm", "--focal"}, {"ep_offset_mm", "--ep-offset"}, {"ep_in_housing_mm", "--ep"}, \
      {"port", "--port"}, {"min_focus_mm", "--min-focus-mm"}, {"pupil_mm", "--pupil-mm"}

struct CameraLensOptions {
  catalogue::CameraLensQuery query;

  void Add(CLI::App* cmd) {
    cmd->add_option("--camera", query.camera,
                    "Camera: a preset, a TOML file, or a name in Debian's lensfun database (a fixed-lens "
                    "camera brings its own lens)")
        ->capture_default_str()->group("Camera");
    cmd->add_option("--lens", query.lens,
                    "Lens: a preset, a TOML file, or a name in Debian's lensfun database (default: " +
                        query.default_lens + ", or the camera's own fixed lens)")
        ->group("Camera");
    cmd->add_option("--pixel-pitch-mm,--pixel-pitch", query.pixel_pitch_mm,
                    "Pixel pitch, mm (needed for a lensfun camera)")
        ->group("Camera");
    cmd->add_option("--focal", query.focal_length_mm, "Focal length, mm (needed for a lensfun zoom)")->group("Camera");
    cmd->add_option("--min-focus-mm", query.lens_data.min_focus_mm,
                    "The lens's minimum focus distance, mm, sensor to subject, as published (lensfun records none: "
                    "without it 10 x the focal length is assumed)")
        ->group("Camera");
    cmd->add_option("--pupil-mm", query.lens_data.pupil_mm,
                    "The entrance pupil's distance ahead of the sensor plane at infinity focus, mm, the lens on "
                    "its own mount (lensfun records none: without it 68.1 mm / crop factor is assumed)")
        ->group("Camera");
    cmd->add_flag("--allow-adapter", query.allow_adapter,
                  "Let a lens for a longer flange sit on an adapter (its pupil moves forward by the adapter)")
        ->group("Camera");
  }
  housing::HousedCamera ToHoused(const PortOptions& port, const WaterOptions& water) const {
    const catalogue::CameraAndLens cl = catalogue::FindCameraAndLens(query);
    housing::HousedCamera s;
    s.camera = cl.camera;
    const auto& pitch = query.pixel_pitch_mm;  // a preset body's other pitch: catalogue::FindCamera
    s.lens = cl.lens;
    WarnIfImplausible(pitch ? "--pixel-pitch-mm" : query.camera + ": pixel_pitch_mm", s.camera.sensor.pixel_pitch_mm,
                      kPixelPitchRange);
    WarnIfImplausible(query.focal_length_mm ? "--focal" : s.lens.name + ": focal_length_mm", s.lens.focal_length_mm,
                      kFocalLengthRange);
    s.port = port.Spec();
    s.env = water.ToEnvironment();
    s.ep_in_housing_mm = port.Ep();
    return s;
  }
};

}  // namespace porthole::cli
