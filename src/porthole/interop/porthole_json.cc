// porthole's own calibration JSON (format json; calib/result_json.h reads it, docs/interop.md,
// "porthole JSON"): every model of the camera list, the pixel pitch, and σ with the covariance of
// the adjusted parameters where it is known.
#include <cmath>
#include <string>

#include "porthole/calib/result_json.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"

namespace porthole::interop {
namespace {

using camera::Camera;

// The camera's parameters (null: not adjusted and 0), σ (null: unknown or not adjusted) and, when
// known, the covariance of the adjusted ones (calib/result_json.h reads them back).
std::string PortholeJson(const calib::CalibrationRecord& cal) {
  using Json = nlohmann::ordered_json;
  const Camera& cam = cal.camera;
  Json params = Json::object(), sigma = Json::object(), fixed = Json::array();
  const auto& info = cam.info();
  for (int i = 0; i < info.num_params; ++i) {
    const std::string key(info.params[i].json_key);
    const bool adjusted = cal.free.size() == cam.params.size() && cal.free[i];
    const bool written = adjusted || cam.params[i] != 0 || i < info.first_distortion;
    params[key] = written ? Json(cam.params[i]) : Json(nullptr);
    if (written && !adjusted) fixed.push_back(key);
    const double var = adjusted ? cal.covariance(i, i) : NAN;
    sigma[key] = var > 0 ? Json(std::sqrt(var)) : Json(nullptr);
  }
  Json j = {
      {"model", std::string(info.name)},
      {"camera", params},
      {"sigma", sigma},
      {"fixed", fixed},
      {"units", calib::CameraUnitsJson(cam.model)},
      {"sensor",
       {{"width_px", cam.sensor.width_px},
        {"height_px", cam.sensor.height_px},
        {"pixel_pitch_mm", cam.sensor.pixel_pitch_mm}}},
      {"note", cal.has_covariance ? "written by porthole convert"
                                  : "written by porthole convert; sigma null: unknown (" + cal.covariance_note + ")"},
  };
  if (cal.has_covariance) j["covariance"] = calib::CovarianceJson(info, cal.free, cal.covariance);
  return j.dump(2) + "\n";
}

}  // namespace

namespace detail {

ReadResult ReadPortholeJson(const std::string& content, const ReadArgs& args) {
  const nlohmann::json j = ParseJsonText(content, args.field, args.origin);
  ReadResult r;
  r.calibration =
      WithJsonLines(content, args.field, args.origin, [&] { return calib::CalibrationFromJson(j, args.field); });
  r.format = args.format;
  r.format_model = std::string(r.camera().model_name());
  r.pitch_known = true;
  // A σ the file does not give is unknown, not 0.
  auto& rec = r.calibration;
  for (int i = 0; i < rec.camera.info().num_params; ++i) {
    if (!rec.free[i] || rec.covariance(i, i) > 0) continue;
    rec.covariance.row(i).setConstant(NAN);
    rec.covariance.col(i).setConstant(NAN);
    rec.has_covariance = false;
  }
  return r;
}

WriteResult WritePortholeJson(const calib::CalibrationRecord& cal, Format /*format*/, const std::string& /*field*/,
                              const WriteExtras& /*extras*/) {
  WriteResult w;
  w.content = PortholeJson(cal);
  w.format_model = std::string(cal.camera.model_name());
  w.sigma_written = cal.has_covariance;
  return w;
}

}  // namespace detail

}  // namespace porthole::interop
