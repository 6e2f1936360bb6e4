// The rig as measure/ uses it (rig_model.h): read from calibrate's rig JSON or from a RigResult.
#include "porthole/measure/rig_model.h"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <cmath>
#include <map>

#include "porthole/calib/result_json.h"
#include "porthole/calib/rig.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/core/nearest.h"
#include "porthole/interop/rig_files.h"
#include "porthole/refraction/shell_json.h"

namespace porthole::measure {
namespace {

using Json = nlohmann::json;

double Number(const Json& j, const std::string& key, const std::string& field) {
  if (!j.contains(key) || !j[key].is_number()) throw InvalidInput(field + "." + key, "must be a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw InvalidInput(field + "." + key, "must be finite");
  return v;
}

Eigen::Vector3d Vector3(const Json& j, const std::string& key, const std::string& field) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) {
    throw InvalidInput(field + "." + key, "must be a list of 3 numbers");
  }
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!j[key][i].is_number()) throw InvalidInput(field + "." + key, "must be a list of 3 numbers");
    v(i) = j[key][i].get<double>();
    if (!std::isfinite(v(i))) throw InvalidInput(field + "." + key, "must be finite");
  }
  return v;
}

refraction::Shell ShellFromJson(const Json& port, const std::string& field) {
  if (!port.contains("kind") || !port["kind"].is_string()) {
    std::string kinds;  // the port list's shapes
    for (std::string_view n : ports::ShapeNames()) kinds += (kinds.empty() ? "" : ", ") + std::string(n);
    throw InvalidInput(field + ".kind", "must be one of " + kinds);
  }
  if (!port.contains("shell") || !port["shell"].is_object()) {
    throw InvalidInput(field + ".shell", "missing: the rig file predates measure (calibrate it again with this "
                                         "version to record each port's shell)");
  }
  return refraction::ShellFromJson(port["kind"].get<std::string>(), port["shell"], field + ".shell");
}

}  // namespace

Eigen::Matrix3d RigCamera::CamFromRigRotation() const {
  const double angle = rotation_rad.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, rotation_rad / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

Rig CameraFromJson(const nlohmann::json& j, const std::string& field) {
  if (!j.is_object() || !j.contains("camera")) {
    if (j.is_object() && j.contains("rig")) return RigFromJson(j, field);
    throw InvalidInput(field, "not a calibration: no \"camera\" object");
  }
  const calib::CalibrationRecord rec = calib::CalibrationFromJson(j, field);
  Rig rig;
  rig.sigma0_px = std::isfinite(rec.sigma0_px) ? rec.sigma0_px : 0.0;
  RigCamera c;
  c.name = "camera";
  c.camera = rec.camera;
  const camera::ModelInfo& info = c.camera.info();
  c.intrinsic_index.assign(info.num_params, -1);
  std::vector<double> sig2;
  std::vector<int> local;
  for (int i = 0; i < info.num_params; ++i) {
    if (rec.free[i] && rec.has_covariance) c.intrinsic_index[i] = static_cast<int>(local.size()), local.push_back(i);
  }
  int n = static_cast<int>(local.size());
  bool port_sigma = false;
  if (j.contains("port") && j["port"].is_object()) {
    const std::string pf = field + ".port";
    c.shell = ShellFromJson(j["port"], pf);
    const auto& names = refraction::PortParams(c.shell->kind);
    for (int i = 0; i < refraction::kPortNumParams; ++i) {
      const std::string key(names[i].json_key);
      c.port[i] = Number(j["port"]["parameters"], key, pf + ".parameters");
      const auto& sj = j["port"].contains("sigma") ? j["port"]["sigma"] : Json();
      if (sj.is_object() && sj.contains(key) && sj[key].is_number()) {
        c.port_index[i] = n++;
        sig2.push_back(std::pow(sj[key].get<double>(), 2));
        port_sigma = true;
      }
    }
    refraction::ValidateParams(*c.shell, c.port.data(), pf + ".parameters");
  }
  rig.covariance = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t a = 0; a < local.size(); ++a) {
    for (std::size_t b = 0; b < local.size(); ++b) rig.covariance(a, b) = rec.covariance(local[a], local[b]);
  }
  for (std::size_t i = 0; i < sig2.size(); ++i) rig.covariance(local.size() + i, local.size() + i) = sig2[i];
  // The port's correlations with the lens and with each other (the refractive calibration's
  // "correlation" rows): the joint covariance back.
  bool joint = false;
  if (port_sigma && rec.has_covariance && j["port"].contains("correlation") && j["port"]["correlation"].is_object()) {
    const RigCamera& cam = c;
    const auto& names = refraction::PortParams(cam.shell->kind);
    const auto sd = [&](int row) { return std::sqrt(rig.covariance(row, row)); };
    for (int i = 0; i < refraction::kPortNumParams; ++i) {
      const std::string key(names[i].json_key);
      const Json& row = j["port"]["correlation"];
      if (cam.port_index[i] < 0 || !row.contains(key) || !row[key].is_object()) continue;
      for (const auto& [other, value] : row[key].items()) {
        if (!value.is_number()) continue;
        int at = -1;
        for (int q = 0; q < info.num_params; ++q) {
          if (info.params[q].json_key == other) at = cam.intrinsic_index[q];
        }
        for (int q = 0; q < refraction::kPortNumParams; ++q) {
          if (names[q].json_key == other) at = cam.port_index[q];
        }
        if (at < 0 || at == cam.port_index[i]) continue;
        const double v = value.get<double>() * sd(cam.port_index[i]) * sd(at);
        rig.covariance(cam.port_index[i], at) = rig.covariance(at, cam.port_index[i]) = v;
        joint = true;
      }
    }
  }
  rig.covariance_note = !rec.has_covariance ? "none (the calibration holds no covariance)"
                        : joint      ? "joint (the lens's covariance, the port's sigma and their correlations)"
                        : port_sigma ? "the lens's covariance and the port's sigma (their correlation left out)"
                                     : "the lens's covariance";
  rig.cameras.push_back(std::move(c));
  return rig;
}

