#include "porthole/calib/result_json.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "porthole/camera/json.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using camera::kBrownNumParams;
using camera::kBrownParamInfo;
using Json = nlohmann::ordered_json;

Json Number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json Matrix(const FreeMask& free, const Eigen::Matrix<double, 10, 10>& m) {
  Json keys = Json::array(), rows = Json::array();
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!free[i]) continue;
    keys.push_back(std::string(kBrownParamInfo[i].json_key));
    Json row = Json::array();
    for (int j = 0; j < kBrownNumParams; ++j) {
      if (free[j]) row.push_back(Number(m(i, j)));
    }
    rows.push_back(row);
  }
  return {{"parameters", keys}, {"matrix", rows}};
}

int KeyIndex(const std::string& key) {
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (kBrownParamInfo[i].json_key == key) return i;
  }
  return -1;
}

}  // namespace

Json CalibrationToJson(const CalibrationResult& r, const TargetSpec& target,
                       const CalibrationOptions& options) {
  const auto value = r.camera.ToArray();
  Json cam = Json::object(), sig = Json::object(), fixed = Json::array();
  for (int i = 0; i < kBrownNumParams; ++i) {
    const std::string key(kBrownParamInfo[i].json_key);
    cam[key] = r.free[i] || value[i] != 0 ? Json(value[i]) : Json(nullptr);
    sig[key] = r.free[i] ? Number(r.sigma[i]) : Json(nullptr);
    if (!r.free[i] && value[i] != 0) fixed.push_back(key);
  }
  Json significance = Json::array(), dropped = Json::array(), images = Json::array();
  for (const auto& s : r.significance) {
    significance.push_back({{"parameter", std::string(kBrownParamInfo[s.index].json_key)},
                            {"t", Number(s.t)},
                            {"significant", s.significant}});
  }
  for (const auto& d : r.dropped) {
    dropped.push_back({{"parameter", std::string(kBrownParamInfo[d.index].json_key)},
                       {"value", d.value},
                       {"sigma", Number(d.sigma)},
                       {"t", Number(d.t)}});
  }
  for (const auto& im : r.images) {
    images.push_back({{"image", im.image},
                      {"n_points", im.n_points},
                      {"n_rejected", im.n_rejected},
                      {"rms_px", Number(im.rms_px)},
                      {"rotation_rad", {im.rotation_rad.x(), im.rotation_rad.y(), im.rotation_rad.z()}},
                      {"translation_mm",
                       {im.translation_mm.x(), im.translation_mm.y(), im.translation_mm.z()}}});
  }
  const bool px = options.pixel_pitch_mm == 1.0;
  Json j = {
      {"camera", cam},
      {"sigma", sig},
      {"units", camera::BrownUnitsJson()},
      {"pixels_are_mm", px},
      {"note", px ? "no --pixel-pitch-mm: pitch 1, so every _mm value is in pixels (K1 in px^-2 …)"
                  : fmt::format("pixel pitch {:g} mm", options.pixel_pitch_mm)},
      {"correlation", Matrix(r.free, r.correlation)},
      {"covariance", Matrix(r.free, r.covariance)},
      {"sigma0_px", Number(r.sigma0_px)},
      {"rms_px", Number(r.rms_px)},
      {"sensor",
       {{"width_px", r.sensor.width_px},
        {"height_px", r.sensor.height_px},
        {"pixel_pitch_mm", r.sensor.pixel_pitch_mm}}},
      {"target", target.ToString()},
      {"free", FreeParametersToString(r.free)},
      {"fixed", fixed},
      {"significance_t", options.significance_t},
      {"significance", significance},
      {"dropped", dropped},
      {"target_free", options.target_free},
      {"n_images", r.n_images},
      {"n_points", r.n_points},
      {"n_rejected", r.n_rejected},
      {"n_unknowns", r.n_unknowns},
      {"redundancy", r.redundancy},
      {"iterations", r.iterations},
      {"seconds", r.seconds},
      {"images", images},
      {"status", r.message},
  };
  return j;
}

CalibrationRecord CalibrationFromJson(const nlohmann::json& j, const std::string& field) {
  CalibrationRecord rec;
  if (!j.is_object() || !j.contains("camera") || !j["camera"].is_object()) {
    throw InvalidInput(field, "not a calibration: no \"camera\" object");
  }
  // null = not adjusted: drop it and let camera::BrownFromJson check keys and values.
  nlohmann::json cam = nlohmann::json::object();
  for (const auto& [key, val] : j["camera"].items()) {
    if (val.is_null()) continue;
    cam[key] = val;
    const int i = KeyIndex(key);
    if (i >= 0) rec.free[i] = true;
  }
  rec.camera = camera::BrownFromJson(cam, field + ".camera").value;
  if (j.contains("fixed")) {
    for (const auto& k : j["fixed"]) {
      const int i = KeyIndex(k.get<std::string>());
      if (i >= 0) rec.free[i] = false;
    }
  }
  try {
    const auto& s = j.at("sensor");
    rec.sensor = {s.at("width_px").get<int>(), s.at("height_px").get<int>(),
                  s.at("pixel_pitch_mm").get<double>()};
  } catch (const nlohmann::json::exception&) {
    throw InvalidInput(field, "sensor: needs width_px, height_px, pixel_pitch_mm");
  }
  camera::ValidateSensor(rec.sensor);
  if (j.contains("covariance") && j["covariance"].is_object()) {
    const auto& c = j["covariance"];
    std::vector<int> idx;
    for (const auto& k : c.at("parameters")) {
      const int i = KeyIndex(k.get<std::string>());
      if (i < 0) throw InvalidInput(field, "covariance: unknown parameter " + k.dump());
      idx.push_back(i);
    }
    const auto& m = c.at("matrix");
    if (m.size() != idx.size()) throw InvalidInput(field, "covariance: matrix size");
    for (std::size_t a = 0; a < idx.size(); ++a) {
      if (m[a].size() != idx.size()) throw InvalidInput(field, "covariance: matrix size");
      for (std::size_t b = 0; b < idx.size(); ++b) {
        rec.covariance(idx[a], idx[b]) = m[a][b].is_number() ? m[a][b].get<double>() : NAN;
      }
    }
    rec.has_covariance = rec.covariance.allFinite() && !idx.empty();
  } else if (j.contains("sigma") && j["sigma"].is_object()) {
    for (const auto& [key, val] : j["sigma"].items()) {
      const int i = KeyIndex(key);
      if (i < 0) throw InvalidInput(field, "sigma." + key + ": unknown parameter");
      if (val.is_number() && rec.free[i]) rec.covariance(i, i) = val.get<double>() * val.get<double>();
    }
    rec.has_covariance = true;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (rec.free[i] && !(rec.covariance(i, i) > 0)) rec.has_covariance = false;
    }
    rec.covariance_note = "diagonal from sigma";
  }
  if (j.contains("sigma0_px") && j["sigma0_px"].is_number()) rec.sigma0_px = j["sigma0_px"];
  return rec;
}

