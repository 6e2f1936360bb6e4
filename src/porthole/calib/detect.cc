#include "porthole/calib/detect.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "porthole/core/error.h"

namespace porthole::calib {
namespace fs = std::filesystem;
namespace {

std::optional<cv::aruco::PREDEFINED_DICTIONARY_NAME> DictionaryByName(const std::string& name) {
  using namespace cv::aruco;
  static const std::map<std::string, PREDEFINED_DICTIONARY_NAME> kNames = {
      {"DICT_4X4_50", DICT_4X4_50},     {"DICT_4X4_100", DICT_4X4_100},
      {"DICT_4X4_250", DICT_4X4_250},   {"DICT_4X4_1000", DICT_4X4_1000},
      {"DICT_5X5_50", DICT_5X5_50},     {"DICT_5X5_100", DICT_5X5_100},
      {"DICT_5X5_250", DICT_5X5_250},   {"DICT_5X5_1000", DICT_5X5_1000},
      {"DICT_6X6_50", DICT_6X6_50},     {"DICT_6X6_100", DICT_6X6_100},
      {"DICT_6X6_250", DICT_6X6_250},   {"DICT_6X6_1000", DICT_6X6_1000},
      {"DICT_7X7_50", DICT_7X7_50},     {"DICT_7X7_100", DICT_7X7_100},
      {"DICT_7X7_250", DICT_7X7_250},   {"DICT_7X7_1000", DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", DICT_ARUCO_ORIGINAL}};
  const auto it = kNames.find(name);
  if (it == kNames.end()) return std::nullopt;
  return it->second;
}

bool FindPoints(const cv::Mat& gray, const TargetSpec& t, std::vector<int>* ids,
                std::vector<cv::Point2f>* pts) {
  const cv::Size size(t.cols, t.rows);
  bool found = false;
  switch (t.kind) {
    case TargetKind::kChessboard:
      found = cv::findChessboardCornersSB(
          gray, size, *pts,
          cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
      break;
    case TargetKind::kCircles:
      // The graph search misses small grids (4×3); the clustering search is the fallback.
      found = cv::findCirclesGrid(gray, size, *pts, cv::CALIB_CB_SYMMETRIC_GRID) ||
              cv::findCirclesGrid(gray, size, *pts,
                                  cv::CALIB_CB_SYMMETRIC_GRID | cv::CALIB_CB_CLUSTERING);
      break;
    case TargetKind::kAsymmetricCircles:
      found = cv::findCirclesGrid(gray, size, *pts, cv::CALIB_CB_ASYMMETRIC_GRID);
      break;
    case TargetKind::kCharuco: {
      const auto dict_name = DictionaryByName(t.dictionary);
      if (!dict_name) throw InvalidInput("--target", "unknown ArUco dictionary " + t.dictionary);
      const auto dict = cv::aruco::getPredefinedDictionary(*dict_name);
      const auto board = cv::aruco::CharucoBoard::create(
          t.cols, t.rows, static_cast<float>(t.spacing_mm), static_cast<float>(t.marker_mm), dict);
      std::vector<int> marker_ids;
      std::vector<std::vector<cv::Point2f>> marker_corners;
      cv::aruco::detectMarkers(gray, dict, marker_corners, marker_ids);
      if (marker_ids.empty()) return false;
      cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, *pts, *ids);
      return ids->size() >= 4;
    }
  }
  if (!found) return false;
  ids->resize(pts->size());
  for (std::size_t i = 0; i < ids->size(); ++i) (*ids)[i] = static_cast<int>(i);
  return true;
}

}  // namespace

DetectResult DetectTarget(const std::string& path, const TargetSpec& target,
                          const std::string& label) {
  DetectResult r;
  const cv::Mat gray = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (gray.empty()) {
    r.reason = "unreadable";
    return r;
  }
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  if (!FindPoints(gray, target, &ids, &pts)) {
    r.reason = "no target found";
    return r;
  }
  ImageDetections d;
  d.image = label.empty() ? path : label;
  d.width_px = gray.cols;
  d.height_px = gray.rows;
  d.ids = ids;
  for (const auto& p : pts) d.points_px.emplace_back(p.x, p.y);
  r.detections = std::move(d);
  return r;
}

std::vector<std::string> ListImages(const std::string& dir, const std::string& field) {
  if (!fs::is_directory(dir)) throw InvalidInput(field, dir + " is not a directory");
  static const std::vector<std::string> kExt = {".jpg", ".jpeg", ".png", ".tif", ".tiff",
                                                ".bmp", ".pgm",  ".ppm"};
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (std::find(kExt.begin(), kExt.end(), ext) != kExt.end()) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  if (out.empty()) throw InvalidInput(field, dir + " holds no images (jpg, png, tif, bmp, pgm)");
  return out;
}

DetectionRun DetectAll(const std::vector<std::string>& paths, const TargetSpec& target,
                       const std::function<void(const std::string&)>& progress) {
  DetectionRun run;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const std::string label = fs::path(paths[i]).filename().string();
    auto r = DetectTarget(paths[i], target, label);
    if (r.detections) {
      if (progress) {
        progress(fmt::format("[{}/{}] {}: {} points", i + 1, paths.size(), label,
                             r.detections->ids.size()));
      }
      run.detections.push_back(std::move(*r.detections));
    } else {
      if (progress) progress(fmt::format("[{}/{}] {}: skipped ({})", i + 1, paths.size(), label,
                                         r.reason));
      run.skipped.push_back({label, r.reason});
    }
  }
  return run;
}

void ToOpenCVCorrespondences(const std::vector<ImageDetections>& detections,
                             const TargetSpec& target,
                             std::vector<std::vector<cv::Point3f>>* object_points,
                             std::vector<std::vector<cv::Point2f>>* image_points) {
  const auto pts = TargetPoints(target);
  object_points->clear();
  image_points->clear();
  for (const auto& d : detections) {
    object_points->emplace_back();
    image_points->emplace_back();
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const auto& p = pts[d.ids[k]];
      object_points->back().emplace_back(p.x(), p.y(), p.z());
      image_points->back().emplace_back(d.points_px[k].x(), d.points_px[k].y());
    }
  }
}

}  // namespace porthole::calib