Rig RigFromJson(const nlohmann::json& j, const std::string& field) {
  if (!j.is_object() || !j.contains("rig")) {
    if (j.is_object() && j.contains("camera")) {
      throw InvalidInput(field, "a single camera's calibration, not a rig: measure needs the JSON of a rig "
                                "calibration (the cameras calibrated together), or a "
                                "known plane or range for one camera (`plane`)");
    }
    throw InvalidInput(field, "not a rig calibration: no \"rig\" object");
  }
  const Json& r = j["rig"];
  const std::string rf = field + ".rig";
  if (!r.is_object() || !r.contains("cameras") || !r["cameras"].is_array() || r["cameras"].empty()) {
    throw InvalidInput(rf + ".cameras", "must be a non-empty list");
  }
  Rig rig;
  rig.sigma0_px = r.contains("sigma0_px") && r["sigma0_px"].is_number() ? r["sigma0_px"].get<double>() : 0.0;
  std::vector<calib::CalibrationRecord> records;
  std::map<std::string, int> row_of;  // joint covariance parameter name → row
  const bool joint = r.contains("covariance") && r["covariance"].is_object();
  int n_joint = 0;
  if (joint) {
    const Json& c = r["covariance"];
    if (!c.contains("parameters") || !c["parameters"].is_array() || !c.contains("matrix") || !c["matrix"].is_array()) {
      throw InvalidInput(rf + ".covariance", "needs parameters [...] and matrix [[...]]");
    }
    n_joint = static_cast<int>(c["parameters"].size());
    for (int i = 0; i < n_joint; ++i) {
      if (!c["parameters"][i].is_string()) throw InvalidInput(rf + ".covariance.parameters", "must be names");
      if (!row_of.emplace(c["parameters"][i].get<std::string>(), i).second) {
        throw InvalidInput(rf + ".covariance.parameters", "names " + c["parameters"][i].get<std::string>() + " twice");
      }
    }
    if (static_cast<int>(c["matrix"].size()) != n_joint) {
      throw InvalidInput(rf + ".covariance.matrix", fmt::format("must be {0} × {0}", n_joint));
    }
    rig.covariance = Eigen::MatrixXd::Zero(n_joint, n_joint);
    for (int a = 0; a < n_joint; ++a) {
      const Json& row = c["matrix"][a];
      if (!row.is_array() || static_cast<int>(row.size()) != n_joint) {
        throw InvalidInput(rf + ".covariance.matrix", fmt::format("must be {0} × {0}", n_joint));
      }
      for (int b = 0; b < n_joint; ++b) {
        if (!row[b].is_number()) throw InvalidInput(rf + ".covariance.matrix", "must hold numbers (not null)");
        rig.covariance(a, b) = row[b].get<double>();
      }
    }
    rig.covariance_note = "joint";
  }
  // Without the joint matrix: each camera's own blocks, gathered below.
  std::vector<std::pair<std::vector<int>, Eigen::MatrixXd>> own_blocks;
  for (std::size_t k = 0; k < r["cameras"].size(); ++k) {
    const Json& cj = r["cameras"][k];
    const std::string cf = fmt::format("{}.cameras[{}]", rf, k);
    RigCamera c;
    c.name = cj.contains("name") && cj["name"].is_string() ? cj["name"].get<std::string>() : fmt::format("camera{}", k);
    const calib::CalibrationRecord rec = calib::CalibrationFromJson(cj, cf);
    c.camera = rec.camera;
    const camera::ModelInfo& info = c.camera.info();
    if (!cj.contains("cam_from_rig") || !cj["cam_from_rig"].is_object()) {
      throw InvalidInput(cf + ".cam_from_rig", "missing");
    }
    c.rotation_rad = Vector3(cj["cam_from_rig"], "rotation_rad", cf + ".cam_from_rig");
    c.translation_mm = Vector3(cj["cam_from_rig"], "translation_mm", cf + ".cam_from_rig");
    if (cj.contains("port") && !cj["port"].is_null()) {
      const std::string pf = cf + ".port";
      c.shell = ShellFromJson(cj["port"], pf);
      if (!cj["port"].contains("parameters") || !cj["port"]["parameters"].is_object()) {
        throw InvalidInput(pf + ".parameters", "missing");
      }
      const auto& names = refraction::PortParams(c.shell->kind);
      for (int i = 0; i < refraction::kPortNumParams; ++i) {
        c.port[i] = Number(cj["port"]["parameters"], std::string(names[i].json_key), pf + ".parameters");
      }
      refraction::ValidateParams(*c.shell, c.port.data(), pf + ".parameters");
    }
    c.intrinsic_index.assign(info.num_params, -1);
    const auto row = [&](const std::string& key) {
      const auto it = row_of.find(c.name + "." + key);
      return it == row_of.end() ? -1 : it->second;
    };
    if (joint) {
      for (int i = 0; i < info.num_params; ++i) {
        if (rec.free[i]) c.intrinsic_index[i] = row(std::string(info.params[i].json_key));
      }
      if (c.shell) {
        const auto& names = refraction::PortParams(c.shell->kind);
        for (int i = 0; i < refraction::kPortNumParams; ++i) c.port_index[i] = row(std::string(names[i].json_key));
      }
      const char* pose_keys[6] = {"rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm"};
      for (int i = 0; i < 6; ++i) c.pose_index[i] = row(std::string("cam_from_rig.") + pose_keys[i]);
    } else {
      // Each camera's own blocks: intrinsics from its calibration, cam_from_rig from its 6 × 6.
      std::vector<int> local;
      for (int i = 0; i < info.num_params; ++i) {
        if (rec.free[i] && rec.has_covariance) c.intrinsic_index[i] = n_joint + static_cast<int>(local.size()), local.push_back(i);
      }
      Eigen::MatrixXd block = Eigen::MatrixXd::Zero(local.size(), local.size());
      for (std::size_t a = 0; a < local.size(); ++a) {
        for (std::size_t b = 0; b < local.size(); ++b) block(a, b) = rec.covariance(local[a], local[b]);
      }
      n_joint += static_cast<int>(local.size());
      own_blocks.push_back({{}, block});
      const Json& cr = cj["cam_from_rig"];
      if (k > 0 && cr.contains("covariance") && cr["covariance"].is_array() && cr["covariance"].size() == 6) {
        Eigen::MatrixXd pc(6, 6);
        for (int a = 0; a < 6; ++a) {
          for (int b = 0; b < 6; ++b) {
            const Json& v = cr["covariance"][a][b];
            pc(a, b) = v.is_number() ? v.get<double>() : 0.0;
          }
        }
        for (int i = 0; i < 6; ++i) c.pose_index[i] = n_joint + i;
        n_joint += 6;
        own_blocks.push_back({{}, pc});
      }
    }
    rig.cameras.push_back(std::move(c));
  }
  if (!joint) {
    rig.covariance = Eigen::MatrixXd::Zero(n_joint, n_joint);
    int at = 0;
    for (const auto& [unused, b] : own_blocks) {
      rig.covariance.block(at, at, b.rows(), b.cols()) = b;
      at += static_cast<int>(b.rows());
    }
    rig.covariance_note = "per camera: the file has no joint covariance (written before it existed), so the "
                          "correlations between cameras (and with the ports) are left out";
  }
  if (!rig.cameras.empty() && (rig.cameras[0].rotation_rad.norm() > 1e-12 || rig.cameras[0].translation_mm.norm() > 1e-9)) {
    throw InvalidInput(rf + ".cameras[0].cam_from_rig", "camera 0 defines the rig frame: its pose must be the identity");
  }
  return rig;
}

