#include "porthole/calib/detections_json.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "porthole/core/error.h"

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
  try {
    d.image = j.at("image").get<std::string>();
    d.width_px = j.at("width_px").get<int>();
    d.height_px = j.at("height_px").get<int>();
    d.ids = j.at("ids").get<std::vector<int>>();
    for (const auto& p : j.at("points_px")) {
      if (!p.is_array() || p.size() != 2) throw InvalidInput(where, "points_px: [u, v] pairs");
      d.points_px.emplace_back(p[0].get<double>(), p[1].get<double>());
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(where, std::string("not a detections object: ") + e.what());
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

nlohmann::json ReadJsonFile(const fs::path& p, const std::string& field) {
  std::ifstream in(p);
  if (!in) throw InvalidInput(field, "cannot read " + p.string());
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(field, p.string() + ": not JSON (" + e.what() + ")");
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
    const auto j = ReadJsonFile(f, field);
    if (j.contains("images")) {  // a set file
      MergeTarget(j, f.string(), field, target);
      for (std::size_t i = 0; i < j.at("images").size(); ++i) {
        out.push_back(DetectionsFromJson(j["images"][i], f.string() + ".images[" +
                                                             std::to_string(i) + "]"));
      }
    } else {
      MergeTarget(j, f.string(), field, target);
      out.push_back(DetectionsFromJson(j, f.string()));
    }
  }
  return out;
}

}  // namespace porthole::calib
