// The one validation of a calibration, whatever file it came from (docs/robustness.md,
// "Calibrations"), and the check that a calibration is one of the camera it is applied to.
//
// ValidateCalibration is called once by every reader (interop::ReadCalibrationFile for every
// format, calib::CalibrationFromJson, camera::LoadBrownJson's callers through the simulation) and
// by every writer before it writes (interop::WriteCalibration): what a reader refuses is never
// written. CheckCalibrationFits is called by every command that applies a calibration to a camera
// body and lens (simulate, report, render --camera-model).
#pragma once

#include <optional>
#include <string>

#include "porthole/camera/camera.h"

namespace porthole::camera {

// Throws InvalidInput("<where>.<key>", rule) unless `camera` is a usable calibration:
//  - a sensor of W, H ≥ 1 px and a finite pitch > 0 ("<where>.sensor.width_px" …), the model's
//    parameter count, every parameter finite;
//  - every focal-length parameter > 0 (c, or fx and fy, or f);
//  - the principal point inside the image (−0.5 … W − 0.5, −0.5 … H − 0.5 px);
//  - a frame the distortion keeps monotonic: along 16 directions from the principal point to the
//    frame's edge (corners, edge midpoints and quarter points), 64 pixels on the way have rays at
//    increasing angles off axis and (forward models: OpenCV, Kannala–Brandt, the fisheye
//    projections) rays at 64 increasing angles up to the edge pixel's project at increasing
//    distances from the principal point, the last onto that pixel. A fisheye model may leave frame
//    pixels without a ray (outside its image circle) only where the map is monotonic to 89°.
void ValidateCalibration(const Camera& camera, const std::string& where = "camera");

// The camera a calibration is applied to (a body and its lens).
struct ExpectedCamera {
  std::string name;                      // for messages: "Nikon D300 + AF Nikkor 24mm f/2.8D"
  Sensor sensor;                         // the body's image size and pixel pitch
  bool size_estimated = false;           // the pixel counts are an estimate (lensfun: crop factor and
                                         // pitch): compare the image's size in mm, within 5 %
  double focal_length_mm = 0;            // the lens's nominal focal length
  double max_principal_distance_mm = 0;  // the principal distance at its closest focus (thin lens)
};

// The tolerances of CheckCalibrationFits (docs/robustness.md says why these).
// Focal length: the principal distance of a calibration lies between the lens's focal length (focus
// at infinity) and its value at the closest focus; 15 % either side of that range covers nominal
// focal lengths rounded by the maker (ISO 517 allows ±5 %), the thin-lens estimate of the close
// focus (the paper's 24 mm lens: 25.8 mm calibrated, 26.7 mm estimated, 3.5 %) and the focus
// breathing of internal-focus lenses, and still refuses a calibration of another lens or in pixels.
inline constexpr double kFocalLengthTolerance = 0.15;
// Image size of a body whose pixel counts porthole estimated (a lensfun body: crop factor, assumed
// 3:2 or 4:3, and the pitch): the sensor's width and height in mm.
inline constexpr double kEstimatedSizeTolerance = 0.05;
// Pixel pitch: makers round the pitch to 0.1 µm (0.0055 mm for 5.51 µm, 2 %).
inline constexpr double kPixelPitchTolerance = 0.02;

// Throws InvalidInput(field, …) on one line naming both values when the calibration is not one of
// `expected`: another image size (W × H px, exact; in mm within kEstimatedSizeTolerance when the
// body's pixel counts are estimated); another pixel pitch by more than
// kPixelPitchTolerance when the calibration states one (`pitch_known`; porthole JSON); a focal
// length (in px times the body's pitch) outside [f·(1 − tol), c_closest·(1 + tol)].
void CheckCalibrationFits(const Camera& calibration, bool pitch_known, const ExpectedCamera& expected,
                          const std::string& field);

// Throws InvalidInput(field, "<what> …") unless a computed camera is possible: every focal-length
// parameter finite and > 0, every parameter finite, `rms_px` (when given) finite and ≥ 0. For
// results (fits, refits, adjustments): an impossible one is an error, never an answer.
void RequirePossibleResult(const Camera& camera, std::optional<double> rms_px, const std::string& field,
                           const std::string& what);

}  // namespace porthole::camera