namespace {

// Reads `path` (size-capped) and parses it with `from`, JSON errors with their file and line.
Rig LoadWith(const std::string& path, const std::string& field, Rig (*from)(const nlohmann::json&, const std::string&)) {
  const std::string text = ReadInputFile(path, field, kMaxCalibrationFileBytes);
  const Json j = ParseJsonText(text, field, path);
  return WithJsonLines(text, field, path, [&] {
    try {
      return from(j, field);
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(field, WithoutJsonTag(e.what()));
    }
  });
}

}  // namespace

Rig LoadCamera(const std::string& path, const std::string& field) { return LoadWith(path, field, &CameraFromJson); }
Rig LoadRig(const std::string& path, const std::string& field) {
  // The rig files of other tools (interop/rig_files.h): read into the rig JSON's form. They hold
  // no covariance; files without a stated length unit or image size are refused there (convert
  // them with their unit first).
  const std::string text = ReadInputFile(path, field, kMaxCalibrationFileBytes);
  const auto format = interop::DetectRigFormat(path, text);
  if (format && *format != interop::RigFormat::kJson) {
    if (*format == interop::RigFormat::kRosCameraInfo) {
      throw InvalidInput(field, "a ROS camera_info file holds one camera of the pair: convert the two files into a rig "
                                "JSON first");
    }
    interop::RigReadOptions o;
    o.format = format;
    interop::RigFile file;
    try {
      file = interop::ParseRigFiles({text}, {path}, o, field);
    } catch (const InvalidInput& e) {
      std::string rule = e.what();
      const std::string prefix = OneLineMessage(e.field()) + ": ";
      if (rule.rfind(prefix, 0) == 0) rule = rule.substr(prefix.size());
      if (rule.find("choices: mm, cm, m") == std::string::npos && rule.find("image size") == std::string::npos) throw;
      throw InvalidInput(e.field(), rule + "; measure reads only what the file states: convert it into a rig JSON "
                                           "with them first");
    }
    Rig rig = RigFromJson(interop::RigFileToJson(file), field);
    rig.covariance_note = fmt::format("none: a {} rig file holds no covariance (T in {})",
                                      interop::RigFormatName(*format), file.length_unit_note);
    return rig;
  }
  return LoadWith(path, field, &RigFromJson);
}

