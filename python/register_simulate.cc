// porthole.simulate(): the underwater calibration to expect behind a port, as a dict with the same
// fields as `porthole simulate --json` (water, air, change, predicted_water, radial_profile, …),
// optionally with a pupil-offset sweep and the distortion map.
#include <pybind11/stl.h>

#include "porthole/camera/json.h"
#include "porthole/core/field_names.h"
#include "porthole/catalogue/lookup.h"
#include "porthole/catalogue/presets.h"
#include "porthole/simulate/report.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
void RegisterSimulate(py::module_& m) {
  m.def(
      "simulate",
      [](const std::string& port, const std::string& camera, const std::string& lens,
         double focus_distance_mm, const std::array<double, 3>& ep_offset_mm,
         std::optional<double> c_mm, const std::optional<py::dict>& air_calibration,
         const std::string& water, std::optional<double> water_index, double lambda_nm,
         double temperature_c, double salinity_psu, int grid_cols, int grid_rows, bool fit_k3,
         bool free_rotation, const std::optional<std::string>& sweep_axis,
         const std::vector<double>& offsets_mm, bool with_map, std::optional<double> pixel_pitch_mm,
         std::optional<double> focal_mm, std::optional<double> min_focus_mm, std::optional<double> pupil_mm) {
        return WithFieldNames({{"subject_distance_mm", "focus_distance_mm"}, {"focal_length_mm", "focal_mm"}, {"port", "port"}}, [&] {
        const catalogue::CameraAndLens cl = FindCameraAndLens(camera, lens, pixel_pitch_mm, focal_mm, {min_focus_mm, pupil_mm});
        simulate::SystemSpec spec;
        spec.port = catalogue::LoadPort(port);
        spec.camera = cl.camera;
        spec.lens = cl.lens;
        spec.env = MakeEnvironment(water, water_index, std::nullopt, lambda_nm, temperature_c,
                                   salinity_psu, /*pressure_dbar=*/0.0);
        spec.object_distance_mm = focus_distance_mm;
        spec.ep_offset_mm = simulate::Vec3(ep_offset_mm[0], ep_offset_mm[1], ep_offset_mm[2]);
        spec.c_mm = c_mm;
        if (air_calibration) {
          const std::string text = py::str(py::module_::import("json").attr("dumps")(*air_calibration));
          spec.air_calibration = camera::LoadBrownJson(text, "air_calibration").value;
        }
        simulate::FitOptions o;
        o.grid_cols = grid_cols;
        o.grid_rows = grid_rows;
        o.fit_k3 = fit_k3;
        o.free_rotation = free_rotation;
        int axis = -1;
        if (sweep_axis) {
          if (*sweep_axis != "x" && *sweep_axis != "y" && *sweep_axis != "z") {
            throw InvalidInput("sweep_axis", "must be 'x', 'y' or 'z'");
          }
          axis = *sweep_axis == "x" ? 0 : *sweep_axis == "y" ? 1 : 2;
        }
        simulate::Json out;
        std::vector<simulate::SweepRow> rows;
        std::vector<simulate::MapPoint> map;
        {
          py::gil_scoped_release release;
          const simulate::Prediction p = simulate::Predict(spec, o);
          out = simulate::PredictionJson(p);
          if (axis >= 0) {
            rows = simulate::SweepPupilOffset(p, axis, offsets_mm);
            const std::vector<double> radii = {5.0, 10.0,
                                               simulate::ProfileRadiiMm(p.camera.sensor).back()};
            out["sweep"] = simulate::SweepJson(rows, axis, radii);
          }
          if (with_map) out["map"] = simulate::MapJson(simulate::DistortionMap(p));
        }
        return JsonToPython(out);
        });
      },
      py::kw_only(), py::arg("port") = "nimar-ni320", py::arg("camera") = "nikon-d300",
      py::arg("lens") = "", py::arg("focus_distance_mm") = 1000.0,
      py::arg("ep_offset_mm") = std::array<double, 3>{0, 0, 0}, py::arg("c_mm") = py::none(),
      py::arg("air_calibration") = py::none(), py::arg("water") = "seawater",
      py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("grid_cols") = 25,
      py::arg("grid_rows") = 17, py::arg("fit_k3") = true, py::arg("free_rotation") = true,
      py::arg("sweep_axis") = py::none(), py::arg("offsets_mm") = std::vector<double>{},
      py::arg("with_map") = false, py::arg("pixel_pitch_mm") = py::none(), py::arg("focal_mm") = py::none(),
      py::arg("min_focus_mm") = py::none(), py::arg("pupil_mm") = py::none(),
      "The central Brown model fitted in water and in air behind a port (dict, units in the keys;\n"
      "Brown coefficients K1..P2 in mm^-n as in 'units'). air_calibration: a dict {c_mm, x0_mm,\n"
      "y0_mm, K1, K2, P1, P2} gives 'predicted_water'. sweep_axis 'x'|'y'|'z' with offsets_mm adds\n"
      "'sweep'; with_map adds the distortion 'map'.");
}

}  // namespace porthole::python
