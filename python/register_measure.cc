// Python bindings of measure/ (docs/python.md): measure() over a rig (file or dict) and image points
// (a CSV file, (frame, camera, id, u_px, v_px) tuples, or detections per camera).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <optional>
#include <tuple>

#include "porthole/calib/detections_json.h"
#include "porthole/core/input.h"
#include "porthole/lens/lens.h"
#include "porthole/measure/measure.h"
#include "porthole/housing/plausible.h"
#include "porthole/measure/plan_rig.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {

void RegisterPlanRig(py::module_& m);

void RegisterMeasure(py::module_& m) {
  RegisterPlanRig(m);
  m.def(
      "measure",
      [](const py::object& rig, const py::object& points, const std::vector<std::pair<int, int>>& lengths,
         double sigma_px, bool calibration_sigma, bool skip_unpaired, int threads,
         std::optional<std::tuple<int, int, double>> scale_bar, std::optional<std::vector<double>> plane,
         std::optional<double> range_mm, double plane_sigma_mm, const std::string& camera,
         std::optional<std::tuple<int, int, double>> laser_pair) {
        return WithFieldNames({{"points", "points"}, {"lengths", "lengths"}, {"sigma_px", "sigma_px"},
                               {"skip_unpaired", "skip_unpaired"}, {"plane_camera", "camera"},
                               {"laser_pair", "laser_pair"}, {"range_mm", "range_mm"}},
                              [&] {
          const auto is_path = [](const py::object& o) {
            return py::isinstance<py::str>(o) || py::hasattr(o, "__fspath__");
          };
          const auto path_of = [](const py::object& o) {
            return py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>();
          };
          const bool one_camera = plane.has_value() || range_mm.has_value() || laser_pair.has_value();
          if (!one_camera && !camera.empty()) throw InvalidInput("camera", "goes with plane or range_mm");
          if (!one_camera) measure::SetOneCamera(nullptr, plane, range_mm, std::nullopt, plane_sigma_mm);
          measure::Rig r;
          if (is_path(rig)) {
            r = one_camera ? measure::LoadCamera(path_of(rig), "rig") : measure::LoadRig(path_of(rig), "rig");
          } else if (py::isinstance<py::dict>(rig)) {
            r = one_camera ? measure::CameraFromJson(PythonToJson(rig), "rig") : measure::RigFromJson(PythonToJson(rig), "rig");
          } else {
            throw InvalidInput("rig", "a rig JSON file or calibrate_rig()'s dict");
          }
          std::vector<measure::ImagePoint> pts;
          if (is_path(points)) {
            const std::string path = path_of(points);
            pts = measure::ParsePointsCsv(ReadInputFile(path, "points"), r, "points", path);
          } else if (py::isinstance<py::list>(points) || py::isinstance<py::tuple>(points)) {
            const py::sequence seq = points.cast<py::sequence>();
            const bool per_camera = seq.size() > 0 && (py::isinstance<py::list>(seq[0]) && !py::isinstance<py::str>(seq[0]) &&
                                                       py::len(seq[0]) > 0 && py::isinstance<py::dict>(seq[0].cast<py::list>()[0]));
            if (per_camera) {  // detections per camera, in the rig's order
              if (seq.size() != r.cameras.size()) {
                throw InvalidInput("points", fmt::format("{} detection lists for the rig's {} cameras: one per camera, "
                                                         "in the rig's order", seq.size(), r.cameras.size()));
              }
              for (std::size_t k = 0; k < seq.size(); ++k) {
                std::vector<calib::ImageDetections> dets;
                const py::list l = seq[k].cast<py::list>();
                for (std::size_t i = 0; i < l.size(); ++i) {
                  dets.push_back(calib::DetectionsFromJson(PythonToJson(l[i]), fmt::format("points[{}][{}]", k, i)));
                }
                const auto got = measure::PointsFromDetections(dets, static_cast<int>(k), fmt::format("points[{}]", k));
                pts.insert(pts.end(), got.begin(), got.end());
              }
            } else {  // (frame, camera, id, u_px, v_px) tuples
              for (std::size_t i = 0; i < seq.size(); ++i) {
                const py::sequence t = seq[i].cast<py::sequence>();
                if (t.size() != 5) {
                  throw InvalidInput("points", fmt::format("points[{}]: (frame, camera, id, u_px, v_px), not {} values",
                                                           i, t.size()));
                }
                measure::ImagePoint p;
                p.where = fmt::format("points[{}]", i);
                p.frame = py::str(t[0]).cast<std::string>();
                p.camera = measure::CameraIndex(r, py::str(t[1]).cast<std::string>(), "points");
                p.id = t[2].cast<int>();
                if (p.id < 0) throw InvalidInput("points", p.where + ": id must be >= 0");
                p.pixel_px = Eigen::Vector2d(t[3].cast<double>(), t[4].cast<double>());
                if (!p.pixel_px.allFinite()) throw InvalidInput("points", p.where + ": u_px, v_px must be finite");
                pts.push_back(p);
              }
            }
          } else {
            throw InvalidInput("points", "a CSV file, (frame, camera, id, u_px, v_px) tuples, or detections per camera");
          }
          measure::MeasureOptions o;
          if (one_camera) {
            std::optional<std::vector<double>> lp;
            if (laser_pair) {
              const auto [a, b, sep] = *laser_pair;
              lp = std::vector<double>{static_cast<double>(a), static_cast<double>(b), sep};
            }
            measure::SetOneCamera(&o, plane, range_mm, lp, plane_sigma_mm);
            o.plane_camera = camera.empty() ? 0 : measure::CameraIndex(r, camera, "camera");
          }
          o.sigma_px = sigma_px;
          o.calibration_sigma = calibration_sigma;
          o.skip_unpaired = skip_unpaired;
          o.lengths = lengths;
          if (scale_bar) o.lengths.push_back({std::get<0>(*scale_bar), std::get<1>(*scale_bar)});
          o.num_threads = threads;
          if (sigma_px < 0 || !std::isfinite(sigma_px)) throw InvalidInput("sigma_px", "must be a positive number of pixels");
          measure::MeasureResult res;
          {
            py::gil_scoped_release release;
            res = measure::Measure(r, pts, o);
          }
          auto j = measure::MeasureToJson(res, r);
          if (scale_bar) {
            j["measure"]["scale_bar"] = measure::ScaleBarToJson(measure::CheckScaleBar(
                res, {std::get<0>(*scale_bar), std::get<1>(*scale_bar), std::get<2>(*scale_bar)}));
          }
          return JsonToPython(j);
        });
      },
      py::arg("rig"), py::arg("points"), py::kw_only(), py::arg("lengths") = std::vector<std::pair<int, int>>{},
      py::arg("sigma_px") = 0.0, py::arg("calibration_sigma") = true, py::arg("skip_unpaired") = false,
      py::arg("threads") = 0, py::arg("scale_bar") = py::none(), py::arg("plane") = py::none(),
      py::arg("range_mm") = py::none(), py::arg("plane_sigma_mm") = 0.0, py::arg("camera") = "",
      py::arg("laser_pair") = py::none(),
      "3-D points and lengths through a calibrated rig (`porthole measure`). rig: a rig JSON file or "
      "calibrate_rig().to_dict(); points: a CSV file frame,camera,id,u_px,v_px, a list of (frame, camera, id, "
      "u_px, v_px) tuples (camera by name or index), or one list of detections per camera in the rig's order; "
      "lengths: (id_a, id_b) pairs; sigma_px: the points' image sigma (0: the rig's sigma0); scale_bar: (id_a, id_b, length_mm), the check of `--scale-bar`; plane (nx, ny, nz, d_mm) or range_mm with plane_sigma_mm and camera: one camera and a known plane (`--plane`; rig may then be one camera's calibration); laser_pair (id_a, id_b, separation_mm): each frame's range from a laser scaler's dots (`--laser-pair`). Returns the JSON of "
      "`porthole measure --json`.");
}

