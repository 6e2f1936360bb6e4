#pragma once

#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

#include "porthole/calib/result_json.h"
#include "porthole/core/field_names.h"
#include "porthole/interop/interop.h"
#include "porthole/catalogue/lookup.h"
#include "porthole/catalogue/presets.h"
#include "porthole/materials/materials.h"
#include "porthole/planning/focus.h"
#include "porthole/ports/environment.h"

namespace porthole::python {

// JSON to Python (dicts, lists, numbers; infinite lengths stay the strings "inf" of the CLI's JSON,
// which the package turns into math.inf) and back, through Python's json module.
template <typename J>
pybind11::object JsonToPython(const J& j) {
  return pybind11::module_::import("json").attr("loads")(j.dump());
}
inline nlohmann::json PythonToJson(const pybind11::handle& o) {
  return nlohmann::json::parse(pybind11::module_::import("json").attr("dumps")(o).template cast<std::string>());
}

// A calibration given as a file path (any format of docs/interop.md, read as the CLI reads it:
// interop::ReadCalibrationFileAs) or as a dict (calibrate()'s JSON), as a camera of `model`;
// nullopt for None.
inline std::optional<calib::CalibrationRecord> CalibrationArg(const pybind11::object& arg, double pitch_mm,
                                                              camera::CameraModelId model,
                                                              const std::string& field) {
  if (arg.is_none()) return std::nullopt;
  if (pybind11::isinstance<pybind11::str>(arg) || pybind11::hasattr(arg, "__fspath__")) {
    const std::string path = pybind11::str(pybind11::module_::import("os").attr("fspath")(arg));
    return interop::ReadCalibrationFileAs(path, pitch_mm, model, field).calibration;
  }
  if (!pybind11::isinstance<pybind11::dict>(arg)) throw InvalidInput(field, "a file path or a calibration dict");
  return interop::ConvertCalibration(calib::CalibrationFromJson(PythonToJson(arg), field), model, field);
}

// The water a port works in, from the keyword arguments every binding accepts (one place, so the
// bindings cannot drift apart). Validation happens where the indices are resolved.
inline ports::Environment MakeEnvironment(const std::string& water, std::optional<double> water_index,
                                          std::optional<double> glass_index, double lambda_nm,
                                          double temperature_c, double salinity_psu,
                                          double pressure_dbar, bool extrapolate = false) {
  // An unknown water is named by its keyword (the library says "medium", which may be the glass).
  WithFieldNames({{"medium", "water"}}, [&] { materials::ModelOf(water); });
  ports::Environment env;
  env.water = water;
  env.water_index = water_index;
  env.glass_index = glass_index;
  env.conditions.lambda_nm = lambda_nm;
  env.conditions.temperature_c = temperature_c;
  env.conditions.salinity_psu = salinity_psu;
  env.conditions.pressure_dbar = pressure_dbar;
  env.conditions.extrapolate = extrapolate;
  return env;
}

// The camera body and lens from the keyword arguments every planning binding accepts (presets,
// files, then lensfun names; one place, as MakeEnvironment).
inline catalogue::CameraAndLens FindCameraAndLens(const std::string& camera, const std::string& lens,
                                           std::optional<double> pixel_pitch_mm,
                                           std::optional<double> focal_mm, const catalogue::LensData& lens_data = {}) {
  catalogue::CameraLensQuery q;
  q.camera = camera;
  q.lens = lens;
  q.pixel_pitch_mm = pixel_pitch_mm;
  q.focal_length_mm = focal_mm;
  q.lens_data = lens_data;
  return catalogue::FindCameraAndLens(q);
}

// The housed camera of plan, flat and report from their keyword arguments.
inline planning::Setup MakeSetup(const std::string& camera, const std::string& lens, const std::string& port,
                                 const std::string& water, std::optional<double> water_index, double lambda_nm,
                                 double temperature_c, double salinity_psu, double pressure_dbar,
                                 std::optional<double> pixel_pitch_mm, std::optional<double> focal_mm,
                                 const catalogue::LensData& lens_data = {}) {
  const catalogue::CameraAndLens cl = FindCameraAndLens(camera, lens, pixel_pitch_mm, focal_mm, lens_data);
  planning::Setup s;
  s.camera = cl.camera;
  s.lens = cl.lens;
  s.port = catalogue::LoadPort(port);
  s.env = MakeEnvironment(water, water_index, std::nullopt, lambda_nm, temperature_c, salinity_psu,
                          pressure_dbar);
  return s;
}

void RegisterMaterials(pybind11::module_& m);
void RegisterPorts(pybind11::module_& m);
void RegisterCalib(pybind11::module_& m);
void RegisterPlanning(pybind11::module_& m);
void RegisterSimulate(pybind11::module_& m);
void RegisterFit(pybind11::module_& m);
void RegisterReport(pybind11::module_& m);
void RegisterMeasure(pybind11::module_& m);
void RegisterUndistort(pybind11::module_& m);
void RegisterConvert(pybind11::module_& m);
void RegisterRender(pybind11::module_& m);

}  // namespace porthole::python
