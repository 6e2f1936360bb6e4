// Detections as JSON, one object per image (written by `porthole detect`, read by
// `porthole calibrate --detections`):
//   {"image": "left01.jpg", "target": "chessboard:9x6:25", "width_px": 640, "height_px": 480,
//    "ids": [0, 1, …], "points_px": [[u, v], …]}
// Pixels: (0, 0) is the centre of the top-left pixel (observations.h). A set file holds
//   {"target": …, "images": [ per-image objects ], "skipped": [{"image": …, "reason": …}]}.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"

namespace porthole::calib {

struct SkippedImage {
  std::string image;
  std::string reason;  // "unreadable", "no target found", …
};

nlohmann::ordered_json DetectionsToJson(const ImageDetections& d, const TargetSpec& target);
// Throws InvalidInput("<where>…") on a malformed object.
ImageDetections DetectionsFromJson(const nlohmann::json& j, const std::string& where);

nlohmann::ordered_json DetectionSetToJson(const std::vector<ImageDetections>& detections,
                                          const std::vector<SkippedImage>& skipped,
                                          const TargetSpec& target);

// Reads a set file, a per-image file, or a directory of per-image *.json files (sorted by name).
// When the files name a target and `target` is non-null and empty (cols == 0), it is filled in;
// a target that disagrees with the files throws InvalidInput(field).
std::vector<ImageDetections> LoadDetections(const std::string& path, const std::string& field,
                                            TargetSpec* target);

}  // namespace porthole::calib
