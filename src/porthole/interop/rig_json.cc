// porthole's rig JSON (rig format json): {"rig": {"cameras": [...]}}, each camera's calibration
// JSON (calib/result_json.h) with its name and cam_from_rig {rotation_rad, translation_mm}, as
// calib::RigToJson writes it and measure::RigFromJson reads it; and a rig calibration in memory
// (calib::RigResult) as a rig file (docs/interop.md, "Rig files").
#include <fmt/format.h>

#include <Eigen/Core>
#include <cmath>

#include "porthole/calib/rig.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/rig_internal.h"

namespace porthole::interop {

using detail::FromRotationVector;
using detail::RotationVector;
using Json = nlohmann::json;

RigFile RigFileFromJson(const nlohmann::json& j, const std::string& field) {
  if (!j.is_object() || !j.contains("rig")) {
    if (j.is_object() && j.contains("camera")) {
      throw InvalidInput(field, "a single camera's calibration, not a rig (a rig JSON has a \"rig\" object)");
    }
    throw InvalidInput(field, "not a rig calibration: no \"rig\" object");
  }
  const Json& r = j["rig"];
  const std::string rf = field + ".rig";
  if (!r.is_object() || !r.contains("cameras") || !r["cameras"].is_array() || r["cameras"].empty()) {
    throw InvalidInput(rf + ".cameras", "must be a non-empty list");
  }
  RigFile rig;
  rig.format = RigFormat::kJson;
  rig.pitch_known = true;
  rig.length_unit_note = "mm (porthole)";
  for (std::size_t k = 0; k < r["cameras"].size(); ++k) {
    const Json& cj = r["cameras"][k];
    const std::string cf = fmt::format("{}.cameras[{}]", rf, k);
    RigFileCamera c;
    c.name = cj.contains("name") && cj["name"].is_string() ? cj["name"].get<std::string>() : fmt::format("camera{}", k);
    c.calibration = calib::CalibrationFromJson(cj, cf);
    c.calibration.label = c.name;
    if (!cj.contains("cam_from_rig") || !cj["cam_from_rig"].is_object()) throw InvalidInput(cf + ".cam_from_rig", "missing");
    const Json& p = cj["cam_from_rig"];
    Eigen::Vector3d rv, tv;
    for (auto [key, out] : {std::pair<const char*, Eigen::Vector3d*>{"rotation_rad", &rv}, {"translation_mm", &tv}}) {
      const std::string where = cf + ".cam_from_rig." + key;
      if (!p.contains(key) || !p[key].is_array() || p[key].size() != 3) throw InvalidInput(where, "must be a list of 3 numbers");
      for (int i = 0; i < 3; ++i) {
        if (!p[key][i].is_number() || !std::isfinite(p[key][i].get<double>())) throw InvalidInput(where, "must be 3 finite numbers");
        (*out)(i) = p[key][i].get<double>();
      }
    }
    c.rotation = FromRotationVector(rv);
    c.translation_mm = tv;
    if (cj.contains("port") && !cj["port"].is_null()) {
      c.port = cj["port"].is_object() && cj["port"].contains("name") && cj["port"]["name"].is_string()
                   ? cj["port"]["name"].get<std::string>()
                   : "a port";
    }
    rig.cameras.push_back(std::move(c));
  }
  return rig;
}

RigFile RigFileFromResult(const calib::RigResult& r) {
  RigFile rig;
  rig.pitch_known = true;
  rig.length_unit_note = "mm (porthole)";
  for (const auto& c : r.cameras) {
    RigFileCamera rc;
    rc.name = c.name;
    rc.calibration.label = c.name;
    rc.calibration.camera = c.calibration.camera;
    rc.calibration.free = c.calibration.free;
    rc.calibration.covariance = c.calibration.covariance;
    rc.calibration.has_covariance = true;
    rc.calibration.sigma0_px = c.calibration.sigma0_px;
    rc.rotation = FromRotationVector(c.rotation_rad);
    rc.translation_mm = c.translation_mm;
    if (c.has_port) rc.port = c.estimated_port.name.empty() ? "a port" : c.estimated_port.name;
    rig.cameras.push_back(std::move(rc));
  }
  return rig;
}

nlohmann::ordered_json RigFileToJson(const RigFile& rig) {
  nlohmann::ordered_json cameras = nlohmann::ordered_json::array();
  for (const auto& c : rig.cameras) {
    if (!c.port.empty()) {
      throw InvalidInput("rig", "camera " + c.name + " is behind a port: a rig file read from another format has none");
    }
    const WriteResult w = WriteCalibration(c.calibration, Format::kJson, "rig: camera " + c.name);
    const auto cal = nlohmann::ordered_json::parse(w.content);
    const Eigen::Vector3d rv = RotationVector(c.rotation);
    nlohmann::ordered_json out = {{"name", c.name},
                                  {"cam_from_rig",
                                   {{"rotation_rad", {rv(0), rv(1), rv(2)}},
                                    {"translation_mm", {c.translation_mm(0), c.translation_mm(1), c.translation_mm(2)}}}}};
    for (const auto& [k, v] : cal.items()) out[k] = v;
    cameras.push_back(out);
  }
  return {{"rig",
           {{"frame", "camera 0's camera frame (X right, Y down, Z forward, mm); cam_from_rig maps it into each camera: "
                      "x_cam = R(rotation_rad) x_rig + translation_mm"},
            {"source", std::string(RigFormatName(rig.format))},
            {"length_unit", rig.length_unit_note},
            {"n_cameras", rig.cameras.size()},
            {"covariance_note", "none: a " + std::string(RigFormatName(rig.format)) + " rig file holds no covariance"},
            {"cameras", cameras}}}};
}

namespace detail {

RigFile ReadRigJsonFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                        RigFormat /*format*/, const RigReadOptions& /*options*/, const std::string& field) {
  return RigFileFromJson(ParseJsonText(contents[0], field, names[0]), field);
}

RigFiles WriteRigJsonFile(const RigFile& rig, RigFormat /*format*/, const std::string& /*field*/,
                          std::vector<RigWriteCamera>* info) {
  RigFiles files{{"", RigFileToJson(rig).dump(1) + "\n"}};
  for (const auto& c : rig.cameras) info->push_back({c.name, std::string(c.calibration.camera.model_name()), true, {}});
  return files;
}

}  // namespace detail

}  // namespace porthole::interop
