// Target detections in images: the input of a calibration.
//
// Pixels follow docs/conventions.md: (0, 0) is the CENTRE of the top-left pixel, u right, v down
// (the OpenCV convention, so OpenCV's detector output is used unchanged).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

namespace porthole::calib {

// The target points found in one image.
struct ImageDetections {
  std::string image;                        // file name or label
  int width_px = 0, height_px = 0;          // image size
  std::vector<int> ids;                     // target point id of each point (target.h)
  std::vector<Eigen::Vector2d> points_px;   // (u, v) of each point, pixels
  // A frame of a video (calib/frames.h): its index from 0 in the file and its time, s; the label
  // `image` is then "f<index, 6 digits>" so that frames of one moment match across a rig's videos.
  int frame_index = -1;       // -1: not a video frame
  double time_s = NAN;
  double blur_px = NAN;  // the target's edge blur, px (calib/detect.h EdgeBlurPx); NaN: not measured
};

}  // namespace porthole::calib
