// `porthole simulate`: the underwater calibration to expect behind a port — the central Brown
// model fitted to rays traced through the port in water and in air (docs/simulate.md), the
// prediction from an in-air calibration, pupil-offset tolerance sweeps, the model's error at other
// distances, and distortion maps.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "commands.h"
#include "common.h"
#include "calibration_check.h"
#include "camera_options.h"
#include "porthole/camera/json.h"
#include "porthole/camera/projection.h"
#include "porthole/camera/profile.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/catalogue/presets.h"
#include "porthole/simulate/report.h"

namespace porthole::cli {
namespace {

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// ".json" → JSON text, anything else → CSV.
std::string AsFile(const std::string& path, const Json& json, const std::string& csv) {
  return EndsWith(path, ".json") ? json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n" : csv;
}

std::string ParamRow(const std::string& label, const camera::BrownParams& p, const std::string& rms) {
  return fmt::format("{:<16} {:>9.4f} {:>8.4f} {:>8.4f} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>8}\n",
                     label, p.c_mm, p.x0_mm, p.y0_mm, p.K1, p.K2, p.K3, p.P1, p.P2, rms);
}

// "focus scale 1234.5 mm" ("infinity" for a focus at infinity), or what stands for it when the lens
// cannot reach that focus (never "nan").
std::string FocusScaleText(const std::optional<double>& fd) {
  if (!fd || std::isnan(*fd)) return "beyond the lens's focus range";
  return std::isinf(*fd) ? std::string("focus scale at infinity") : fmt::format("focus scale {:.1f} mm", *fd);
}

struct SimulateCliOptions {
  std::string port = "nimar-ni320";
  CameraLensOptions camera;
  WaterOptions water;
  double focus_distance_mm = 1000;
  std::vector<double> ep_offset;
  std::optional<double> c_mm;
  std::string air_calibration;
  int grid_cols = 25, grid_rows = 17;
  std::vector<std::string> distances;
  bool no_k3 = false, fixed_rotation = false;
  std::string sweep;
  std::vector<double> offsets;
  std::string sweep_out, map_out;
  std::vector<std::string> check = {"300", "500", "800", "1300", "2000", "5000", "100000"};
  bool json = false, force = false;
  OutputRules rules;  // set by the callback: --force and the files the options name
};

// A fisheye lens: the Kannala–Brandt fits in water and in air (pixels).
std::string FisheyeText(const simulate::SystemSpec& spec, const simulate::Prediction& p) {
  std::string t = DescribeSystemLine(p.water_system, spec.env) + "\n" + catalogue::DescribeCameraAndLens(spec.camera, spec.lens);
  t += fmt::format("{} + {} ({} fisheye) focused for {:g} mm under water: virtual image {:.1f} mm from the pupil, "
                   "{}; c = {:.3f} mm\n\n{} fitted, pixels:\n",
                   spec.camera.name, spec.lens.name, camera::ProjectionName(spec.lens.projection),
                   p.object_distance_mm, p.focus.d_s2ep_mm, FocusScaleText(p.focus.focus_distance_mm),
                   p.camera.lens.c_mm,
                   p.water_fisheye->camera.model == camera::CameraModelId::kKannalaBrandt
                       ? std::string("Kannala-Brandt (OpenCV fisheye)")
                       : std::string(p.water_fisheye->camera.model_name()));
  const camera::ModelInfo& info = p.water_fisheye->camera.info();
  t += fmt::format("{:<16}", "");
  for (int i = 0; i < info.num_params; ++i) t += fmt::format(" {:>11}", info.params[i].name);
  t += fmt::format(" {:>9}\n", "rms px");
  for (const auto& [label, fit] : {std::pair{"air (fitted)", &*p.air_fisheye}, {"water (fitted)", &*p.water_fisheye}}) {
    t += fmt::format("{:<16}", label);
    for (double v : fit->camera.params) t += fmt::format(" {:>11.5g}", v);
    t += fmt::format(" {:>9.4f}\n", fit->rms_px);
  }
  if (p.predicted_water_fisheye) {
    for (const auto& [label, cam] : {std::pair{"in-air calib.", &*p.air_fisheye_calibration},
                                     {"water predicted", &*p.predicted_water_fisheye}}) {
      t += fmt::format("{:<16}", label);
      for (double v : cam->params) t += fmt::format(" {:>11.5g}", v);
      t += "\n";
    }
  }
  const simulate::FitView water = p.water_view(), air = p.air_view();
  t += fmt::format("\nfocal length water/air = {:.5f}; radial change against the {} projection (water - air):",
                   water.c_mm() / air.c_mm(), camera::ProjectionName(p.lens_projection));
  for (double r : {5.0, 10.0, simulate::ProfileRadiiMm(p.camera.sensor).back()}) {
    const double change_um = 1000 * (water.RadialProfileMm(r) - air.RadialProfileMm(r));
    // A radius whose rays do not reach the water (beyond the port's rim) has no change.
    t += std::isfinite(change_um) ? fmt::format(" {:.1f} um at r = {:.1f} mm;", change_um, r)
                                  : fmt::format(" none at r = {:.1f} mm (not traced through the port);", r);
  }
  if (p.predicted_water_fisheye) t += std::string("\nin-air calibration taken as ") + simulate::kAirCalibrationTakenAs;
  return t + "\n";
}

// A rectilinear lens: the Brown fits, the change, the profile and the error at other distances.
std::string BrownText(const simulate::SystemSpec& spec, const simulate::Prediction& p,
                    const std::vector<simulate::DistanceError>& errors, const std::vector<double>& radii) {
  std::string t = DescribeSystemLine(p.water_system, spec.env) + "\n" + catalogue::DescribeCameraAndLens(spec.camera, spec.lens);
  t += fmt::format("{} + {} focused for {:g} mm under water: virtual image {:.1f} mm from the pupil, "
                   "{}, pupil {:.2f} mm ahead of the flange; c = {:.3f} mm\n\n",
                   spec.camera.name, spec.lens.name, p.object_distance_mm, p.focus.d_s2ep_mm,
                   FocusScaleText(p.focus.focus_distance_mm), p.focus.ep_to_flange_mm, p.camera.lens.c_mm);
  t += fmt::format("{:<16} {:>9} {:>8} {:>8} {:>11} {:>11} {:>11} {:>11} {:>11} {:>8}\n", "", "c mm",
                   "x0 mm", "y0 mm", "K1 mm^-2", "K2 mm^-4", "K3 mm^-6", "P1 mm^-1", "P2 mm^-1", "rms um");
  t += ParamRow("air (fitted)", p.air.params, Fixed(p.air.rms_um, 3));
  t += ParamRow("water (fitted)", p.water.params, Fixed(p.water.rms_um, 3));
  t += ParamRow("change", p.change, "");
  if (p.predicted_water) {
    t += ParamRow("in-air calib.", *spec.air_calibration, "");
    t += ParamRow("water predicted", *p.predicted_water, "");
  }
  t += fmt::format("\nc water/air = {:.5f}; radial profile change (water - air):", p.water.params.c_mm / p.air.params.c_mm);
  for (double r : radii) {
    t += fmt::format(" {:.1f} um at r = {:.1f} mm;",
                     1000 * (camera::RadialProfileMm(p.water.params, r) - camera::RadialProfileMm(p.air.params, r)), r);
  }
  if (p.predicted_water || p.predicted_water_fisheye) {
    t += std::string("\nin-air calibration taken as ") + simulate::kAirCalibrationTakenAs;
  }
  t += "\n\nfitted water model at other distances from the pupil:\n";
  for (const auto& e : errors) {
    t += fmt::format("  {:>9.0f} mm  rms {:>8.3f} um  max {:>8.3f} um\n", e.distance_mm, e.rms_um, e.max_um);
  }
  return t;
}

}  // namespace

void RunSimulate(const SimulateCliOptions& o);

void RegisterSimulate(CLI::App& app) {
  auto o = std::make_shared<SimulateCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Predict the underwater calibration: fit the central Brown model (c, x0, y0, K1-K3, P1, P2, "
      "free pose; Kannala-Brandt for a fisheye lens) to rays traced through the port in water and in air; sweeps "
      "and maps");
  cmd->add_option("--port", o->port, "Port: a preset name ('porthole presets') or a TOML file")
      ->capture_default_str();
  o->camera.Add(cmd);
  o->water.Add(cmd);
  cmd->add_option("--focus-distance", o->focus_distance_mm,
                  "Focused under water on an object this far from the entrance pupil, mm")
      ->capture_default_str();
  cmd->add_option("--ep-offset", o->ep_offset,
                  "Entrance-pupil offset dx,dy,dz from the lens's pupil, housing frame, mm")
      ->delimiter(',')->expected(3);
  cmd->add_option("--c", o->c_mm, "Principal distance, mm (default: thin lens focused on the virtual image)");
  cmd->add_option("--air-calibration", o->air_calibration,
                  "In-air calibration in the housing: a file (porthole JSON, OpenCV YAML, COLMAP, mrcal, Metashape "
                  "XML; a pixel model is refit to Brown; a fisheye lens keeps its Kannala-Brandt calibration) or "
                  "text {c_mm, x0_mm, y0_mm, K1, K2, P1, P2}; prints the underwater calibration to expect");
  cmd->add_option("--grid-cols", o->grid_cols, "Image points across")->capture_default_str();
  cmd->add_option("--grid-rows", o->grid_rows, "Image points down")->capture_default_str();
  cmd->add_option("--distances", o->distances,
                  "Object distances from the pupil for the fit, mm (default 0.8,1.05,1.3 x focus)")
      ->delimiter(',');
  cmd->add_flag("--no-k3", o->no_k3, "Hold K3 = 0 (a K1/K2 calibration, like the paper's)");
  cmd->add_flag("--fixed-rotation", o->fixed_rotation,
                "Hold the camera's axes at the housing's: a port tilt goes into x0/y0, P1/P2");
  cmd->add_option("--check-distances", o->check,
                  "Distances at which to report the fitted water model's error, mm")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--sweep", o->sweep, "Sweep the pupil offset along x, y or z (z: toward the glass)")
      ->check(CLI::IsMember({"x", "y", "z"}));
  cmd->add_option("--offsets", o->offsets, "Sweep offsets, mm (default z: -10..10 step 1; x, y: -2..2 step 0.5)")
      ->delimiter(',');
  cmd->add_option("--sweep-out", o->sweep_out, "Write the sweep to this file (.csv or .json)");
  cmd->add_option("--map", o->map_out, "Write the distortion maps on the fit grid to this file (.csv or .json)");
  cmd->add_flag("--json", o->json, "JSON output for scripts");

  AddForceFlag(cmd, &o->force);
  cmd->callback([o, cmd] {
    o->rules = OutputRules{.force = o->force, .inputs = InputFiles(cmd, {"--sweep-out", "--map"})};
    WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"subject_distance_mm", "--focus-distance"}, {"c_mm", "--c"},
                    {"air_calibration", "--air-calibration"}},
                   [&] { RunSimulate(*o); });
  });
}