Rig RigFromResult(const calib::RigResult& r) {
  Rig rig;
  rig.sigma0_px = r.sigma0_px;
  rig.covariance = r.covariance;
  rig.covariance_note = "joint";
  std::map<std::string, int> row_of;
  for (std::size_t i = 0; i < r.covariance_parameters.size(); ++i) row_of[r.covariance_parameters[i]] = static_cast<int>(i);
  for (const calib::RigCamera& rc : r.cameras) {
    RigCamera c;
    c.name = rc.name;
    c.camera = rc.calibration.camera;
    c.rotation_rad = rc.rotation_rad;
    c.translation_mm = rc.translation_mm;
    const auto row = [&](const std::string& key) {
      const auto it = row_of.find(c.name + "." + key);
      return it == row_of.end() ? -1 : it->second;
    };
    const camera::ModelInfo& info = c.camera.info();
    c.intrinsic_index.assign(info.num_params, -1);
    for (int i = 0; i < info.num_params; ++i) {
      if (rc.calibration.free[i]) c.intrinsic_index[i] = row(std::string(info.params[i].json_key));
    }
    if (rc.has_port) {
      c.shell = rc.shell;
      c.port = rc.port;
      const auto& names = refraction::PortParams(rc.port_kind);
      for (int i = 0; i < refraction::kPortNumParams; ++i) c.port_index[i] = row(std::string(names[i].json_key));
    }
    const char* pose_keys[6] = {"rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm"};
    for (int i = 0; i < 6; ++i) c.pose_index[i] = row(std::string("cam_from_rig.") + pose_keys[i]);
    rig.cameras.push_back(std::move(c));
  }
  return rig;
}

int CameraIndex(const Rig& rig, std::string_view name, const std::string& field) {
  std::vector<std::string> names;
  int by_name = -1;
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    if (rig.cameras[k].name == name) by_name = static_cast<int>(k);
    names.push_back(rig.cameras[k].name);
  }
  const bool digits = !name.empty() && name.find_first_not_of("0123456789") == std::string_view::npos && name.size() < 6;
  const int by_index = digits && std::stoi(std::string(name)) < static_cast<int>(rig.cameras.size())
                           ? std::stoi(std::string(name))
                           : -1;
  if (by_name >= 0 && by_index >= 0 && by_name != by_index) {
    throw InvalidInput(field, fmt::format("camera {} could be the camera named {} (index {}) or the camera at index "
                                          "{} ({}): rename the cameras", std::string(name), std::string(name), by_name,
                                          by_index, names[by_index]));
  }
  if (by_name >= 0) return by_name;
  if (by_index >= 0) return by_index;

  std::string known;
  for (std::size_t k = 0; k < names.size(); ++k) known += (k ? ", " : "") + fmt::format("{} ({})", names[k], k);
  const auto near = NearestNames(name, names, 1, TypoDistance(name));
  throw InvalidInput(field, fmt::format("no camera {} in the rig{} (cameras: {})", std::string(name),
                                        near.empty() ? "" : "; did you mean " + near[0] + "?", known));
}

}  // namespace porthole::measure
