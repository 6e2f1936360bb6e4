// Python binding of render/ (docs/render.md, docs/python.md): render() is `porthole render --out
// NAME.png` for one camera — a target at a pose seen through the camera model, the thin lens and the
// port, in water or air — with the CLI's defaults: it writes NAME.png and its ground truth NAME.json
// under core/output.h's rule and returns what `render --json` prints, the ground truth itself
// (ground_truth) and the plausibility warnings of the housed camera (warnings).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/calib/target.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/housing/plausible.h"
#include "porthole/render/render.h"
#include "porthole/simulate/simulate.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

namespace fs = std::filesystem;

std::string Path(const py::handle& o) { return py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>(); }

// A calibration of any format porthole reads, or a render's ground truth (its "camera"), checked
// against the body and lens it renders through (simulate::CheckAirCalibration), as the CLI's
// --camera-model.
camera::Camera LoadCameraModel(const std::string& path, const housing::HousedCamera& h) {
  if (fs::path(path).extension() == ".json") {
    const std::string text = ReadInputFile(path, "camera_model", kMaxCalibrationFileBytes);
    nlohmann::json j;
    try {
      j = ParseJsonText(text, "camera_model", path);
    } catch (const InvalidInput&) {  // not JSON: the calibration readers below say why
    }
    if (j.is_object() && j.contains("points") && j.contains("camera") && j["camera"].is_object()) {
      const camera::Camera cam = calib::CalibrationFromJson(j["camera"], "camera_model").camera;
      simulate::CheckAirCalibration(cam, true, h, "camera_model '" + path + "'");
      return cam;
    }
  }
  const interop::ReadResult r = interop::ReadCalibrationFile(path, h.camera.sensor.pixel_pitch_mm, "camera_model");
  simulate::CheckAirCalibration(r.camera(), r.pitch_known, h, "camera_model '" + path + "'");
  return r.camera();
}

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
         std::array<double, 3> vignetting_pa, std::optional<std::array<double, 2>> noise_e) {
        render::Scene scene;
        const bool bare = port == "none";  // the lens alone: the port only places the pupil
        scene.housed = MakeSetup(camera, lens, bare ? "nimar-ni320" : port, water, water_index, lambda_nm,
                                 temperature_c, salinity_psu, pressure_dbar, pixel_pitch_mm, focal_mm);
        scene.bare = bare;
        if (ep_mm) {
          for (const double v : *ep_mm) RequireFinite("ep_mm", v);
          scene.housed.ep_in_housing_mm = ports::Vec3((*ep_mm)[0], (*ep_mm)[1], (*ep_mm)[2]);
        }
        scene.natural_vignetting = natural_vignetting;
        scene.vignetting_pa = vignetting_pa;
        std::vector<std::string> warnings = housing::PlausibilityWarnings(scene.housed);
        scene.target = calib::ParseTarget(target);
        const std::string field_path = field.is_none() ? std::string() : Path(field);
        if (!field_path.empty()) calib::LoadTargetField(field_path, &scene.target);
        if (medium != "water" && medium != "air") throw InvalidInput("medium", "must be water or air");
        scene.medium = medium == "air" ? render::Medium::kAir : render::Medium::kWater;
        if (focus_distance_mm && !(*focus_distance_mm > 0)) {
          throw InvalidInput("focus_distance_mm", "must be > 0 mm (math.inf: focused at infinity; None: on the target)");
        }
        scene.focus_distance_mm = focus_distance_mm;
        if (f_number && !(*f_number > 0)) throw InvalidInput("f_number", "must be > 0 (math.inf: a pinhole)");
        scene.f_number = f_number ? *f_number : lens::DefaultFNumber(scene.housed.lens);
        // The outputs are checked before anything is read or rendered.
        const fs::path png = Path(out);
        if (png.extension() != ".png") throw InvalidInput("out", "must name a .png file");
        const std::string model_path = camera_model.is_none() ? std::string() : Path(camera_model);
        const OutputRules rules{.force = force, .inputs = InputFiles({port, camera, lens, field_path, model_path})};
        fs::path truth_path = png;
        truth_path.replace_extension(".json");
        CheckOutput(png, "out", rules);
        CheckOutput(truth_path, "out", rules, FileKind::kGroundTruth);
        if (!model_path.empty()) scene.camera = LoadCameraModel(model_path, scene.housed);
        scene.c_mm = c_mm;
        scene.bands_nm = bands_nm;
        if (white_on_black) std::swap(scene.style.black, scene.style.white);
        render::RenderOptions ro;
        ro.samples_per_pixel = samples_per_pixel;
        ro.edge_samples_per_pixel = edge_samples_per_pixel;
        ro.seed = seed;
        ro.exposure = exposure;
        ro.threads = threads;
        if (noise_e) {  // full well and read noise, electrons
          ro.full_well_e = RequirePositive("noise_e", (*noise_e)[0]);
          ro.read_noise_e = (*noise_e)[1];
        }
        if (color != "grey" && color != "rgb") throw InvalidInput("color", "must be grey or rgb");
        ro.color = color == "rgb" ? render::ColorMode::kRgb : render::ColorMode::kGrey;
        render::Validate(ro);
        if (bit_depth != 8 && bit_depth != 16) throw InvalidInput("bit_depth", "must be 8 or 16");
        RequireFinite("distance_mm", distance_mm);
        scene.pose = render::PoseFacing(scene.target, distance_mm, {shift_mm[0], shift_mm[1]}, tilt_deg[0],
                                        tilt_deg[1], roll_deg);
        render::Rendered r;
        std::string bytes, truth_text;
        nlohmann::ordered_json truth;
        {
          py::gil_scoped_release release;
          r = render::Render(scene, ro);
          bytes = render::EncodePng(r.image, bit_depth);
          truth = render::TruthJson(scene, ro, r, png.filename().string(), bit_depth);
          truth_text = truth.dump(1, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
          WriteOutput(truth_path, truth_text, "out", rules);
          WriteOutput(png, bytes, "out", rules);
        }
        const nlohmann::ordered_json j = {{"image", png.string()},
                                          {"truth", truth_path.string()},
                                          {"width_px", r.image.width},
                                          {"height_px", r.image.height},
                                          {"points", r.truth.size()},
                                          {"left_out_partial", r.left_out.partial.size()},
                                          {"left_out_occluded", r.left_out.occluded.size()},
                                          {"blocked_fraction", r.blocked_fraction},
                                          {"refined_fraction", r.refined_fraction},
                                          {"seconds", r.seconds},
                                          {"warnings", warnings},
                                          {"ground_truth", nlohmann::ordered_json::parse(truth_text)}};
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
      "`render --json` prints, with ground_truth (that JSON) and warnings.");
}

}  // namespace porthole::python
