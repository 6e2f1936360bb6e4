// Target detections in images: the input of a calibration.
//
// Pixels follow docs/conventions.md: (0, 0) is the CENTRE of the top-left pixel, u right, v down
// (the OpenCV convention, so OpenCV's detector output is used unchanged).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace porthole::calib {

// The target points found in one image.
struct ImageDetections {
  std::string image;                        // file name or label
  int width_px = 0, height_px = 0;          // image size
  std::vector<int> ids;                     // target point id of each point (target.h)
  std::vector<Eigen::Vector2d> points_px;   // (u, v) of each point, pixels
};

}  // namespace porthole::calib
