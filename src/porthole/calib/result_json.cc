#include "porthole/calib/result_json.h"

#include <fmt/format.h>

#include <algorithm>


#include "porthole/camera/json.h"
#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/core/plausible.h"

namespace porthole::calib {
namespace {

using Json = nlohmann::ordered_json;

Json Number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json Matrix(const camera::ModelInfo& m, const FreeMask& free, const Eigen::MatrixXd& mat) {
  Json keys = Json::array(), rows = Json::array();
  for (int i = 0; i < m.num_params; ++i) {
    if (!free[i]) continue;
    keys.push_back(std::string(m.params[i].json_key));
    Json row = Json::array();
    for (int j = 0; j < m.num_params; ++j) {
      if (free[j]) row.push_back(Number(mat(i, j)));
    }
    rows.push_back(row);
  }
  return {{"parameters", keys}, {"matrix", rows}};
}

int KeyIndex(const camera::ModelInfo& m, const std::string& key) {
  for (int i = 0; i < m.num_params; ++i) {
    if (m.params[i].json_key == key) return i;
  }
  return -1;
}

std::string KnownKeys(const camera::ModelInfo& m) {
  std::string known;
  for (const auto& p : m.params) known += (known.empty() ? "" : ", ") + std::string(p.json_key);
  return known;
}

}  // namespace

Json CovarianceJson(const camera::ModelInfo& m, const FreeMask& free, const Eigen::MatrixXd& matrix) {
  return Matrix(m, free, matrix);
}

Json CameraUnitsJson(camera::CameraModelId model) {
  Json j = Json::object();
  for (const auto& p : camera::Info(model).params) j[std::string(p.json_key)] = std::string(p.unit);
  return j;
}

Json FieldJson(const TargetSpec& target) {
  Json points = Json::array();
  Json normals = Json::object();  // the targets facing another way than −Z: {id: [nx, ny, nz]}
  for (const auto& p : target.field) {
    points.push_back({p.id, p.xyz_mm.x(), p.xyz_mm.y(), p.xyz_mm.z()});
    if (!coded::FacesMinusZ(p)) normals[std::to_string(p.id)] = {p.normal.x(), p.normal.y(), p.normal.z()};
  }
  Json j = {{"file", target.field_file}, {"n_points", target.field.size()}, {"points", points}};
  if (!normals.empty()) j["normals"] = normals;
  return j;
}

Json AdjustedTargetJson(const CalibrationResult& r, const TargetSpec& target) {
  const std::vector<Eigen::Vector3d> nominal = TargetPoints(target);
  const auto xyz = [](const Eigen::Vector3d& v) { return Json::array({Number(v.x()), Number(v.y()), Number(v.z())}); };
  Json points = Json::array();
  for (std::size_t id = 0; id < r.target_sigma_mm.size() && id < r.target_points_mm.size(); ++id) {
    if (!r.target_sigma_mm[id].allFinite()) continue;  // not observed
    points.push_back({{"id", id}, {"xyz_mm", xyz(r.target_points_mm[id])}, {"sigma_mm", xyz(r.target_sigma_mm[id])},
                      {"nominal_mm", xyz(nominal[id])}});
  }
  if (!r.datum.control.empty()) {
    return {{"datum", {{"control", r.datum.control},
                       {"note", "the control points: coordinates of sigma 0 held at their given values, the others "
                                "a prior of their sigma; the points are in the control points' frame"}}},
            {"points", points}};
  }
  const char* axis[] = {"x", "y", "z"};
  return {{"datum", {{"fixed", {r.datum.a, r.datum.b}}, {"one_coordinate", r.datum.c}, {"axis", axis[r.datum.axis]},
                     {"note", "7 coordinates held at their nominal values: all of the two 'fixed' points, one of the third"}}},
          {"points", points}};
}

std::string AdjustedFieldText(const CalibrationResult& r, const TargetSpec& target) {
  if (target.kind != TargetKind::kCoded) {
    throw InvalidInput("field_out", "a target-field file is for coded targets (`target` coded:...)");
  }
  if (!r.datum.Set()) throw InvalidInput("field_out", "needs `free_target` (without it no point is adjusted)");
  const std::vector<Eigen::Vector3d> nominal = TargetPoints(target);
  const std::vector<Eigen::Vector3d> normal = TargetNormals(target);
  int n_adjusted = 0, n_given = 0;
  std::string body;
  for (std::size_t id = 0; id < nominal.size(); ++id) {
    if (!target.HasPoint(static_cast<int>(id))) continue;
    const bool adjusted = id < r.target_sigma_mm.size() && id < r.target_points_mm.size() &&
                          r.target_sigma_mm[id].allFinite();
    const Eigen::Vector3d& p = adjusted ? r.target_points_mm[id] : nominal[id];
    body += fmt::format("{} {:.6f} {:.6f} {:.6f}", id, p.x(), p.y(), p.z());
    if ((normal[id] + Eigen::Vector3d::UnitZ()).norm() >= 1e-12) {  // facing another way: its normal, as read
      body += fmt::format(" {:.9f} {:.9f} {:.9f}", normal[id].x(), normal[id].y(), normal[id].z());
    }
    if (adjusted) {
      const Eigen::Vector3d& s = r.target_sigma_mm[id];
      const bool control = std::find(r.datum.control.begin(), r.datum.control.end(), static_cast<int>(id)) !=
                           r.datum.control.end();
      const char* datum = control ? " (datum: control point)"
                          : static_cast<int>(id) == r.datum.a || static_cast<int>(id) == r.datum.b ? " (datum)"
                          : static_cast<int>(id) == r.datum.c ? " (datum: one coordinate)" : "";
      body += fmt::format("  # sigma {:.6f} {:.6f} {:.6f}{}\n", s.x(), s.y(), s.z(), datum);
      ++n_adjusted;
    } else {
      body += "  # not observed: as given\n";
      ++n_given;
    }
  }
  const char* axis = "xyz";
  // The source path goes into a comment line: a line break in it would start a line of data.
  std::string source = target.field_file.empty() ? std::string("the default sheet") : target.field_file;
  std::replace_if(source.begin(), source.end(), [](char ch) { return ch == '\n' || ch == '\r'; }, '?');
  return fmt::format(
             "# porthole target field, self-calibrated (porthole calibrate, the target points free): {}\n"
             "# from {}; {} images, sigma0 {:.4f} px\n"
             "# datum: {}\n"
             "# {} points adjusted (sigma in mm after each), {} not observed (as given)\n"
             "# id x_mm y_mm z_mm [nx ny nz: the dot's normal, where not -Z]\n",
             target.ToString(), source,
             r.n_images, r.sigma0_px,
             r.datum.control.empty()
                 ? fmt::format("(held at the given values) ids {} and {} whole, the {} of id {}", r.datum.a, r.datum.b,
                               axis[r.datum.axis], r.datum.c)
                 : fmt::format("the {} control points (held, or a prior of their sigma)", r.datum.control.size()),
             n_adjusted, n_given) +
         body;
}

Json ImagesJson(const std::vector<ImageResult>& images) {
  Json out = Json::array();
  for (const auto& im : images) {
    out.push_back({{"image", im.image},
                   {"n_points", im.n_points},
                   {"n_rejected", im.n_rejected},
                   {"rms_px", Number(im.rms_px)},
                   {"rotation_rad", {im.rotation_rad.x(), im.rotation_rad.y(), im.rotation_rad.z()}},
                   {"translation_mm", {im.translation_mm.x(), im.translation_mm.y(), im.translation_mm.z()}}});
  }
  return out;
}

Json CalibrationToJson(const CalibrationResult& r, const TargetSpec& target,
                       const CalibrationOptions& options) {
  const camera::ModelInfo& m = r.camera.info();
  const std::vector<double>& value = r.camera.params;
  Json cam = Json::object(), sig = Json::object(), fixed = Json::array();
  for (int i = 0; i < m.num_params; ++i) {
    const std::string key(m.params[i].json_key);
    cam[key] = r.free[i] || value[i] != 0 ? Json(value[i]) : Json(nullptr);
    sig[key] = r.free[i] ? Number(r.sigma[i]) : Json(nullptr);
    if (!r.free[i] && value[i] != 0) fixed.push_back(key);
  }
  Json significance = Json::array(), dropped = Json::array(), images = Json::array();
  for (const auto& s : r.significance) {
    significance.push_back({{"parameter", std::string(m.params[s.index].json_key)},
                            {"t", Number(s.t)},
                            {"significant", s.significant}});
  }
  for (const auto& d : r.dropped) {
    dropped.push_back({{"parameter", std::string(m.params[d.index].json_key)},
                       {"value", d.value},
                       {"sigma", Number(d.sigma)},
                       {"t", Number(d.t)}});
  }
  images = ImagesJson(r.images);
  const bool px = m.caps.image_mm && options.pixel_pitch_mm == 1.0;
  const camera::Sensor& sensor = r.camera.sensor;
  Json j = {
      {"model", std::string(m.name)},
      {"camera", cam},
      {"sigma", sig},
      {"units", CameraUnitsJson(r.camera.model)},
      {"pixels_are_mm", px},
      {"note", px ? "no pixel pitch given: pitch 1, so every _mm value is in pixels (K1 in px^-2 …)"
                  : fmt::format("pixel pitch {:g} mm", options.pixel_pitch_mm)},
      {"correlation", Matrix(m, r.free, r.correlation)},
      {"covariance", Matrix(m, r.free, r.covariance)},
      {"sigma0_px", Number(r.sigma0_px)},
      {"rms_px", Number(r.rms_px)},
      {"sensor",
       {{"width_px", sensor.width_px},
        {"height_px", sensor.height_px},
        {"pixel_pitch_mm", sensor.pixel_pitch_mm}}},
      {"target", target.ToString()},
      {"dot_radius_mm", r.dot_radius_mm},
      {"max_centre_offset_px", r.max_centre_offset_px},
      {"free", FreeParametersToString(r.camera.model, r.free).empty()  // "none": every parameter held
                   ? std::string("none")
                   : FreeParametersToString(r.camera.model, r.free)},
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
  if (!target.field.empty()) j["field"] = FieldJson(target);
  if (options.target_free && r.datum.Set()) j["target_adjusted"] = AdjustedTargetJson(r, target);
  // Plausibility of the inputs (core/plausible.h): a pitch of 1 means pixels, not a typo.
  Json warnings = Json::array();
  if (options.pixel_pitch_mm != 1.0) {
    if (auto w = PlausibilityWarning("pixel_pitch_mm", options.pixel_pitch_mm, kPixelPitchRange)) warnings.push_back(*w);
  }
  j["warnings"] = warnings;
  return j;
}

namespace {

// A pixel count from JSON: a whole number in [1, 1e6] (get<int>() wrapped 4294967936 to 640).
int PixelCount(const nlohmann::json& v, const std::string& field, const std::string& key) {
  const double d = v.is_number() ? v.get<double>() : NAN;
  if (!(d >= 1 && d <= 1e6 && d == std::floor(d))) {
    throw InvalidInput(field, "sensor." + key + ": must be a whole number from 1 to 1000000");
  }
  return static_cast<int>(d);
}

CalibrationRecord CalibrationFromJsonUnchecked(const nlohmann::json& j, const std::string& field) {
  CalibrationRecord rec;
  if (!j.is_object() || !j.contains("camera") || !j["camera"].is_object()) {
    throw InvalidInput(field, "not a calibration: no \"camera\" object");
  }
  rec.camera.model = camera::CameraModelId::kBrown;
  if (j.contains("model")) {
    if (!j["model"].is_string()) throw InvalidInput(field + ".model", "must be a model name");
    rec.camera.model = camera::ModelFromName(j["model"].get<std::string>(), field + ".model");
  }
  const camera::ModelInfo& m = rec.camera.info();
  rec.camera.params.assign(m.num_params, 0.0);
  rec.free.assign(m.num_params, false);
  rec.covariance = Eigen::MatrixXd::Zero(m.num_params, m.num_params);
  // null = not adjusted (0); a number = adjusted unless listed in `fixed`.
  for (const auto& [key, val] : j["camera"].items()) {
    const int i = KeyIndex(m, key);
    if (i < 0) {
      throw InvalidInput(field + ".camera." + key, "unknown key (" + std::string(m.name) +
                                                       " parameters are " + KnownKeys(m) + ")");
    }
    if (val.is_null()) continue;
    if (!val.is_number()) throw InvalidInput(field + ".camera." + key, "must be a number or null");
    rec.camera.params[i] = val.get<double>();
    rec.free[i] = true;
  }
  if (rec.camera.params[0] == 0 && !j["camera"].contains(std::string(m.params[0].json_key))) {
    throw InvalidInput(field + ".camera." + std::string(m.params[0].json_key), "is required");
  }
  if (j.contains("fixed")) {
    if (!j["fixed"].is_array()) throw InvalidInput(field + ".fixed", "must be a list of keys");
    for (const auto& k : j["fixed"]) {
      const int i = k.is_string() ? KeyIndex(m, k.get<std::string>()) : -1;
      if (i >= 0) rec.free[i] = false;
    }
  }
  try {
    const auto& s = j.at("sensor");
    rec.camera.sensor = {PixelCount(s.at("width_px"), field, "width_px"), PixelCount(s.at("height_px"), field, "height_px"),
                         s.at("pixel_pitch_mm").get<double>()};
  } catch (const nlohmann::json::exception&) {
    throw InvalidInput(field, "sensor: needs width_px, height_px, pixel_pitch_mm");
  }
  try {
    camera::ValidateSensor(rec.camera.sensor);
  } catch (const InvalidInput& e) {
    throw InvalidInput(field + ".sensor." + e.field(), std::string(e.what()).substr(e.field().size() + 2));
  }
  // The one validation of a calibration read (camera/validate.h): focal lengths > 0, principal
  // point in the image, a frame the distortion keeps monotonic.
  camera::ValidateCalibration(rec.camera, field + ".camera");
  if (j.contains("covariance") && j["covariance"].is_object()) {
    const auto& c = j["covariance"];
    std::vector<int> idx;
    if (!c.contains("parameters") || !c["parameters"].is_array() || !c.contains("matrix") ||
        !c["matrix"].is_array()) {
      throw InvalidInput(field + ".covariance", "needs parameters [...] and matrix [[...]]");
    }
    for (const auto& k : c["parameters"]) {
      const int i = k.is_string() ? KeyIndex(m, k.get<std::string>()) : -1;
      if (i < 0) throw InvalidInput(field, "covariance: unknown parameter " + k.dump());
      idx.push_back(i);
    }
    const auto& mat = c["matrix"];
    if (mat.size() != idx.size()) throw InvalidInput(field, "covariance: matrix size");
    for (std::size_t a = 0; a < idx.size(); ++a) {
      if (!mat[a].is_array() || mat[a].size() != idx.size()) {
        throw InvalidInput(field, "covariance: matrix size");
      }
      for (std::size_t b = 0; b < idx.size(); ++b) {
        rec.covariance(idx[a], idx[b]) = mat[a][b].is_number() ? mat[a][b].get<double>() : NAN;
      }
    }
    rec.has_covariance = rec.covariance.allFinite() && !idx.empty();
  } else if (j.contains("sigma") && j["sigma"].is_object()) {
    for (const auto& [key, val] : j["sigma"].items()) {
      const int i = KeyIndex(m, key);
      if (i < 0) throw InvalidInput(field, "sigma." + key + ": unknown parameter");
      if (val.is_number() && rec.free[i]) rec.covariance(i, i) = val.get<double>() * val.get<double>();
    }
    rec.has_covariance = true;
    for (int i = 0; i < m.num_params; ++i) {
      if (rec.free[i] && !(rec.covariance(i, i) > 0)) rec.has_covariance = false;
    }
    rec.covariance_note = "diagonal from sigma";
  }
  if (j.contains("sigma0_px") && j["sigma0_px"].is_number()) rec.sigma0_px = j["sigma0_px"];
  if (j.contains("dot_radius_mm") && j["dot_radius_mm"].is_number()) rec.dot_radius_mm = j["dot_radius_mm"];
  if (j.contains("max_centre_offset_px") && j["max_centre_offset_px"].is_number()) {
    rec.max_centre_offset_px = j["max_centre_offset_px"];
  }
  return rec;
}

}  // namespace

CalibrationRecord CalibrationFromJson(const nlohmann::json& j, const std::string& field) {
  try {
    return CalibrationFromJsonUnchecked(j, field);
  } catch (const nlohmann::json::exception& e) {  // a value of the wrong type: one line, naming the file
    throw InvalidInput(field, JsonMessage(e));
  }
}

std::string ExportOpenCVYaml(const CalibrationRecord& rec, camera::ConversionFit* fit) {
  const camera::Sensor& sensor = rec.camera.sensor;
  if (rec.camera.model == camera::CameraModelId::kOpenCV) {
    using M = camera::OpenCVModel;
    const std::vector<double>& p = rec.camera.params;
    if (fit != nullptr) *fit = camera::ConversionFit{};
    return fmt::format(
        "%YAML:1.0\n---\n"
        "# porthole calibration, OpenCV rational model (exact)\n"
        "image_width: {}\nimage_height: {}\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        "   data: [ {:.17g}, 0., {:.17g}, 0., {:.17g}, {:.17g}, 0., 0., 1. ]\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 8\n   dt: d\n"
        "   data: [ {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g} ]\n",
        sensor.width_px, sensor.height_px, p[M::kFx], p[M::kCx], p[M::kFy], p[M::kCy], p[M::kK1],
        p[M::kK2], p[M::kP1], p[M::kP2], p[M::kK3], p[M::kK4], p[M::kK5], p[M::kK6]);
  }
  const auto conv = camera::BrownToOpenCV(camera::ToBrown(rec.camera, "opencv_yaml"), sensor);
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
      conv.fit.rms_px, conv.fit.max_px, sensor.width_px, sensor.height_px, o.fx, o.cx,
      o.fy, o.cy, o.k1, o.k2, o.p1, o.p2, o.k3);
}

}  // namespace porthole::calib
