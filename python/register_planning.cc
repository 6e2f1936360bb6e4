// porthole.plan() and porthole.flat(): the dive plan and the flat-port analysis as dicts, from the
// same JSON serialisation as `porthole plan --json` and `porthole flat --json` (field names with
// units; infinite lengths as "inf").
#include <pybind11/stl.h>

#include <limits>

#include "porthole/core/field_names.h"
#include "porthole/planning/json.h"
#include "porthole/lens/lens.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
void RegisterPlanning(py::module_& m) {
  m.def(
      "plan",
      [](const std::string& camera, const std::string& lens, const std::string& port, std::optional<double> wd_mm,
         std::optional<double> subject_distance_mm, std::optional<double> f_number, std::optional<double> coc_mm,
         const std::string& water, std::optional<double> water_index, double lambda_nm, double temperature_c,
         double salinity_psu, double pressure_dbar, std::optional<double> pixel_pitch_mm,
         std::optional<double> focal_mm, std::optional<double> min_focus_mm, std::optional<double> pupil_mm) {
        return WithFieldNames({{"focal_length_mm", "focal_mm"}, {"port", "port"}}, [&] {
          const planning::Setup s = MakeSetup(camera, lens, port, water, water_index, lambda_nm, temperature_c,
                                              salinity_psu, pressure_dbar, pixel_pitch_mm, focal_mm,
                                              {min_focus_mm, pupil_mm});
          planning::PlanOptions o;
          o.wd_mm = wd_mm;
          o.subject_distance_mm = subject_distance_mm;
          o.f_number = f_number.value_or(lens::DefaultFNumber(s.lens));  // f/8, or the nearest the lens has
          o.coc_mm = coc_mm;
          o.lambda_nm = lambda_nm;
          return JsonToPython(planning::PlanToJson(s, planning::MakePlan(s, o)));
        });
      },
      py::kw_only(), py::arg("camera") = "nikon-d300", py::arg("lens") = "",
      py::arg("port") = "nimar-ni320", py::arg("wd_mm") = py::none(), py::arg("subject_distance_mm") = py::none(),
      py::arg("f_number") = py::none(), py::arg("coc_mm") = py::none(), py::arg("water") = "seawater",
      py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07, py::arg("temperature_c") = 20.0,
      py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0, py::arg("pixel_pitch_mm") = py::none(),
      py::arg("focal_mm") = py::none(), py::arg("min_focus_mm") = py::none(), py::arg("pupil_mm") = py::none(),
      "Dive plan (as `porthole plan --json`): focus, minimum WD, close-up lenses, depth of field, FOV, GSD.");
  m.def(
      "flat",
      [](const std::string& camera, const std::string& lens, const std::string& port, double wd_mm,
         const std::string& water, std::optional<double> water_index, double lambda_nm, double temperature_c,
         double salinity_psu, double pressure_dbar, std::optional<double> pixel_pitch_mm,
         std::optional<double> focal_mm, std::optional<double> min_focus_mm, std::optional<double> pupil_mm) {
        return WithFieldNames({{"focal_length_mm", "focal_mm"}, {"port", "port"}}, [&] {
          const planning::Setup s = MakeSetup(camera, lens, port, water, water_index, lambda_nm, temperature_c,
                                              salinity_psu, pressure_dbar, pixel_pitch_mm, focal_mm,
                                              {min_focus_mm, pupil_mm});
          planning::FlatOptions o;
          o.wd_mm = wd_mm;
          return JsonToPython(planning::FlatToJson(s, planning::AnalyseFlat(s, o)));
        });
      },
      py::kw_only(), py::arg("camera") = "nikon-d300", py::arg("lens") = "",
      py::arg("port") = "flat-acrylic-10mm", py::arg("wd_mm") = std::numeric_limits<double>::infinity(),
      py::arg("water") = "seawater", py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0,
      py::arg("pixel_pitch_mm") = py::none(), py::arg("focal_mm") = py::none(), py::arg("min_focus_mm") = py::none(),
      py::arg("pupil_mm") = py::none(),
      "Flat-port analysis (as `porthole flat --json`): FOV, maximum FOV, Eq. 1 table, lateral colour.");
}

}  // namespace porthole::python
