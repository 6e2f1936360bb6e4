// Target detection in images with OpenCV (the only part of calib that links OpenCV):
//  - chessboard: cv::findChessboardCornersSB (sector-based, sub-pixel by its own refinement with
//    CALIB_CB_ACCURACY on the up-sampled image), inner corners row-major;
//  - ChArUco: contrib aruco detectMarkers + interpolateCornersCharuco (ids = OpenCV's corner ids);
//  - circle grids: cv::findCirclesGrid, symmetric or asymmetric.
// Pixel convention of OpenCV = porthole's: (0, 0) is the centre of the top-left pixel.
// An unreadable image or one without the target is not an error: it is returned as skipped.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/detections_json.h"
#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"

namespace porthole::calib {

struct DetectResult {
  std::optional<ImageDetections> detections;  // set when the target was found
  std::string reason;                          // why not: "unreadable", "no target found"
};

// Detects `target` in the image file at `path`. `label` names it in the result (default: path).
DetectResult DetectTarget(const std::string& path, const TargetSpec& target,
                          const std::string& label = "");

// Image files (jpg, jpeg, png, tif, tiff, bmp, pgm, ppm; any case) in a directory, sorted by name.
// Throws InvalidInput(field) if the directory does not exist or holds none.
std::vector<std::string> ListImages(const std::string& dir, const std::string& field = "--images");

struct DetectionRun {
  std::vector<ImageDetections> detections;
  std::vector<SkippedImage> skipped;
};

// Detects the target in every image; `progress` (may be empty) gets one line per image.
DetectionRun DetectAll(const std::vector<std::string>& paths, const TargetSpec& target,
                       const std::function<void(const std::string&)>& progress = {});

// The detections as OpenCV's calibrateCamera takes them: per image, target points (target frame,
// mm) and their pixels. For comparisons with OpenCV on the same points.
void ToOpenCVCorrespondences(const std::vector<ImageDetections>& detections,
                             const TargetSpec& target,
                             std::vector<std::vector<cv::Point3f>>* object_points,
                             std::vector<std::vector<cv::Point2f>>* image_points);

}  // namespace porthole::calib
