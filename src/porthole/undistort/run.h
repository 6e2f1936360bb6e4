// `porthole undistort` as one library call (docs/undistort.md): a calibration file and a folder of
// images in, the undistorted images and the pinhole's files out, under core/output.h's rules. The
// CLI and the Python module call Run and print or return its summary.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/measure/rig_model.h"
#include "porthole/undistort/undistort.h"

namespace porthole::undistort {

// The calibration as one camera: porthole's refractive JSON (a lens behind its port, or a rig of
// one camera) through measure's loader, every other file (any format interop reads) as a central
// camera. Throws InvalidInput(field, …).
measure::RigCamera LoadCalibration(const std::string& path,
                                   const std::string& field = "calibration");

// "1000" or "500:3000" (mm). Throws InvalidInput(field, …).
std::vector<double> ParseWd(const std::string& text, const std::string& field = "wd_mm");

struct RunOptions {
  std::string calibration;  // file (field "calibration")
  // The camera itself (a rig's camera), instead of reading `calibration`; `calibration` then only
  // names its file, which no output may replace.
  std::optional<measure::RigCamera> camera;
  std::string images;  // a folder, one image or a video (field "images"; calib/frames.h)
  int every = 1;       // every N-th image or frame (field "every")
  std::string out;     // folder, created when missing (field "out")
  UndistortOptions undistort;
  bool force = false;  // replace existing outputs (core/output.h's rule)
  std::vector<std::filesystem::path>
      inputs;  // further inputs no output may replace (the caller's files)
  std::string gnuplot = "gnuplot";
  // Only the checks (calibration, options, image sizes, the outputs under the rules, gnuplot) and
  // the pinhole: nothing is remapped; the output folders may have been created. Returns the
  // pinhole's summary (SummaryJson). For several runs that must all be possible before the first
  // writes.
  bool check_only = false;
  // One line per event (the pinhole and map; each image done), from one thread at a time. May be
  // empty.
  std::function<void(const std::string&)> progress;
};

// Reads the calibration, checks every image's size from its header and every output under the
// rules, builds the map, remaps the images (in parallel), writes OUT/images/*, cameras.txt,
// camera.yml, camera.xml, transforms.json, undistort.json and, behind a port,
// residual.png/.dat/.gp. Returns undistort.json's content. Throws InvalidInput naming the field
// (calibration, images, out, alpha, keep_focal, wd_mm, threads, gnuplot).
nlohmann::ordered_json Run(const RunOptions& options);

}  // namespace porthole::undistort
