// Python bindings of undistort/ (docs/undistort.md, docs/python.md): undistort() runs `porthole
// undistort` (undistort::Run) and returns undistort.json's content.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "porthole/undistort/run.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {

void RegisterUndistort(py::module_& m) {
  m.def(
      "undistort",
      [](const py::object& calibration, const py::object& images, const py::object& out,
         std::optional<double> alpha, bool keep_focal, const py::object& wd_mm,
         const std::string& interpolation, int threads, bool force, bool progress) {
        const auto path = [](const py::object& o) {
          return py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>();
        };
        undistort::RunOptions ro;
        ro.calibration = path(calibration);
        ro.images = path(images);
        ro.out = path(out);
        ro.undistort.alpha = alpha;
        ro.undistort.keep_focal = keep_focal;
        ro.undistort.threads = threads;
        ro.undistort.interpolation =
            undistort::InterpolationFromName(interpolation, "interpolation");
        if (py::isinstance<py::str>(wd_mm)) {
          ro.undistort.wd_mm = undistort::ParseWd(wd_mm.cast<std::string>(), "wd_mm");
        } else if (!wd_mm.is_none()) {
          if (py::isinstance<py::float_>(wd_mm) || py::isinstance<py::int_>(wd_mm)) {
            ro.undistort.wd_mm = {wd_mm.cast<double>()};
          } else {
            ro.undistort.wd_mm = wd_mm.cast<std::vector<double>>();
          }
        }
        ro.force = force;
        if (progress)
          ro.progress = [](const std::string& line) {
            py::print(line, py::arg("file") = py::module_::import("sys").attr("stderr"));
          };
        nlohmann::ordered_json summary;
        if (progress) {
          summary =
              undistort::Run(ro);  // the progress callback prints through Python: keep the GIL
        } else {
          py::gil_scoped_release release;
          summary = undistort::Run(ro);
        }
        return JsonToPython(summary);
      },
      py::arg("calibration"), py::arg("images"), py::arg("out"), py::kw_only(),
      py::arg("alpha") = py::none(), py::arg("keep_focal") = false, py::arg("wd_mm") = py::none(),
      py::arg("interpolation") = "linear", py::arg("threads") = 0, py::arg("force") = false,
      py::arg("progress") = false,
      "Remap a folder of images to a virtual pinhole (`porthole undistort`): calibration (any "
      "format porthole "
      "reads, or the refractive JSON of calibrate --port), images (folder), out (folder); alpha in "
      "[0, 1] as "
      "cv2.getOptimalNewCameraMatrix (default 0) or keep_focal; wd_mm behind a port (required "
      "there): a distance, "
      "(near, far) or 'near:far' in mm from the port's vertex; interpolation nearest, linear, "
      "cubic or lanczos. "
      "Writes what the CLI writes and returns undistort.json's content.");
}

}  // namespace porthole::python