void RunSimulate(const SimulateCliOptions& o_ref) {  // NOLINT: the body of the callback
  const SimulateCliOptions* o = &o_ref;
  {
    simulate::SystemSpec spec;
    static_cast<housing::HousedCamera&>(spec) =
        HousedWithCalibrationPitch(o->camera, PortOptions{o->port, {}}, o->water, o->air_calibration, "--air-calibration");
    if (!o->sweep_out.empty()) CheckOutput(o->sweep_out, "--sweep-out", o->rules);
    if (!o->map_out.empty()) CheckOutput(o->map_out, "--map", o->rules);
    spec.object_distance_mm = RequirePositive("--focus-distance", o->focus_distance_mm);
    if (!o->ep_offset.empty()) {
      spec.ep_offset_mm = simulate::Vec3(o->ep_offset[0], o->ep_offset[1], o->ep_offset[2]);
      if (!spec.ep_offset_mm.allFinite()) throw InvalidInput("--ep-offset", "must be three finite numbers");
    }
    if (o->c_mm) spec.c_mm = RequirePositive("--c", *o->c_mm);
    // --air-calibration: Brown parameters as inline JSON text, or a file of any format interop
    // reads (a pixel model refit to Brown over the image; the refit is reported).
    std::optional<interop::ReadResult> air_read;
    if (!o->air_calibration.empty()) {
      const auto first = o->air_calibration.find_first_not_of(" \t\r\n");
      const bool flat_brown_file =  // {c_mm, x0_mm, …} in a file, without a calibration's "camera"
          std::filesystem::path(o->air_calibration).extension() == ".json" &&
          ReadInputFile(o->air_calibration, "--air-calibration", kMaxCalibrationFileBytes).find("\"camera\"") ==
              std::string::npos;
      const bool fisheye_lens = camera::IsFisheye(spec.lens.projection);
      if ((first != std::string::npos && o->air_calibration[first] == '{') || flat_brown_file) {
        if (fisheye_lens) {
          throw InvalidInput("--air-calibration", "Brown parameters cannot describe the " + spec.lens.name +
                                                      " (a fisheye): give a Kannala-Brandt calibration file");
        }
        spec.air_calibration = camera::LoadBrownJson(o->air_calibration, "--air-calibration").value;
      } else if (fisheye_lens) {
        // A fisheye keeps the calibration's own model (Kannala-Brandt, or a projection of the list).
        air_read = interop::ReadCalibrationFile(o->air_calibration, spec.camera.sensor.pixel_pitch_mm,
                                                "--air-calibration");
        if (!air_read->camera().info().caps.fisheye) {
          throw InvalidInput("--air-calibration", "is a " + std::string(air_read->camera().model_name()) +
                                                      " calibration; the " + spec.lens.name +
                                                      " is a fisheye (give a Kannala-Brandt calibration)");
        }
        // Image size, pitch and focal length against the body and lens (camera/validate.h).
        simulate::CheckAirCalibration(air_read->camera(), air_read->pitch_known, spec,
                                      "--air-calibration '" + o->air_calibration + "'");
        spec.air_fisheye_calibration = air_read->camera();
      } else {
        // Checked against the body and lens before a pixel model is refit to Brown.
        air_read = ReadCalibrationFor(o->air_calibration, spec, camera::CameraModelId::kBrown, "--air-calibration");
        spec.air_calibration = camera::ToBrown(air_read->camera(), "--air-calibration");
      }
    }
    simulate::FitOptions fo;
    fo.grid_cols = o->grid_cols;
    fo.grid_rows = o->grid_rows;
    if (fo.grid_cols < 3) throw InvalidInput("--grid-cols", "must be >= 3");
    if (fo.grid_rows < 3) throw InvalidInput("--grid-rows", "must be >= 3");
    if (!o->distances.empty()) {
      fo.distances_mm = ParseLengthList(o->distances, "--distances");
      for (double d : fo.distances_mm) {
        if (std::isinf(d)) throw InvalidInput("--distances", "must be finite");
      }
      if (fo.distances_mm.size() < 2) throw InvalidInput("--distances", "needs at least two distances");
    }
    fo.fit_k3 = !o->no_k3;
    fo.free_rotation = !o->fixed_rotation;
    std::vector<double> check = ParseLengthList(o->check, "--check-distances");
    for (double& d : check) d = std::min(d, 1e9);  // 'inf': far enough to be at infinity
    int axis = -1;
    std::vector<double> offsets = o->offsets;
    if (!o->sweep.empty()) {
      axis = o->sweep == "x" ? 0 : o->sweep == "y" ? 1 : 2;
      if (offsets.empty()) {
        const double step = axis == 2 ? 1.0 : 0.5, span = axis == 2 ? 10.0 : 2.0;
        for (double v = -span; v <= span + 1e-9; v += step) offsets.push_back(v);
      }
      for (double v : offsets) RequireFinite("--offsets", v);
    } else if (!o->offsets.empty() || !o->sweep_out.empty()) {
      throw InvalidInput("--offsets", "--offsets and --sweep-out need --sweep x|y|z");
    }

    const simulate::Prediction p = simulate::Predict(spec, fo);
    const bool fisheye = p.water_fisheye.has_value();
    // The reprojection error at other distances is the Brown fit's (a fisheye prints its fit only).
    std::vector<simulate::DistanceError> errors;
    if (!fisheye) errors = simulate::DistanceErrors(p.water_system, p.camera, p.water, check, p.options);
    std::vector<simulate::SweepRow> sweep;
    if (axis >= 0) sweep = simulate::SweepPupilOffset(p, axis, offsets);
    const std::vector<double> radii = {5.0, 10.0, simulate::ProfileRadiiMm(p.camera.sensor).back()};

    if (!o->map_out.empty()) {
      const auto map = simulate::DistortionMap(p);
      WriteOutput(o->map_out, AsFile(o->map_out, simulate::MapJson(map), simulate::MapCsv(map)), "--map", o->rules);
    }
    if (!o->sweep_out.empty()) {
      WriteOutput(o->sweep_out,
                  AsFile(o->sweep_out, simulate::SweepJson(sweep, axis, radii), simulate::SweepCsv(sweep, axis, radii)),
                  "--sweep-out", o->rules);
    }

    if (o->json) {
      Json out = DescribeSystem(p.water_system, spec.env);
      out["medium"] = out["water"];  // "water" and "air" are the fits below
      out.erase("water");
      out["camera_body"] = spec.camera.name;
      out["lens"] = spec.lens.name;
      // Which source answered each name ("preset", "file", "lensfun"), and what of the lens is assumed.
      out["camera_found_in"] = spec.camera.lookup;
      out["lens_found_in"] = spec.lens.lookup;
      out["lens_min_focus_assumed"] = spec.lens.min_focus_assumed;
      out["lens_pupil_estimated"] = spec.lens.pupil_estimated;
      const Json prediction = simulate::PredictionJson(p);  // outlives the loop over its items
      for (const auto& [k, v] : prediction.items()) out[k] = v;
      if (!fisheye) out["distance_errors"] = simulate::DistanceErrorsJson(errors);
      if (axis >= 0) out["sweep"] = simulate::SweepJson(sweep, axis, radii);
      if (air_read) {
        out["air_calibration_read"] = interop::DescribeRead(*air_read, o->air_calibration);
        out["air_calibration_refit_rms_px"] = air_read->exact ? 0.0 : air_read->fit.rms_px;
      }
      fmt::print("{}\n", out.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
      return;
    }
    std::string t = fisheye ? FisheyeText(spec, p) : BrownText(spec, p, errors, radii);
    if (air_read) t += "in-air calibration read from " + interop::DescribeRead(*air_read, o->air_calibration) + "\n";
    if (axis >= 0) {
      t += fmt::format("\npupil offset along {} (mm) vs water - air change ({}):\n{:>9} {:>10} {:>10} {:>12} {:>9}\n",
                       o->sweep, p.water_view().model_name(), "offset", "dc mm", "c ratio", "dr@10mm um", "rms um");
      for (const auto& r : sweep) {
        const simulate::FitView w = r.water_view(), a = r.air_view();
        t += fmt::format("{:>9.2f} {:>10.4f} {:>10.5f} {:>12.2f} {:>9.3f}\n", r.offset_mm, w.c_mm() - a.c_mm(),
                         w.c_mm() / a.c_mm(), 1000 * (w.RadialProfileMm(10) - a.RadialProfileMm(10)), w.rms_um());
      }
    }
    fmt::print("{}", t);
  }
}

}  // namespace porthole::cli
