// `porthole convert IN OUT [--to FORMAT]`: a calibration from one tool's file format to another's
// (porthole JSON, OpenCV YAML, COLMAP cameras.txt/.bin, mrcal .cameramodel, Metashape XML;
// docs/interop.md).
#include <fmt/format.h>

#include <filesystem>
#include <optional>

#include "commands.h"
#include "common.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/refractive.h"
#include "porthole/io/presets.h"
#include "porthole/materials/materials.h"

namespace porthole::cli {

void RegisterConvert(CLI::App& app) {
  struct Options {
    std::string in, out, to, port_out, port;
    std::optional<double> pitch_mm, water_index;
    int camera_id = 0;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "convert",
      "Convert a calibration between porthole JSON, OpenCV YAML, COLMAP, mrcal, Metashape and calibmar files");
  cmd->footer(
      "Formats (read: detected from the extension, else the content; write: from OUT's extension or "
      "--to):\n"
      "  json         porthole calibration JSON (.json), every camera model\n"
      "  opencv-yaml  OpenCV FileStorage (.yml/.yaml): camera_matrix, distortion_coefficients\n"
      "  colmap       COLMAP cameras.txt (or a sparse-model directory holding it): SIMPLE_PINHOLE,\n"
      "               PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE\n"
      "  colmap-bin   COLMAP cameras.bin, the same models\n"
      "  mrcal        mrcal .cameramodel: LENSMODEL_PINHOLE, OPENCV4, OPENCV5, OPENCV8\n"
      "  metashape    Agisoft Metashape / PhotoScan calibration XML (.xml): frame, fisheye;\n"
      "               its <covariance> is read and written\n"
      "  calibmar     calibmar calibration.yaml: COLMAP's models, sigma and RMS in # comments,\n"
      "               and the housing (refractive COLMAP FLATPORT / DOMEPORT, metres):\n"
      "               --port-out writes it as a porthole port TOML, --port puts one in\n"
      "Same-family conversions are exact (COLMAP's principal point is shifted by 0.5 px: its\n"
      "top-left pixel centre is (0.5, 0.5)). A Brown calibration written to a pixel format is refit\n"
      "to OpenCV's model over the image and the refit's RMS is printed; so is a Metashape camera\n"
      "with terms OpenCV lacks (b2, k4, p3, p4). sigma is carried where both formats hold it\n"
      "(porthole JSON, Metashape) and unknown where the input has none. See docs/interop.md.\n"
      "Example: porthole convert calib.json sparse/0/cameras.txt");
  cmd->add_option("IN", o->in, "Calibration to read (file, or a COLMAP sparse-model directory)")
      ->required();
  cmd->add_option("OUT", o->out,
                  "File to write (an existing directory: its cameras.txt / cameras.bin)")
      ->required();
  cmd->add_option("--to", o->to, "Output format: " + interop::FormatNames() +
                                     " (default: from OUT's extension)");
  cmd->add_option("--pixel-pitch-mm", o->pitch_mm,
                  "Pixel pitch for inputs that have none (all but porthole JSON), mm; without it "
                  "pitch 1 (pixels are mm)");
  cmd->add_option("--camera-id", o->camera_id, "The camera of a COLMAP file holding several (its CAMERA_ID)");
  cmd->add_option("--port-out", o->port_out,
                  "calibmar input: write its FLATPORT/DOMEPORT housing as a porthole port TOML (cam frame, mm)");
  cmd->add_option("--port", o->port,
                  "calibmar output: the housing to write (a port preset or TOML; a dome must be concentric)");
  cmd->add_option("--water-index", o->water_index,
                  "calibmar output with --port: the water index nw (default: seawater, Quan-Fry at 20 C, 35 PSU, "
                  "546.07 nm)");
  cmd->add_flag("--json", o->json, "JSON summary for scripts");
  cmd->callback([o] {
    if (o->pitch_mm) {
      RequirePositive("--pixel-pitch-mm", *o->pitch_mm);
      WarnIfImplausible("--pixel-pitch-mm", *o->pitch_mm, kPixelPitchRange);
    }
    const auto in = interop::ReadCalibrationFile(o->in, o->pitch_mm.value_or(1.0), "IN", o->camera_id);
    std::filesystem::path out = o->out;
    const std::optional<std::string> to = o->to.empty() ? std::nullopt : std::optional(o->to);
    if (std::filesystem::is_directory(out)) {
      const auto dir_format = to ? interop::FormatFromName(*to, "--to") : interop::Format::kColmapText;
      if (dir_format != interop::Format::kColmapText && dir_format != interop::Format::kColmapBinary) {
        throw InvalidInput("OUT", "'" + o->out + "' is a directory: only COLMAP writes into one");
      }
      out /= dir_format == interop::Format::kColmapText ? "cameras.txt" : "cameras.bin";
    }
    const auto format = interop::OutputFormat(out.string(), to, "OUT");
    // The refractive housing: calibmar's, or a porthole port given with --port.
    if (o->water_index && o->port.empty()) throw InvalidInput("--water-index", "goes with --port");
    interop::WriteExtras extras{in.housing, in.rt_fromref};  // carried where the output holds them
    auto& housing = extras.housing;
    if (!o->port.empty()) {
      if (format != interop::Format::kCalibmar) throw InvalidInput("--port", "only calibmar output holds a housing");
      const ports::PortSpec port = io::LoadPort(o->port);
      const double n_water = o->water_index ? *o->water_index : materials::Index("seawater");
      housing = interop::RefractiveFromPort(port, materials::Index(port.material()), n_water, "--port");
    }
    std::string port_toml;
    double port_water_index = NAN;
    if (!o->port_out.empty()) {
      if (!in.housing) throw InvalidInput("--port-out", "IN has no housing (only calibmar files hold one)");
      ports::PortSpec port = interop::PortFromRefractive(*in.housing, "IN '" + o->in + "'", &port_water_index);
      port.description += fmt::format("; water index {:g} (give --water-index)", port_water_index);
      port_toml = io::PortToToml(port);
      io::ParsePortToml(port_toml, "--port-out");  // porthole reads what it writes
    }
    const auto w = interop::WriteCalibration(in.calibration, format, "OUT '" + out.string() + "'", extras);
    if (!port_toml.empty()) CheckOutputFile(o->port_out, "--port-out");
    WriteFileAtomically(out, w.content, "OUT");
    if (!port_toml.empty()) WriteFileAtomically(o->port_out, port_toml, "--port-out");

    // Reading (a Metashape model with terms porthole's lacks) or writing (Brown to a pixel format)
    // may be a refit: report the one that is, the larger if both are.
    const bool exact = in.exact && w.exact;
    const camera::ConversionFit fit =
        w.exact ? in.fit : (in.exact || w.fit.rms_px >= in.fit.rms_px ? w.fit : in.fit);
    const std::string how = exact ? "exact"
                                  : fmt::format("refit over the image: RMS {:.6f} px, max {:.6f} px "
                                                "({} points)", fit.rms_px, fit.max_px, fit.num_points);
    if (o->json) {
      Json j = {{"in", o->in},
                {"in_format", std::string(interop::FormatName(in.format))},
                {"in_model", in.format_model},
                {"camera_model", std::string(in.camera().model_name())},
                {"out", out.string()},
                {"out_format", std::string(interop::FormatName(format))},
                {"out_model", w.format_model},
                {"exact", exact},
                {"refit_rms_px", exact ? Json(0.0) : Json(fit.rms_px)},
                {"refit_max_px", exact ? Json(0.0) : Json(fit.max_px)},
                {"sigma", w.sigma_written ? "written" : in.calibration.has_covariance ? "dropped: the format holds none"
                                                                                       : "unknown"},
                {"housing", in.housing ? Json(in.housing->model) : Json(nullptr)},
                {"port_out", o->port_out.empty() ? Json(nullptr) : Json(o->port_out)},
                {"water_index", std::isfinite(port_water_index) ? Json(port_water_index) : Json(nullptr)},
                {"in_rms_px", std::isfinite(in.file_rms_px) ? Json(in.file_rms_px) : Json(nullptr)},
                {"width_px", in.camera().sensor.width_px},
                {"height_px", in.camera().sensor.height_px}};
      return fmt::print("{}\n", j.dump(2));
    }
    std::string extra;
    if (!port_toml.empty()) {
      extra = fmt::format("\nhousing {} -> {} (porthole port, cam frame, mm); water index {:g}: give "
                          "--water-index {:g} to commands using it", in.housing->model, o->port_out,
                          port_water_index, port_water_index);
    } else if (in.housing) {
      extra = fmt::format("\nhousing {} not converted: give --port-out FILE.toml", in.housing->model);
    }
    fmt::print("{} ({} {}) -> {} ({} {}): {}{}\n", o->in, interop::FormatName(in.format),
               in.format_model, out.string(), interop::FormatName(format), w.format_model, how, extra);
  });
}

}  // namespace porthole::cli
