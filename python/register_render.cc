// Python binding of render/ (docs/render.md, docs/python.md): render() is `porthole render` — one
// library call, render::RenderJob (render/job.h), as the CLI's — with the CLI's defaults: one image
// (out NAME.png and its ground truth NAME.json), a calibration set (set=N: out/water, out/air) or
// every camera of a rig (rig= a rig file or dict, or baseline_mm=; with set=N synchronised frames).
// It returns what `render --json` prints with the plausibility warnings of the housed camera
// (warnings): for one image also its ground truth (ground_truth), for a set or a rig `renders`, one
// entry per image written (camera, medium, frame, files, counts, its ground_truth).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "porthole/core/output.h"
#include "porthole/render/job.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

namespace fs = std::filesystem;

std::string Path(const py::handle& o) { return py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>(); }

// The files among the options (a port, camera or lens TOML, a target field, a calibration): no output
// replaces them.
std::vector<fs::path> InputFiles(const std::vector<std::string>& values) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& v : values) {
    if (!v.empty() && fs::exists(v, ec)) files.emplace_back(v);
  }
  return files;
}

}  // namespace

void RegisterRender(py::module_& m) {
  m.def(
      "render",
      [](const py::object& out, const std::string& target, const py::object& field, const std::string& port,
         const std::string& camera, const std::string& lens, std::optional<double> pixel_pitch_mm,
         std::optional<double> focal_mm, const std::string& water, std::optional<double> water_index,
         double lambda_nm, double temperature_c, double salinity_psu, double pressure_dbar,
         const std::string& medium, double distance_mm, std::array<double, 2> shift_mm,
         std::array<double, 2> tilt_deg, double roll_deg, std::optional<double> focus_distance_mm,
         std::optional<double> f_number, const py::object& camera_model, std::optional<double> c_mm,
         std::vector<double> bands_nm, const std::string& color, int bit_depth, int samples_per_pixel,
         int edge_samples_per_pixel, std::uint64_t seed, double exposure, bool white_on_black, int threads,
         bool force, std::optional<std::array<double, 3>> ep_mm, bool natural_vignetting,
         std::array<double, 3> vignetting_pa, std::optional<std::array<double, 2>> noise_e, const py::object& rig,
         std::optional<double> baseline_mm, double convergence_deg, int set,
         std::optional<std::array<double, 2>> distances_mm, double max_tilt_deg, double min_whole_fraction) {
        render::RenderJobOptions o;
        const bool bare = port == "none";  // the lens alone: the port only places the pupil
        o.housed = MakeSetup(camera, lens, bare ? "nimar-ni320" : port, water, water_index, lambda_nm, temperature_c,
                             salinity_psu, pressure_dbar, pixel_pitch_mm, focal_mm);
        o.bare = bare;
        if (ep_mm) {
          for (const double v : *ep_mm) RequireFinite("ep_mm", v);
          o.housed.ep_in_housing_mm = ports::Vec3((*ep_mm)[0], (*ep_mm)[1], (*ep_mm)[2]);
        }
        o.target = target;
        o.field = field.is_none() ? std::string() : Path(field);
        o.medium = medium;
        o.focus_distance_mm = focus_distance_mm;
        o.f_number = f_number;
        o.natural_vignetting = natural_vignetting;
        o.vignetting_pa = vignetting_pa;
        o.camera_model = camera_model.is_none() ? std::string() : Path(camera_model);
        o.c_mm = c_mm;
        o.bands_nm = bands_nm;
        o.white_on_black = white_on_black;
        o.distance_mm = distance_mm;
        o.shift_mm = {shift_mm[0], shift_mm[1]};
        o.tilt_deg = {tilt_deg[0], tilt_deg[1]};
        o.roll_deg = roll_deg;
        o.render.samples_per_pixel = samples_per_pixel;
        o.render.edge_samples_per_pixel = edge_samples_per_pixel;
        o.render.seed = seed;
        o.render.exposure = exposure;
        o.render.threads = threads;
        o.color = color;
        o.noise_e = noise_e;
        o.bit_depth = bit_depth;
        o.set_count = set;
        o.distances_mm = distances_mm;
        o.max_tilt_deg = max_tilt_deg;
        o.min_whole_fraction = min_whole_fraction;
        std::string rig_path;
        if (!rig.is_none()) {
          if (py::isinstance<py::dict>(rig)) {
            o.rig_json = PythonToJson(rig);
          } else if (py::isinstance<py::str>(rig) || py::hasattr(rig, "__fspath__")) {
            rig_path = o.rig = Path(rig);
          } else {
            throw InvalidInput("rig", "a rig JSON file (any rig format) or calibrate_rig()'s dict");
          }
        }
        o.baseline_mm = baseline_mm;
        if (convergence_deg != 0 && !baseline_mm) throw InvalidInput("convergence_deg", "goes with `baseline_mm`");
        o.convergence_deg = convergence_deg;
        o.out = Path(out);
        o.rules = OutputRules{.force = force,
                              .inputs = InputFiles({port, camera, lens, o.field, o.camera_model, rig_path})};
        o.keep_truth = true;
        std::vector<std::string> notes;
        o.note = [&](const std::string& line) { notes.push_back(line); };
        const bool several = set > 0 || !rig.is_none() || baseline_mm;
        render::RenderJobResult r;
        // The library's fields that are not this function's keywords.
        WithFieldNames({{"count", "set"}, {"near_mm", "distances_mm"}, {"far_mm", "distances_mm"}, {"cameras", "rig"}},
                       [&] {
                         py::gil_scoped_release release;
                         r = render::RenderJob(o);
                       });
        nlohmann::ordered_json j = r.summary;
        std::vector<std::string> warnings = r.warnings;
        for (const std::string& n : notes) warnings.push_back(RenameQuotedFields({}, n));  // `rig` -> rig
        j["warnings"] = warnings;
        if (!several) {
          j["ground_truth"] = r.images.front().ground_truth;
        } else {
          nlohmann::ordered_json renders = nlohmann::ordered_json::array();
          for (const render::JobImage& image : r.images) {
            nlohmann::ordered_json e = {{"camera", image.camera}, {"medium", image.medium}, {"frame", image.frame}};
            for (const auto& [key, value] : image.summary.items()) {
              if (!e.contains(key)) e[key] = value;
            }
            e["ground_truth"] = image.ground_truth;
            renders.push_back(std::move(e));
          }
          j["renders"] = std::move(renders);
        }
        return JsonToPython(j);
      },
      py::arg("out"), py::kw_only(), py::arg("target") = "chessboard:9x6:40", py::arg("field") = py::none(),
      py::arg("port") = "nimar-ni320", py::arg("camera") = "nikon-d300", py::arg("lens") = "",
      py::arg("pixel_pitch_mm") = py::none(), py::arg("focal_mm") = py::none(), py::arg("water") = "seawater",
      py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07, py::arg("temperature_c") = 20.0,
      py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0, py::arg("medium") = "water",
      py::arg("distance_mm") = 1000.0, py::arg("shift_mm") = std::array<double, 2>{0, 0},
      py::arg("tilt_deg") = std::array<double, 2>{0, 0}, py::arg("roll_deg") = 0.0,
      py::arg("focus_distance_mm") = py::none(), py::arg("f_number") = py::none(),
      py::arg("camera_model") = py::none(), py::arg("c_mm") = py::none(),
      py::arg("bands_nm") = render::kDefaultBandsNm, py::arg("color") = "grey", py::arg("bit_depth") = 8,
      py::arg("samples_per_pixel") = 16, py::arg("edge_samples_per_pixel") = 0, py::arg("seed") = 1,
      py::arg("exposure") = 1.0, py::arg("white_on_black") = false, py::arg("threads") = 0,
      py::arg("force") = false, py::arg("ep_mm") = py::none(), py::arg("natural_vignetting") = false,
      py::arg("vignetting_pa") = std::array<double, 3>{0, 0, 0}, py::arg("noise_e") = py::none(),
      py::arg("rig") = py::none(), py::arg("baseline_mm") = py::none(), py::arg("convergence_deg") = 0.0,
      py::arg("set") = 0, py::arg("distances_mm") = py::none(), py::arg("max_tilt_deg") = 35.0,
      py::arg("min_whole_fraction") = 1.0,
      "Render what the camera sees through the port, as `porthole render --out NAME.png` with its defaults: "
      "target (a spec string, as detect and calibrate take) at distance_mm from the entrance pupil, shifted "
      "shift_mm (x, y, cam frame), tilted tilt_deg (about its x, then y axis) and rolled roll_deg; camera, "
      "lens, pixel_pitch_mm, focal_mm as plan() takes them; port (a preset or TOML; 'none': the lens alone, in "
      "air); the water keywords; medium water or air; focus_distance_mm the lens's focus-scale distance FD "
      "(None: focused on the target); f_number (None: f/8 or the nearest the lens has; math.inf: a pinhole); "
      "camera_model: a calibration file (any format; default the ideal camera of the lens) or c_mm; bands_nm, "
      "color (grey, rgb), bit_depth (8, 16), samples_per_pixel and edge_samples_per_pixel (squares), seed, "
      "exposure, white_on_black; ep_mm: the entrance pupil (x, y, z) in the housing frame (default the lens's); "
      "natural_vignetting (cos^4 for a rectilinear lens), vignetting_pa (lensfun's pa k1, k2, k3); noise_e: "
      "(full well, read noise) in electrons (default none). Writes out (a .png) and its ground truth beside it (.json) and returns what "
      "`render --json` prints, with ground_truth (that JSON) and warnings. "
      "set=N (`--set N`): N seeded poses in water and in air into out/water and out/air (out a folder; the lens "
      "alone: air only), distances_mm (near, far), max_tilt_deg, min_whole_fraction (coded targets: partial views). "
      "rig (`--rig`): a rig file (calibrate_rig()'s, any rig format) or its dict: every camera with its calibration, "
      "cam_from_rig and port, the target posed in the rig frame, into out/<camera>/render.png, with set=N "
      "out/water/<camera>/pose_NNN.png and out/air/<camera>/...; or baseline_mm (and convergence_deg): two of the "
      "camera behind port. A set or a rig returns `render --json`'s summary with `renders`: one entry per image "
      "(camera, medium, frame, image, truth, points, ..., ground_truth) and warnings (with any note).");
}

}  // namespace porthole::python
