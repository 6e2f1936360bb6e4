// Python binding of interop/convert.h (docs/interop.md, docs/python.md): convert() runs `porthole
// convert` (interop::Convert) and returns what `porthole convert --json` prints, with the files
// written (out_files) and the plausibility warnings of the options (warnings).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "porthole/interop/convert.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

std::string Path(const py::handle& o) { return py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>(); }

// A path, or "" for None.
std::string OptionalPath(const py::object& o) { return o.is_none() ? std::string() : Path(o); }

}  // namespace

void RegisterConvert(py::module_& m) {
  m.def(
      "convert",
      [](const py::object& inputs, const py::object& out, std::optional<std::string> to,
         std::optional<double> pixel_pitch_mm, int camera_id, const py::object& port, const py::object& port_out,
         std::optional<double> water_index, std::optional<std::string> length_unit,
         std::optional<std::pair<int, int>> image_size_px, bool force) {
        interop::ConvertOptions o;
        if (py::isinstance<py::str>(inputs) || py::hasattr(inputs, "__fspath__")) {
          o.inputs.push_back(Path(inputs));
        } else {
          for (const py::handle& i : inputs) o.inputs.push_back(Path(i));
        }
        o.out = Path(out);
        o.to = std::move(to);
        o.pixel_pitch_mm = pixel_pitch_mm;
        o.camera_id = camera_id;
        o.port = OptionalPath(port);
        o.port_out = OptionalPath(port_out);
        o.water_index = water_index;
        o.length_unit = length_unit.value_or("");
        o.image_size_px = image_size_px;
        o.force = force;
        o.words = [](std::string_view text) {  // `water_index` → water_index=
          return RenameQuotedFieldsBy([](std::string_view) { return std::optional<std::string>(); }, text, "=");
        };
        interop::ConvertResult r;
        {
          py::gil_scoped_release release;
          r = interop::Convert(o);
        }
        nlohmann::ordered_json j = interop::ConvertJson(r);
        if (r.rig) {  // `pixel_pitch_mm` → pixel_pitch_mm=
          j["pitch"] = RenameQuotedFieldsBy([](std::string_view) { return std::optional<std::string>(); },
                                            j["pitch"].get<std::string>(), "=");
        }
        j["out_files"] = r.out_files;
        j["warnings"] = r.warnings;
        return JsonToPython(j);
      },
      py::arg("inputs"), py::arg("out"), py::kw_only(), py::arg("to") = py::none(),
      py::arg("pixel_pitch_mm") = py::none(), py::arg("camera_id") = 0, py::arg("port") = py::none(),
      py::arg("port_out") = py::none(), py::arg("water_index") = py::none(), py::arg("length_unit") = py::none(),
      py::arg("image_size_px") = py::none(), py::arg("force") = false,
      "Convert a calibration (or a rig) between file formats, as `porthole convert`: inputs (one path, or "
      "several written into one COLMAP cameras.txt/.bin; a rig file, or one ROS camera_info per camera), out "
      "(the file to write; an existing directory: its COLMAP cameras.txt); to: the output format (json, "
      "opencv-yaml, opencv-xml, colmap, colmap-bin, mrcal, metashape, calibmar; rigs: opencv-stereo, "
      "opencv-stereo-xml, viame-npz, ros-camera-info, kalibr; default from out's extension); pixel_pitch_mm for "
      "inputs without one (else pixels are mm); camera_id of a COLMAP file holding several; port (a preset or "
      "TOML) and water_index: the housing a calibmar or COLMAP cameras.txt output gets; port_out: where a "
      "calibmar or refractive COLMAP input's housing is written as a port TOML; length_unit (mm, cm, m) and "
      "image_size_px (width, height) for rig files that lack them; force: replace an existing out. Returns "
      "what `porthole convert --json` prints, with out_files and warnings.");
}

}  // namespace porthole::python
