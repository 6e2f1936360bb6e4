// porthole's report from Python: the same page, figures and report.json as `porthole report`,
// written whole into `out` or not at all; returns the summary of `porthole report --json`.
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include "porthole/core/field_names.h"
#include "porthole/report/report.h"
#include "porthole/lens/lens.h"
#include "porthole/housing/plausible.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {

void RegisterReport(py::module_& m) {
  m.def(
      "report",
      [](const std::string& out, const std::string& camera, const std::string& lens, const std::string& port,
         const std::string& compare_port, const std::string& water, std::optional<double> water_index,
         double lambda_nm, double temperature_c, double salinity_psu, double pressure_dbar,
         double subject_distance_mm, std::optional<double> f_number, std::optional<double> coc_mm,
         const py::object& air_calibration, const py::object& water_calibration, bool force,
         std::optional<double> pixel_pitch_mm, std::optional<double> focal_mm, std::optional<double> min_focus_mm,
         std::optional<double> pupil_mm) {
        return WithFieldNames({{"focal_length_mm", "focal_mm"}, {"port", "port"}, {"out", "out"}}, [&] {
          report::ReportInputs in;
          in.setup = MakeSetup(camera, lens, port, water, water_index, lambda_nm, temperature_c, salinity_psu,
                               pressure_dbar, pixel_pitch_mm, focal_mm, {min_focus_mm, pupil_mm});
          // Chosen to fit the camera, as the CLI does (a fixed-focus action camera behind a flat port gets a
          // dome it can focus through).
          in.other_port = WithFieldNames({{"port", "compare_port"}}, [&] {
            return catalogue::LoadPort(compare_port.empty() ? report::ChooseOtherPort(in.setup, subject_distance_mm).name
                                                     : compare_port);
          });
          in.subject_distance_mm = subject_distance_mm;
          in.f_number = f_number.value_or(lens::DefaultFNumber(in.setup.lens));
          in.coc_mm = coc_mm;
          const double pitch = in.setup.camera.sensor.pixel_pitch_mm;
          in.air_calibration = CalibrationArg(air_calibration, pitch, camera::CameraModelId::kBrown, "air_calibration");
          in.water_calibration =
              CalibrationArg(water_calibration, pitch, camera::CameraModelId::kBrown, "water_calibration");
          in.echo.emplace_back("(Python)", "porthole.report()");
          report::ReportOptions ro;
          ro.out_dir = out;
          ro.force = force;
          report::ReportSummary s;
          {
            py::gil_scoped_release release;
            s = report::WriteReport(in, ro);
          }
          nlohmann::json steps = nlohmann::json::object();
          for (const auto& [name, sec] : s.step_seconds) steps[name] = sec;
          return JsonToPython(nlohmann::ordered_json{{"index_html", s.index_html.string()},
                               {"report_json", (s.index_html.parent_path() / "report.json").string()},
                               {"figures", s.figures},
                               {"step_seconds", steps},
                               {"seconds", s.seconds},
                               // the inputs' plausibility, as `porthole report` prints it on stderr
                               {"warnings", housing::PlausibilityWarnings(in.setup)}});
        });
      },
      py::arg("out"), py::kw_only(), py::arg("camera") = "nikon-d300", py::arg("lens") = "",
      py::arg("port") = "nimar-ni320", py::arg("compare_port") = "", py::arg("water") = "seawater",
      py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07, py::arg("temperature_c") = 20.0,
      py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0, py::arg("subject_distance_mm") = 1000.0,
      py::arg("f_number") = py::none(), py::arg("coc_mm") = py::none(), py::arg("air_calibration") = py::none(),
      py::arg("water_calibration") = py::none(), py::arg("force") = false, py::arg("pixel_pitch_mm") = py::none(),
      py::arg("focal_mm") = py::none(), py::arg("min_focus_mm") = py::none(), py::arg("pupil_mm") = py::none(),
      "Writes the report of a camera-lens-port-water system into the directory `out` (as `porthole "
      "report`): index.html, report.json and the figures. Calibrations are file paths (any format "
      "`porthole convert` reads: porthole JSON, OpenCV YAML, COLMAP, mrcal, Metashape, calibmar) or "
      "calibrate()'s results.");
}

}  // namespace porthole::python
