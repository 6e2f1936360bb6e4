// One rig calibration as the front ends run it (issue 25: `porthole calibrate` with several
// `--images` or `--detections`, Python's calibrate_rig): each camera's images (detected here, or
// detections read or given), frames matched by name (calib/rig.h), and the policies the front ends
// held twice: the per-camera options (one for all or one per camera, a count mismatch refused), the
// in-air calibrations (one rig file of any rig format or one file per camera, made through the
// ports or of the lenses alone), each camera's air images, its port, the options a rig does not
// take, the OpenCV stereo pair. The front ends parse their options into CalibrateRigJobOptions, call
// CalibrateRigJob and print or return the result; CalibrateRigJobJson is the JSON both give.
//
// Errors are InvalidInput naming the library's fields, as CalibrateJob's (calib/job.h): images,
// detections, names, target, field, model, free, pixel_pitch_mm, port, air_calibration, air_lens_bare,
// air_images, air_detections, ep, port_out, field_out, stereo_out, and the options a rig refuses
// (intrinsics, free_water_index, free_shell, port_sigma, free_port, opencv_yaml,
// plan_only, drop_insignificant); CalibrateRig's own (cameras, …) pass through.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include "porthole/calib/rig.h"
#include "porthole/ports/environment.h"

namespace porthole::calib {

struct CalibrateRigJobOptions {
  // Each camera's images, in rig order (two or more): directories, images or videos to detect the
  // target in (`images`), detections files or directories (`detections`), or detections already in
  // memory (`given`; errors then name `detections`). Frames are matched by file name.
  std::vector<std::string> images, detections;
  std::optional<std::vector<std::vector<ImageDetections>>> given;
  // The cameras' names in the output; empty: the folders' or files' names (camera0, … for given).
  std::vector<std::string> names;
  std::string target;   // the spec (ParseTarget); may be empty with detections that name theirs
  std::string field;    // a coded target's field file (empty: the default sheet)
  FrameOptions frames;  // a video's or a folder's frames (images, air_images)
  // The lenses: one model for all or one per camera, the free set (one model's names: not with a
  // model per camera), loss and centre correction by name; the numbers (reject_k, loss_scale_px)
  // and progress in `lens`. target_free and drop_insignificant are refused in a rig.
  std::vector<std::string> model = {"brown"};
  std::string free = "default", loss = "none", centre_correction = "auto";
  CalibrationOptions lens;
  // One pitch for all or one per camera; empty: 1 (millimetres are pixels).
  std::vector<double> pixel_pitch_mm;
  // Said at once (and kept in the result): the plausibility warnings of the pitches and the ports.
  std::function<void(const std::string&)> warn;
  // Cameras behind ports, in water: one port (preset name or TOML file) for all or one per camera.
  std::vector<std::string> port;
  ports::Environment water;
  // Every camera's entrance pupil in its housing frame, mm (with `port`): where its port's
  // parameters are predicted from; unset: each port file's own (as one camera's `ep_mm`).
  std::optional<Eigen::Vector3d> ep_mm;
  // In-air calibrations of the lenses (with `port`), as priors: one rig file of any rig format
  // (interop/rig_files.h; every camera at one pitch) or one file of any format per camera, or one
  // calibration given per camera (Python's dicts); made through the ports in air (the default) or
  // of each lens alone (`air_lens_bare`).
  std::vector<std::string> air_calibration;
  std::optional<std::vector<CalibrationRecord>> air_given;
  bool air_lens_bare = false;
  // Images in air through each camera's port (with `port`): one source per camera, in rig order —
  // images to detect in, detections files, or detections given.
  std::vector<std::string> air_images, air_detections;
  std::optional<std::vector<std::vector<ImageDetections>>> air_given_detections;
  // The datum of a free target (lens.target_free): auto | minimal | control, as a single camera's
  // (LensOptionsFromNames); the first camera's calibration chooses it.
  std::string datum = "auto";
  // The air images were taken at another focus (each camera's air set its own focal factor).
  bool air_refocused = false;
  // Each camera's estimated port as a port TOML (result.port_tomls; with `port`): its housing-frame
  // port with the estimated parameters, the pupil where `port` put it, read by every command.
  bool port_out = false;
  // The free target's adjusted points as a target-field file (result.field_text; with
  // lens.target_free and a coded target), as one camera's (calib/result_json.h AdjustedFieldText).
  bool field_out = false;
  // The single camera's options a rig does not take (yet): set, each is refused by its name
  // (free_port: the port parameters adjusted).
  bool intrinsics = false, free_water_index = false, free_shell = false,
       free_port = false, port_sigma = false, opencv_yaml = false, plan_only = false;
  // The first two cameras as OpenCV's stereo file (result.stereo_text): the file name the front end
  // will write (.xml: XML, else YAML); empty: none. Both cameras of the opencv model without a port.
  std::string stereo_out;
  // Called once the options hold together, before any file is read or image searched: the front
  // end checks the files it will write there (the CLI's overwrite rule).
  std::function<void()> check_outputs;
};

struct CalibrateRigJobResult {
  TargetSpec target;                      // as used (from the detections, with its field)
  RigOptions rig_options;                 // as CalibrateRig took them (cameras, names, ports, air)
  RigResult rig;                          // the calibration
  std::vector<SkippedImage> skipped;      // images without the target ("<source>: <image>")
  std::optional<nlohmann::ordered_json> images_source;  // with `images`: each camera's FrameChoiceToJson
  std::vector<std::string> warnings;      // those said through options.warn
  std::string stereo_text;                // the OpenCV stereo file asked for (stereo_out)
  std::vector<std::string> port_tomls;    // port_out: each camera's estimated port (catalogue::PortToToml)
  std::string field_text;                 // field_out: the adjusted target field
};

// Runs the rig calibration the options describe. Throws InvalidInput(field, …) for bad options or
// input, and for a camera whose calibration ended impossible, naming `images` or `detections`.
CalibrateRigJobResult CalibrateRigJob(const CalibrateRigJobOptions& options);

// The result as `porthole calibrate --json` prints it for a rig (before the CLI adds its output
// files): RigToJson's {"rig": …}, with images_source (from images) and skipped.
nlohmann::ordered_json CalibrateRigJobJson(const CalibrateRigJobResult& r);

}  // namespace porthole::calib
