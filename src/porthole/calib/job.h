// One calibration of one camera as the front ends run it (issue 25: `porthole calibrate` without a
// rig, Python's calibrate and calibrate_refractive): the images (detected here, or detections read
// or given), the target and its field, the lens options by name, the policies (the pixel pitch an
// in-air calibration states, the plausibility warning, which options go together, an impossible
// adjustment refused), then the central calibration, the explicit refractive one behind a port, or
// the network advice (plan_only). The front ends parse their options into CalibrateJobOptions, call
// CalibrateJob and print or return the result; CalibrateJobJson is the JSON both give.
//
// Errors are InvalidInput naming the library's fields, which are the CLI's flags with dashes and
// Python's keywords: images, detections, target, field, model, free, loss, centre_correction,
// datum, free_target, pixel_pitch_mm, port, ep, air_calibration, air_lens_bare, air_images, air_refocused,
// air_detections, intrinsics, free_port, port_sigma, free_water_index, free_shell, plan_only,
// opencv_yaml, field_out, port_out. A rule names another field between backquotes.
#pragma once

#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/result_json.h"
#include "porthole/ports/environment.h"

namespace porthole::calib {

struct CalibrateJobOptions {
  // The images of the camera (in water with a port): one of a directory, one image or a video to
  // detect the target in (`images`), a detections file or directory (`detections`), or
  // detections already in memory (`given`; errors then name `detections`).
  std::string images;
  std::string detections;
  std::optional<std::vector<ImageDetections>> given;
  // Or a list of image files to search (Python's calibrate_images of a list; errors name `images`):
  // each searched, no frame choice (frames.every and max_frames refused).
  std::optional<std::vector<std::string>> image_files;
  std::string target;  // the spec (ParseTarget); may be empty with detections that name theirs
  std::string field;   // a coded target's field file (empty: the default sheet)
  FrameOptions frames;  // a video's or a folder's frames (images, air_images)
  DetectOptions detect;  // the search of images and air_images (threads, limits)
  // The lens: its model, free set, robust loss, centre correction and datum by name (as the CLI
  // and Python take them); the numbers (reject_k, loss_scale_px, target_free, drop_insignificant,
  // significance_t) and progress in `lens`, whose model, free, loss, centre_correction, datum and
  // pixel_pitch_mm are set from the names here.
  std::string model = "brown", free = "default", loss = "none", centre_correction = "auto",
              datum = "auto";
  CalibrationOptions lens;
  // Unset: with a port, the pitch an in-air calibration file states (porthole JSON), else 1
  // (millimetres are pixels).
  std::optional<double> pixel_pitch_mm;
  // Said at once (and kept in the result): the plausibility warnings of the pitch and the port, in
  // the library's words (`pixel_pitch_mm`: …).
  std::function<void(const std::string&)> warn;
  // The explicit refractive calibration (calib/refractive.h): a port preset name or TOML file,
  // the pupil in the housing frame (unset: the port's), the water.
  std::string port;
  std::optional<Eigen::Vector3d> ep_mm;
  ports::Environment water;
  // An in-air calibration: a file of any format (interop), or a calibration given (Python's dict),
  // read as the lens model; made through the port in air (the default) or of the lens alone.
  std::string air_calibration;
  std::optional<CalibrationRecord> air_given;
  bool air_lens_bare = false;
  // The same target in air through the same port: images to detect in, or detections (a path, or
  // given).
  std::string air_images, air_detections;
  std::optional<std::vector<ImageDetections>> air_given_detections;
  // The air images were taken at another focus: their own focal length (RefractiveOptions).
  bool air_refocused = false;
  std::string intrinsics;  // free | fixed | prior; empty: prior with an air calibration, else free
  std::string free_port = "all";
  std::optional<std::array<double, refraction::kPortNumParams>> port_sigma;
  bool free_water_index = false, free_shell = false, compare_central = true;
  // Network advice only (PlanRefractiveFromImages) at plan_sigma_px pixel noise.
  bool plan_only = false;
  double plan_sigma_px = 0.3;
  // The outputs the front end will write, so that what cannot be made is refused before the work:
  // an OpenCV YAML (central only; result.opencv_yaml), the adjusted target field (needs
  // free_target; result.field_text), the estimated port (refractive; result.port_toml).
  bool opencv_yaml = false, field_out = false, port_out = false;
  // Called once the options hold together, before any file is read or image searched: the front
  // end checks the files it will write there (the CLI's overwrite rule).
  std::function<void()> check_outputs;
};

struct CalibrateJobResult {
  TargetSpec target;                         // as used (from the detections, with its field)
  std::vector<ImageDetections> detections;   // the images' detections, the target's points kept
  std::vector<SkippedImage> skipped;         // images without the target ("air: " for air images)
  std::optional<nlohmann::ordered_json> images_source, air_images_source;  // FrameChoiceToJson
  CalibrationOptions lens;                   // as resolved (model, free, pitch, …)
  std::optional<RefractiveOptions> refractive_options;  // with a port
  // One of the three, by the options: the central calibration, the refractive one, the plan.
  std::optional<CalibrationResult> central;
  std::optional<RefractiveResult> refractive;
  std::optional<RefractivePlan> plan;
  // How the in-air calibration was read ("<file> (<format> <model>): exact, made through the port
  // in air …"); empty without one given as a file.
  std::string air_note;
  std::vector<std::string> warnings;  // those said through options.warn
  // The outputs asked for: the OpenCV YAML and its refit, the target-field text, the port TOML.
  std::string opencv_yaml, field_text, port_toml;
  camera::ConversionFit opencv_yaml_fit;
};

// `numbers` (reject_k, loss_scale_px, target_free, drop_insignificant, significance_t, progress,
// pixel_pitch_mm) with the model, free set, robust loss (none | huber | cauchy), centre correction
// (auto | on | off) and datum (auto | minimal | control; not auto only with target_free) read from
// their names. Throws InvalidInput(model, free, loss, centre_correction, datum).
CalibrationOptions LensOptionsFromNames(CalibrationOptions numbers, const std::string& model, const std::string& free,
                                        const std::string& loss, const std::string& centre_correction,
                                        const std::string& datum = "auto");

// Runs the calibration the options describe. Throws InvalidInput(field, …) for bad options or
// input, and for an adjustment that ended impossible (a focal length <= 0, a value, the RMS or a
// free parameter's σ not finite), naming `images` or `detections`.
CalibrateJobResult CalibrateJob(const CalibrateJobOptions& options);

// The result as `porthole calibrate --json` prints it (before the CLI adds its output files): the
// plan's JSON (PlanToJson); or the calibration's (CalibrationToJson, or RefractiveToJson with
// port.air_calibration) with skipped, images_source and air_images_source.
nlohmann::ordered_json CalibrateJobJson(const CalibrateJobResult& r);

}  // namespace porthole::calib
