// The camera of a command that applies a calibration to it (simulate, report, render
// --camera-model): a lensfun body without a pixel pitch takes the calibration's (issue 23: no
// --pixel-pitch-mm asked for when the calibration holds it), and the calibration is checked against
// the body and lens before anything converts it (simulate::CheckAirCalibration, camera/validate.h).
#pragma once

#include <fmt/format.h>

#include <string>

#include "camera_options.h"
#include "porthole/interop/interop.h"
#include "porthole/simulate/simulate.h"

namespace porthole::cli {

// `calibration`: a file path, or "" / inline JSON text (no pitch to take).
inline housing::HousedCamera HousedWithCalibrationPitch(const CameraLensOptions& camera, const PortOptions& port,
                                                        const WaterOptions& water, const std::string& calibration,
                                                        const std::string& calibration_flag) {
  try {
    return camera.ToHoused(port, water);
  } catch (const InvalidInput& e) {
    const auto first = calibration.find_first_not_of(" \t\r\n");
    if (e.field() != "pixel_pitch_mm" || camera.query.pixel_pitch_mm || first == std::string::npos ||
        calibration[first] == '{') {
      throw;
    }
    std::optional<double> pitch;
    try {
      pitch = interop::StatedPixelPitchMm(calibration, calibration_flag);
    } catch (const InvalidInput&) {
      throw e;  // the calibration's own errors come when it is read
    }
    if (!pitch) throw;
    CameraLensOptions with = camera;
    with.query.pixel_pitch_mm = *pitch;
    fmt::print(stderr, "porthole: pixel pitch {:g} mm from {} {}\n", *pitch, calibration_flag, calibration);
    return with.ToHoused(port, water);
  }
}

// The calibration file `path` (any format, docs/interop.md) checked against the housed camera, then
// converted to `model` (a refit where the families differ, reported by interop::DescribeRead).
inline interop::ReadResult ReadCalibrationFor(const std::string& path, const housing::HousedCamera& h,
                                              camera::CameraModelId model, const std::string& flag) {
  interop::ReadResult r = interop::ReadCalibrationFile(path, h.camera.sensor.pixel_pitch_mm, flag);
  const std::string where = flag + " '" + path + "'";
  simulate::CheckAirCalibration(r.camera(), r.pitch_known, h, where);
  const std::string label = r.calibration.label;
  r = interop::ConvertRead(std::move(r), model, where);
  r.calibration.label = label;
  return r;
}

}  // namespace porthole::cli
