#include "porthole/simulate/report.h"

#include <fmt/format.h>

#include <cmath>

#include "porthole/camera/json.h"
#include "porthole/camera/profile.h"

namespace porthole::simulate {
namespace {

constexpr int kNumFitted = camera::kBrownP2 + 1;  // c … P2

const char* AxisName(int axis) { return axis == 0 ? "x" : axis == 1 ? "y" : "z"; }

Json Number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json VecJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

std::string RadiusKey(double r) { return fmt::format("dr_change_um_at_{:g}mm", r); }

}  // namespace

Json FittedParamsJson(const camera::BrownParams& p) {
  Json all = camera::BrownToJson(p);
  Json j = Json::object();
  for (int i = 0; i < kNumFitted; ++i) {
    const std::string key(camera::kBrownParamInfo[i].json_key);
    j[key] = all[key];
  }
  return j;
}

Json FitUnitsJson() {
  Json all = camera::BrownUnitsJson();
  Json j = Json::object();
  for (int i = 0; i < kNumFitted; ++i) {
    const std::string key(camera::kBrownParamInfo[i].json_key);
    j[key] = all[key];
  }
  return j;
}

Json FitJson(const BrownFit& f) {
  Json j = FittedParamsJson(f.params);
  j["rms_um"] = f.rms_um;
  j["max_um"] = f.max_um;
  j["num_points"] = f.num_points;
  j["num_failed"] = f.num_failed;
  j["converged"] = f.converged;
  j["center_in_housing_mm"] = VecJson(f.center_in_housing_mm);
  j["rotation_deg"] = VecJson(f.rotation_deg);
  return j;
}

std::vector<double> ProfileRadiiMm(const camera::Sensor& s) {
  const double half_diag =
      0.5 * std::hypot(s.width_px - 1.0, s.height_px - 1.0) * s.pixel_pitch_mm;
  std::vector<double> r;
  for (int k = 1; k <= static_cast<int>(std::floor(half_diag)); ++k) r.push_back(k);
  r.push_back(half_diag);
  return r;
}

namespace {
// A camera's parameters under their JSON keys (units: camera::Info(model)).
Json CameraParamsJson(const camera::Camera& c) {
  Json j;
  const camera::ModelInfo& info = c.info();
  for (int i = 0; i < info.num_params; ++i) j[std::string(info.params[i].json_key)] = c.params[i];
  return j;
}
}  // namespace

Json CameraFitJson(const CameraFit& f) {
  Json j = CameraParamsJson(f.camera);
  j["rms_px"] = f.rms_px;
  j["max_px"] = f.max_px;
  j["num_points"] = f.num_points;
  j["num_failed"] = f.num_failed;
  j["converged"] = f.converged;
  j["pose"] = {{"center_in_housing_mm", VecJson(f.center_in_housing_mm)}, {"rotation_deg", VecJson(f.rotation_deg)}};
  return j;
}

Json PredictionJson(const Prediction& p) {
  Json j;
  const housing::FocusSetting& f = p.focus;
  j["focus"] = {{"object_distance_mm", p.object_distance_mm}, {"wd_mm", p.wd_mm},
                {"virtual_image_d_s2ep_mm", f.d_s2ep_mm}, {"focus_scale_fd_mm", f.focus_distance_mm.value_or(NAN)},
                {"d_ep2f_mm", f.ep_to_flange_mm}, {"ep_in_housing_mm", VecJson(f.ep_in_housing_mm)}};
  j["camera"] = camera::BrownToJson(p.camera.lens);
  j["camera"]["width_px"] = p.camera.sensor.width_px;
  j["camera"]["height_px"] = p.camera.sensor.height_px;
  j["camera"]["pixel_pitch_mm"] = p.camera.sensor.pixel_pitch_mm;
  j["distances_mm"] = Distances(p.options);
  j["grid"] = {{"cols", p.options.grid_cols}, {"rows", p.options.grid_rows}};
  j["free_rotation"] = p.options.free_rotation;
  j["warnings"] = p.warnings;
  const FitView water = p.water_view(), air = p.air_view();
  j["model"] = water.model_name();
  j["c_ratio_water_air"] = water.c_mm() / air.c_mm();
  Json profile = Json::array();
  for (double r : ProfileRadiiMm(p.camera.sensor)) {
    const double w = 1000 * water.RadialProfileMm(r), a = 1000 * air.RadialProfileMm(r);
    Json row = {{"r_mm", r}, {"water_um", Number(w)}, {"air_um", Number(a)}, {"change_um", Number(w - a)}};
    if (const auto dec = water.DecentringProfileMm(r)) row["decentring_water_um"] = 1000 * *dec;
    profile.push_back(row);
  }
  j["radial_profile"] = profile;
  if (p.water_fisheye) {
    // The fitted model's parameters in pixels; the profiles above are against the lens's own
    // projection at the fitted focal length (FitView).
    j["lens_projection"] = camera::ProjectionName(p.lens_projection);
    j["water"] = CameraFitJson(*p.water_fisheye);
    j["air"] = CameraFitJson(*p.air_fisheye);
    if (p.predicted_water_fisheye) {
      // The in-air calibration + (water − air), parameter by parameter (units: camera::Info(model)).
      for (const auto& [key, cam] : {std::pair{"air_calibration", &*p.air_fisheye_calibration},
                                     {"predicted_water", &*p.predicted_water_fisheye}}) {
        j[key] = CameraParamsJson(*cam);
        j[key]["model"] = cam->model_name();
      }
      j["air_calibration_taken_as"] = kAirCalibrationTakenAs;
    }
    return j;
  }
  j["water"] = FitJson(p.water);
  j["air"] = FitJson(p.air);
  j["change"] = FittedParamsJson(p.change);
  if (p.predicted_water) {
    j["predicted_water"] = FittedParamsJson(*p.predicted_water);
    j["air_calibration_taken_as"] = kAirCalibrationTakenAs;
  }
  Json units = FitUnitsJson();
  units["rms_um"] = "um";
  units["max_um"] = "um";
  j["units"] = units;
  return j;
}

Json SweepJson(const std::vector<SweepRow>& rows, int axis, const std::vector<double>& radii) {
  Json out = Json::array();
  for (const SweepRow& r : rows) {
    const FitView water = r.water_view(), air = r.air_view();
    Json row = {{"axis", AxisName(axis)},
                {"offset_mm", r.offset_mm},
                {"dc_mm", water.c_mm() - air.c_mm()},
                {"c_ratio_water_air", water.c_mm() / air.c_mm()}};
    for (double rad : radii) {
      row[RadiusKey(rad)] = Number(1000 * (water.RadialProfileMm(rad) - air.RadialProfileMm(rad)));
    }
    row["rms_water_um"] = water.rms_um();
    row["water"] = r.water_fisheye ? CameraFitJson(*r.water_fisheye) : FitJson(r.water);
    row["air"] = r.air_fisheye ? CameraFitJson(*r.air_fisheye) : FitJson(r.air);
    out.push_back(row);
  }
  return out;
}

std::string SweepCsv(const std::vector<SweepRow>& rows, int axis,
                     const std::vector<double>& radii) {
  const bool brown = rows.empty() || !rows.front().water_fisheye;
  std::string s = fmt::format(
      "# porthole simulate: entrance-pupil offset along {} (mm) vs the fitted water and air "
      "calibrations ({}); dr_change = water - air radial profile\n",
      AxisName(axis), rows.empty() ? "brown" : rows.front().water_view().model_name());
  s += "offset_mm,dc_mm,c_ratio_water_air";
  for (double r : radii) s += "," + RadiusKey(r);
  s += brown ? ",c_water_mm,x0_water_mm,y0_water_mm,K1_water,K2_water,K3_water,P1_water,P2_water,"
               "rms_water_um,c_air_mm,K1_air,K2_air,K3_air,rms_air_um\n"
             : ",c_water_mm,rms_water_um,c_air_mm,rms_air_um\n";
  for (const SweepRow& r : rows) {
    const FitView water = r.water_view(), air = r.air_view();
    s += fmt::format("{:.6g},{:.9g},{:.9g}", r.offset_mm, water.c_mm() - air.c_mm(), water.c_mm() / air.c_mm());
    for (double rad : radii) {
      s += fmt::format(",{:.6g}", 1000 * (water.RadialProfileMm(rad) - air.RadialProfileMm(rad)));
    }
    if (!brown) {
      s += fmt::format(",{:.9g},{:.6g},{:.9g},{:.6g}\n", water.c_mm(), water.rms_um(), air.c_mm(), air.rms_um());
      continue;
    }
    const auto& w = r.water.params;
    const auto& a = r.air.params;
    s += fmt::format(",{:.9g},{:.6g},{:.6g},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6g}", w.c_mm,
                     w.x0_mm, w.y0_mm, w.K1, w.K2, w.K3, w.P1, w.P2, r.water.rms_um);
    s += fmt::format(",{:.9g},{:.6e},{:.6e},{:.6e},{:.6g}\n", a.c_mm, a.K1, a.K2, a.K3,
                     r.air.rms_um);
  }
  return s;
}

Json DistanceErrorsJson(const std::vector<DistanceError>& rows) {
  Json out = Json::array();
  for (const DistanceError& e : rows) {
    out.push_back({{"distance_mm", e.distance_mm}, {"rms_um", Number(e.rms_um)},
                   {"max_um", e.max_um}, {"num_points", e.num_points}});
  }
  return out;
}

std::string DistanceErrorsCsv(const std::vector<DistanceError>& rows) {
  std::string s =
      "# porthole simulate: reprojection error of the fitted water model at other object "
      "distances from the entrance pupil\ndistance_mm,rms_um,max_um,num_points\n";
  for (const DistanceError& e : rows) {
    s += fmt::format("{:.6g},{:.6g},{:.6g},{}\n", e.distance_mm, e.rms_um, e.max_um, e.num_points);
  }
  return s;
}

Json MapJson(const std::vector<MapPoint>& map) {
  Json out = Json::array();
  auto vec = [](const Eigen::Vector2d& v) {
    return Json{{"dx_um", v.x()}, {"dy_um", v.y()}, {"length_um", v.norm()}};
  };
  for (const MapPoint& m : map) {
    out.push_back({{"x_mm", m.x_mm}, {"y_mm", m.y_mm}, {"u_px", m.u_px}, {"v_px", m.v_px},
                   {"water", vec(m.water_um)}, {"air", vec(m.air_um)},
                   {"difference", vec(m.difference_um)}, {"residual_um", Number(m.residual_um)}});
  }
  return out;
}

std::string MapCsv(const std::vector<MapPoint>& map) {
  std::string s =
      "# porthole simulate: correction vectors (um, image x right / y up; ideal - measured) of the "
      "water and air fits, their difference (water - air) and the water fit's residual, on the fit grid\n"
      "x_mm,y_mm,u_px,v_px,water_dx_um,water_dy_um,water_um,air_dx_um,air_dy_um,air_um,"
      "diff_dx_um,diff_dy_um,diff_um,residual_um\n";
  for (const MapPoint& m : map) {
    s += fmt::format("{:.6f},{:.6f},{:.3f},{:.3f}", m.x_mm, m.y_mm, m.u_px, m.v_px);
    for (const Eigen::Vector2d& v : {m.water_um, m.air_um, m.difference_um}) {
      s += fmt::format(",{:.6g},{:.6g},{:.6g}", v.x(), v.y(), v.norm());
    }
    s += fmt::format(",{:.6g}\n", m.residual_um);
  }
  return s;
}

}  // namespace porthole::simulate