std::string ExportOpenCVYaml(const CalibrationRecord& rec, camera::ConversionFit* fit) {
  const auto conv = camera::BrownToOpenCV(rec.camera, rec.sensor);
  if (fit != nullptr) *fit = conv.fit;
  const auto& o = conv.opencv;
  return fmt::format(
      "%YAML:1.0\n---\n"
      "# porthole calibration refit to OpenCV's model: RMS {:.4f} px, max {:.4f} px over the image\n"
      "image_width: {}\nimage_height: {}\n"
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ {:.17g}, 0., {:.17g}, 0., {:.17g}, {:.17g}, 0., 0., 1. ]\n"
      "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
      "   data: [ {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g} ]\n",
      conv.fit.rms_px, conv.fit.max_px, rec.sensor.width_px, rec.sensor.height_px, o.fx, o.cx,
      o.fy, o.cy, o.k1, o.k2, o.p1, o.p2, o.k3);
}

namespace {

int YamlInt(const std::string& y, const std::string& key, const std::string& field) {
  const std::regex re("(^|\\n)" + key + ":\\s*([0-9]+)");
  std::smatch m;
  if (!std::regex_search(y, m, re)) throw InvalidInput(field, "OpenCV YAML: no " + key);
  return std::stoi(m[2]);
}

std::vector<double> YamlMatrix(const std::string& y, const std::string& key,
                               const std::string& field) {
  const std::regex re("(^|\\n)" + key + ":[^\\[]*\\[([^\\]]*)\\]");
  std::smatch m;
  if (!std::regex_search(y, m, re)) throw InvalidInput(field, "OpenCV YAML: no " + key + " data");
  std::vector<double> out;
  std::stringstream ss(m[2].str());
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      out.push_back(std::stod(item));
    } catch (const std::exception&) {
      throw InvalidInput(field, "OpenCV YAML: " + key + ": '" + item + "' is not a number");
    }
  }
  return out;
}

}  // namespace

CalibrationRecord ImportOpenCVYaml(const std::string& yaml, double pixel_pitch_mm,
                                   const std::string& field, camera::ConversionFit* fit) {
  RequirePositive("--pixel-pitch-mm", pixel_pitch_mm);
  const auto k = YamlMatrix(yaml, "camera_matrix", field);
  const auto d = YamlMatrix(yaml, "distortion_coefficients", field);
  if (k.size() != 9) throw InvalidInput(field, "camera_matrix must have 9 entries");
  if (d.size() < 4) throw InvalidInput(field, "distortion_coefficients: at least k1 k2 p1 p2");
  for (std::size_t i = 5; i < d.size(); ++i) {
    if (d[i] != 0) throw InvalidInput(field, "distortion beyond k3 (rational/thin prism) is not "
                                             "representable in the Brown model");
  }
  camera::OpenCVParams o{k[0], k[4], k[2], k[5], d[0], d[1], d[2], d[3], d.size() > 4 ? d[4] : 0};
  CalibrationRecord rec;
  rec.sensor = {YamlInt(yaml, "image_width", field), YamlInt(yaml, "image_height", field),
                pixel_pitch_mm};
  const auto conv = camera::OpenCVToBrown(o, rec.sensor);
  if (fit != nullptr) *fit = conv.fit;
  rec.camera = conv.brown;
  rec.free = {true, true, true, true, true, true, true, true, true, true};
  return rec;
}

CalibrationRecord LoadCalibration(const std::string& path, double pixel_pitch_mm,
                                  const std::string& field, camera::ConversionFit* fit) {
  std::ifstream in(path);
  if (!in) throw InvalidInput(field, "cannot read " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string ext = std::filesystem::path(path).extension().string();
  CalibrationRecord rec;
  if (ext == ".yml" || ext == ".yaml") {
    rec = ImportOpenCVYaml(ss.str(), pixel_pitch_mm, field, fit);
  } else {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(ss.str());
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(field, path + ": not JSON (" + e.what() + ")");
    }
    rec = CalibrationFromJson(j, field);
  }
  rec.label = std::filesystem::path(path).stem().string();
  return rec;
}

}  // namespace porthole::calib
