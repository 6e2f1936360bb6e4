#include "porthole/calib/detections_json.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

#include <fmt/format.h>

#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace fs = std::filesystem;

nlohmann::ordered_json DetectionsToJson(const ImageDetections& d, const TargetSpec& target) {
  nlohmann::ordered_json pts = nlohmann::ordered_json::array();
  for (const auto& p : d.points_px) pts.push_back({p.x(), p.y()});
  nlohmann::ordered_json j = {{"image", d.image}};
  if (d.frame_index >= 0) {  // a video frame: its index and time in the file
    j["frame_index"] = d.frame_index;
    j["time_s"] = d.time_s;
  }
  if (!std::isnan(d.blur_px)) j["blur_px"] = std::isfinite(d.blur_px) ? nlohmann::ordered_json(d.blur_px) : nlohmann::ordered_json("inf");
  j["target"] = target.ToString();
  j["width_px"] = d.width_px;
  j["height_px"] = d.height_px;
  j["ids"] = d.ids;
  j["points_px"] = pts;
  return j;
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
    const auto& ids = j.at("ids");
    if (!ids.is_array()) throw InvalidInput(where, "ids: must be a list of point ids");
    if (ids.size() > kMaxPointsPerImage) {
      throw InvalidInput(where, fmt::format("ids: {} points in image '{}', more than the limit of {} points per image",
                                            ids.size(), d.image, kMaxPointsPerImage));
    }
    // Whole numbers 0 … 2^31 - 1: get<int>() made 1.9 → 1, 4294967296 → 0, and 1e20 undefined.
    std::unordered_map<int, std::size_t> first_at;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const auto& v = ids[i];
      const double x = v.is_number() ? v.get<double>() : NAN;
      if (!(x >= 0 && x <= std::numeric_limits<int>::max() && x == std::floor(x))) {
        throw InvalidInput(where, fmt::format("ids[{}]: {} in image '{}' is not a point id (a whole number from 0 to {})",
                                              i, v.dump().substr(0, 40), d.image, std::numeric_limits<int>::max()));
      }
      const int id = static_cast<int>(x);
      const auto [it, fresh] = first_at.emplace(id, i);
      if (!fresh) {
        throw InvalidInput(where, fmt::format("ids[{}]: point {} is listed twice in image '{}' (also ids[{}]); each "
                                              "point of the target may appear once per image",
                                              i, id, d.image, it->second));
      }
      d.ids.push_back(id);
    }
    reading = "points_px";
    const auto& points = j.at("points_px");
    if (!points.is_array()) throw InvalidInput(where, "points_px: must be a list of [u, v] pairs");
    if (points.size() != d.ids.size()) {
      throw InvalidInput(where, fmt::format("points_px: {} points for {} ids in image '{}' (one pair per id)",
                                            points.size(), d.ids.size(), d.image));
    }
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto& p = points[i];
      const std::string at = "points_px[" + std::to_string(i) + "]";
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) {
        throw InvalidInput(where, at + ": must be a pair [u, v] of numbers");
      }
      d.points_px.emplace_back(p[0].get<double>(), p[1].get<double>());
      const Eigen::Vector2d& q = d.points_px.back();
      if (!q.allFinite()) throw InvalidInput(where, at + ": finite numbers");
      // Pixel centres run from 0 to W - 1: the image covers [-0.5, W - 0.5] × [-0.5, H - 0.5].
      if (!(q.x() >= -0.5 && q.x() <= d.width_px - 0.5 && q.y() >= -0.5 && q.y() <= d.height_px - 0.5)) {
        throw InvalidInput(where, fmt::format("{}: point {} at ({:g}, {:g}) px lies outside image '{}' of {} x {} px",
                                              at, d.ids[i], q.x(), q.y(), d.image, d.width_px, d.height_px));
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(where, reading + ": not a detections object: " + JsonMessage(e));
  }
  if (d.width_px < 1 || d.height_px < 1) throw InvalidInput(where, "width_px, height_px >= 1");
  // Optional: a video frame's index and time, and the target's edge blur (calib/detect.h).
  if (j.contains("frame_index")) {
    const auto& v = j["frame_index"];
    const double f = v.is_number() ? v.get<double>() : NAN;
    if (!(f >= 0 && f <= 2e9 && f == std::floor(f))) throw InvalidInput(where, "frame_index: a whole number >= 0");
    d.frame_index = static_cast<int>(f);
    const auto t = j.find("time_s");
    if (t == j.end() || !t->is_number() || !std::isfinite(t->get<double>())) {
      throw InvalidInput(where, "time_s: a number of seconds with frame_index");
    }
    d.time_s = t->get<double>();
  }
  if (const auto b = j.find("blur_px"); b != j.end()) {
    if (b->is_string() && b->get<std::string>() == "inf") {
      d.blur_px = INFINITY;
    } else if (b->is_number() && b->get<double>() >= 0) {
      d.blur_px = b->get<double>();
    } else {
      throw InvalidInput(where, "blur_px: a number >= 0 (px) or \"inf\"");
    }
  }
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
    if (files.size() > kMaxImagesPerSet) {
      throw InvalidInput(field, fmt::format("{} holds {} detection files, more than the limit of {} images per set",
                                            path, files.size(), kMaxImagesPerSet));
    }
  } else if (fs::exists(path)) {
    files.push_back(path);
  } else {
    throw InvalidInput(field, path + " does not exist");
  }
  std::vector<ImageDetections> out;
  std::size_t n_points = 0;
  // Counts bound memory and time (a calibration holds every point): checked as each image is read.
  const auto add = [&](ImageDetections d, const std::string& where) {
    if (out.size() == kMaxImagesPerSet) {
      throw InvalidInput(where, fmt::format("more than the limit of {} images per set", kMaxImagesPerSet));
    }
    n_points += d.ids.size();
    if (n_points > kMaxPointsPerSet) {
      throw InvalidInput(where, fmt::format("image '{}' brings the set to {} points, more than the limit of {} "
                                            "points per set", d.image, n_points, kMaxPointsPerSet));
    }
    out.push_back(std::move(d));
  };
  for (const auto& f : files) {
    const std::string text = ReadInputFile(f, field, kMaxJsonFileBytes);
    const auto j = ParseJsonText(text, field, f.string());
    // Errors name the file, the line and the key (file.json.images[3]: file.json:17: points_px: …).
    WithJsonLines(text, f.string(), f.string(), [&] {
      try {
        if (j.contains("images")) {  // a set file
          MergeTarget(j, f.string(), field, target);
          for (std::size_t i = 0; i < j.at("images").size(); ++i) {
            const std::string where = f.string() + ".images[" + std::to_string(i) + "]";
            add(DetectionsFromJson(j["images"][i], where), where);
          }
        } else {
          MergeTarget(j, f.string(), field, target);
          add(DetectionsFromJson(j, f.string()), f.string());
        }
      } catch (const nlohmann::json::exception& e) {  // "images" or "target" of the wrong type
        throw InvalidInput(field, f.string() + ": " + JsonMessage(e));
      }
    });
  }
  return out;
}

}  // namespace porthole::calib