void RegisterPlanRig(py::module_& m) {
  m.def(
      "plan_rig",
      [](const py::object& rig, std::optional<double> baseline_mm, double convergence_deg, const std::string& camera,
         const std::string& lens, const std::string& port, const std::string& water, std::optional<double> water_index,
         double lambda_nm, double temperature_c, double salinity_psu, double pressure_dbar,
         std::optional<double> pixel_pitch_mm, std::optional<double> focal_mm, std::optional<double> f_number,
         double sigma_px, double length_mm, const std::vector<double>& ranges_mm, double central_range_mm,
         int threads) {
        return WithFieldNames({{"central_fit_range_mm", "central_range_mm"}, {"focal_length_mm", "focal_mm"}}, [&] {
          if (rig.is_none() == !baseline_mm.has_value()) {
            throw InvalidInput("rig", "give a rig (a rig JSON file or calibrate_rig()'s dict) or baseline_mm (two of "
                                      "the camera behind the port), not both");
          }
          measure::Rig r;
          std::string what;
          std::vector<std::string> warnings;  // a described rig's camera, lens and port, as the CLI says them
          if (!rig.is_none()) {
            if (py::isinstance<py::str>(rig) || py::hasattr(rig, "__fspath__")) {
              const std::string path = py::str(py::module_::import("os").attr("fspath")(rig)).cast<std::string>();
              r = measure::LoadRig(path, "rig");
              what = fmt::format("{} cameras ({})", r.cameras.size(), path);
            } else {
              r = measure::RigFromJson(PythonToJson(rig), "rig");
              what = fmt::format("{} cameras", r.cameras.size());
            }
          } else {
            const planning::Setup s = MakeSetup(camera, lens, port, water, water_index, lambda_nm, temperature_c,
                                                salinity_psu, pressure_dbar, pixel_pitch_mm, focal_mm);
            warnings = housing::PlausibilityWarnings(s);
            r = measure::DescribedRig(s, *baseline_mm, convergence_deg, central_range_mm > 0 ? central_range_mm : 1500,
                                      f_number.value_or(lens::DefaultFNumber(s.lens)), &what);
          }
          measure::RigPlanOptions o;
          o.sigma_px = sigma_px;
          o.length_mm = length_mm;
          if (!ranges_mm.empty()) o.ranges_mm = ranges_mm;
          o.central_fit_range_mm = central_range_mm;
          o.num_threads = threads;
          if (!(central_range_mm >= 0)) throw InvalidInput("central_range_mm", "must be >= 0 mm (0: no comparison)");
          measure::RigPlan p;
          {
            py::gil_scoped_release release;
            p = measure::PlanRig(r, o);
          }
          return JsonToPython(nlohmann::ordered_json{{"rig_plan", measure::RigPlanToJson(p, what)["rig_plan"]},
                                                     {"warnings", warnings}});
        });
      },
      py::kw_only(), py::arg("rig") = py::none(), py::arg("baseline_mm") = py::none(), py::arg("convergence_deg") = 0.0,
      py::arg("camera") = "nikon-d300", py::arg("lens") = "", py::arg("port") = "nimar-ni320",
      py::arg("water") = "seawater", py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0,
      py::arg("pixel_pitch_mm") = py::none(), py::arg("focal_mm") = py::none(), py::arg("f_number") = py::none(),
      py::arg("sigma_px") = 0.3, py::arg("length_mm") = 300.0, py::arg("ranges_mm") = std::vector<double>{},
      py::arg("central_range_mm") = 1500.0, py::arg("threads") = 0,
      "Plan a rig (`porthole plan --rig` / `--baseline`): the sigma of a length over the common field at each range "
      "and a central model's error. Returns the JSON of `porthole plan --rig --json` with warnings: the plausibility "
      "warnings of a described rig's camera, lens and port.");
}

}  // namespace porthole::python
