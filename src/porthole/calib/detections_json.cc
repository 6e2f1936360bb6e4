#include "porthole/calib/detections_json.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace fs = std::filesystem;

nlohmann::ordered_json DetectionsToJson(const ImageDetections& d, const TargetSpec& target) {
  nlohmann::ordered_json pts = nlohmann::ordered_json::array();
  for (const auto& p : d.points_px) pts.push_back({p.x(), p.y()});
  return {{"image", d.image},       {"target", target.ToString()}, {"width_px", d.width_px},
          {"height_px", d.height_px}, {"ids", d.ids},                {"points_px", pts}};
}

ImageDetections DetectionsFromJson(const nlohmann::json& j, const std::string& where) {
  ImageDetections d;
  std::string reading = "image";  // the key being read, named in errors ("points_px[3]: …")
  try {
    d.image = j.at("image").get<std::string>();
    // Whole numbers in [1, 1e6]: get<int>() would wrap 4294967936 to 640.
    for (auto [key, out] : {std::pair{"width_px", &d.width_px}, std::pair{"height_px", &d.height_px}}) {
      reading = key;
      const double v = j.at(key).is_number() ? j.at(key).get<double>() : NAN;
      if (!(v >= 1 && v <= 1e6 && v == std::floor(v))) {
        throw InvalidInput(where, std::string(key) + ": must be a whole number from 1 to 1000000");
      }
      *out = static_cast<int>(v);
    }
    reading = "ids";
    d.ids = j.at("ids").get<std::vector<int>>();
    reading = "points_px";
    const auto& points = j.at("points_px");
    if (!points.is_array()) throw InvalidInput(where, "points_px: must be a list of [u, v] pairs");
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto& p = points[i];
      const std::string at = "points_px[" + std::to_string(i) + "]";
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) {
        throw InvalidInput(where, at + ": must be a pair [u, v] of numbers");
      }
      d.points_px.emplace_back(p[0].get<double>(), p[1].get<double>());
      if (!d.points_px.back().allFinite()) throw InvalidInput(where, at + ": finite numbers");
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(where, reading + ": not a detections object: " + JsonMessage(e));
  }
  if (d.ids.size() != d.points_px.size()) {
    throw InvalidInput(where, "ids and points_px differ in length");
  }
  if (d.width_px < 1 || d.height_px < 1) throw InvalidInput(where, "width_px, height_px >= 1");
  return d;
}

nlohmann::ordered_json DetectionSetToJson(const std::vector<ImageDetections>& detections,
                                          const std::vector<SkippedImage>& skipped,
                                          const TargetSpec& target) {
  nlohmann::ordered_json images = nlohmann::ordered_json::array(),
                         skip = nlohmann::ordered_json::array();
  for (const auto& d : detections) images.push_back(DetectionsToJson(d, target));
  for (const auto& s : skipped) skip.push_back({{"image", s.image}, {"reason", s.reason}});
  return {{"target", target.ToString()}, {"images", images}, {"skipped", skip}};
}

namespace {

void MergeTarget(const nlohmann::json& j, const std::string& where, const std::string& field,
                 TargetSpec* target) {
  if (target == nullptr || !j.contains("target")) return;
  const TargetSpec t = ParseTarget(j.at("target").get<std::string>(), where + ".target");
  if (target->cols == 0) {
    *target = t;
  } else if (t.ToString() != target->ToString()) {
    throw InvalidInput(field, where + " was detected with target " + t.ToString() + ", not " +
                                  target->ToString());
  }
}

}  // namespace

std::vector<ImageDetections> LoadDetections(const std::string& path, const std::string& field,
                                            TargetSpec* target) {
  std::vector<fs::path> files;
  if (fs::is_directory(path)) {
    for (const auto& e : fs::directory_iterator(path)) {
      if (e.path().extension() == ".json") files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    if (files.empty()) throw InvalidInput(field, path + " holds no *.json detection files");
  } else if (fs::exists(path)) {
    files.push_back(path);
  } else {
    throw InvalidInput(field, path + " does not exist");
  }
  std::vector<ImageDetections> out;
  for (const auto& f : files) {
    const std::string text = ReadInputFile(f, field, kMaxJsonFileBytes);
    const auto j = ParseJsonText(text, field, f.string());
    // Errors name the file, the line and the key (file.json.images[3]: file.json:17: points_px: …).
    WithJsonLines(text, f.string(), f.string(), [&] {
      try {
        if (j.contains("images")) {  // a set file
          MergeTarget(j, f.string(), field, target);
          for (std::size_t i = 0; i < j.at("images").size(); ++i) {
            out.push_back(DetectionsFromJson(j["images"][i], f.string() + ".images[" + std::to_string(i) + "]"));
          }
        } else {
          MergeTarget(j, f.string(), field, target);
          out.push_back(DetectionsFromJson(j, f.string()));
        }
      } catch (const nlohmann::json::exception& e) {  // "images" or "target" of the wrong type
        throw InvalidInput(field, f.string() + ": " + JsonMessage(e));
      }
    });
  }
  return out;
}

}  // namespace porthole::calib
