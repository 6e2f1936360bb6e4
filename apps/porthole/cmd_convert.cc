// `porthole convert IN [IN …] OUT [--to FORMAT]`: a calibration from one tool's file format to
// another's (porthole JSON, OpenCV YAML/XML, COLMAP cameras.txt/.bin, mrcal .cameramodel, Metashape
// XML, calibmar; several INs: one COLMAP file holding them all; docs/interop.md), and a rig between
// porthole's rig JSON and OpenCV stereo, VIAME npz, ROS camera_info and Kalibr files (RunRig).
#include <fmt/format.h>

#include <filesystem>
#include <optional>

#include "commands.h"
#include "common.h"
#include "convert_photomodeler.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/refractive.h"
#include "porthole/interop/rig_files.h"
#include "porthole/io/presets.h"
#include "porthole/materials/materials.h"

namespace porthole::cli {
namespace {

struct ConvertRigOptions {
  std::string length_unit, image_size;
};

// Whether the INs (and --to) make this a rig conversion: the first IN is a rig file (several INs:
// ROS camera_info files, one per camera, written to a rig format), or --to names a rig format.
bool IsRigConversion(const std::vector<std::string>& ins, const std::string& out, const std::string& to) {
  if (!to.empty()) {
    for (const std::string_view name : {"opencv-stereo", "opencv-stereo-xml", "viame-npz", "ros-camera-info", "kalibr"}) {
      if (to == name) return true;
    }
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(ins.front(), ec)) return false;
  std::string head;
  try {
    head = ReadInputFile(ins.front(), "IN", kMaxCalibrationFileBytes);
  } catch (const InvalidInput&) {
    return false;  // the ordinary path reports it
  }
  const auto f = interop::DetectRigFormat(ins.front(), head);
  if (!f) return false;
  if (*f == interop::RigFormat::kRosCameraInfo) {  // one camera_info is a camera (opencv-yaml), two a rig into JSON
    return ins.size() > 1 && (to == "json" || std::filesystem::path(out).extension() == ".json");
  }
  return true;
}

std::pair<int, int> ParseImageSize(const std::string& s) {
  const auto x = s.find('x');
  int w = 0, h = 0;
  try {
    if (x != std::string::npos) w = std::stoi(s.substr(0, x)), h = std::stoi(s.substr(x + 1));
  } catch (const std::exception&) {
  }
  if (x == std::string::npos || !(w >= 1 && h >= 1 && w <= 1000000 && h <= 1000000) ||
      s.find_first_not_of("0123456789x") != std::string::npos) {
    throw InvalidInput("--image-size", "'" + s.substr(0, 20) + "' must be WIDTHxHEIGHT in pixels, e.g. 1920x1080");
  }
  return {w, h};
}

// IN … OUT as a rig: read every IN as one rig file (ROS: one per camera), write OUT in its format.
void RunRig(const std::vector<std::string>& ins, const std::string& out_arg, const std::string& to,
            std::optional<double> pitch_mm, const ConvertRigOptions& ro, bool json, bool force) {
  interop::RigReadOptions opt;
  opt.pixel_pitch_mm = pitch_mm.value_or(1.0);
  if (!ro.length_unit.empty()) opt.length_unit = interop::LengthUnitFromName(ro.length_unit, "--length-unit");
  if (!ro.image_size.empty()) opt.image_size = ParseImageSize(ro.image_size);
  const interop::RigFile rig = interop::ReadRigFiles(ins, opt, "IN");
  const std::optional<std::string> to_opt = to.empty() ? std::nullopt : std::optional(to);
  const interop::RigFormat format = interop::RigOutputFormat(out_arg, to_opt, "OUT");
  const interop::RigWriteResult w = interop::WriteRigFile(rig, format, "OUT '" + out_arg + "'");
  OutputRules rules{.force = force, .inputs = {}};
  for (const auto& path : ins) rules.inputs.emplace_back(path);
  std::vector<std::filesystem::path> paths;
  if (format == interop::RigFormat::kRosCameraInfo) {
    if (std::filesystem::exists(out_arg) && !std::filesystem::is_directory(out_arg)) {
      throw InvalidInput("OUT", "'" + out_arg + "': ros-camera-info writes one file per camera into a directory");
    }
    std::error_code ec;
    std::filesystem::create_directories(out_arg, ec);
    if (ec) throw InvalidInput("OUT", "'" + out_arg + "': cannot create the directory: " + ec.message());
    for (const auto& [name, unused] : w.files) paths.push_back(std::filesystem::path(out_arg) / name);
  } else {
    paths.emplace_back(out_arg);
  }
  for (std::size_t i = 0; i < paths.size(); ++i) {
    CheckOutput(paths[i], "OUT", rules, format == interop::RigFormat::kJson ? FileKind::kCalibration : FileKind::kOther);
  }
  for (std::size_t i = 0; i < paths.size(); ++i) WriteOutput(paths[i], w.files[i].second, "OUT", rules);
  const std::string in_text = ins.size() == 1 ? ins.front() : fmt::format("{} files", ins.size());
  if (json) {
    Json cams = Json::array();
    for (const auto& c : w.cameras) {
      cams.push_back({{"name", c.name},
                      {"out_model", c.format_model},
                      {"exact", c.exact},
                      {"refit_rms_px", c.exact ? 0.0 : c.fit.rms_px},
                      {"refit_max_px", c.exact ? 0.0 : c.fit.max_px}});
    }
    Json files = Json::array();
    for (const auto& p : paths) files.push_back(p.string());
    Json j = {{"in", ins},
              {"in_format", std::string(interop::RigFormatName(rig.format))},
              {"out", out_arg},
              {"out_files", files},
              {"out_format", std::string(interop::RigFormatName(format))},
              {"n_cameras", rig.cameras.size()},
              {"length_unit", rig.length_unit_note},
              {"pitch", rig.pitch_known ? "from the file" : pitch_mm ? "--pixel-pitch-mm" : "none: pixels are mm"},
              {"exact", w.exact()},
              {"sigma", rig.format != interop::RigFormat::kJson ? "unknown: the input holds none"
                        : format != interop::RigFormat::kJson   ? "dropped: the format holds none"
                                                                : "dropped: the rig JSON is rewritten without its covariance"},
              {"cameras", cams}};
    return fmt::print("{}\n", PrintableJson(j));
  }
  fmt::print("rig of {} cameras: {} ({}) -> {} ({})\n", rig.cameras.size(), in_text, interop::RigFormatName(rig.format),
             out_arg, interop::RigFormatName(format));
  for (const auto& c : w.cameras) {
    fmt::print("  {}: {} {}\n", c.name, c.format_model,
               c.exact ? std::string("exact")
                       : fmt::format("refit over the image: RMS {:.6f} px, max {:.6f} px ({} points)", c.fit.rms_px,
                                     c.fit.max_px, c.fit.num_points));
  }
  if (rig.format != interop::RigFormat::kJson) {
    fmt::print("T in {}; no sigma (the format holds no covariance)\n", rig.length_unit_note);
  } else if (format != interop::RigFormat::kJson) {
    fmt::print("sigma and the rig's covariance not written ({} holds none)\n", interop::RigFormatName(format));
  }
}

}  // namespace

void RegisterConvert(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;  // IN [IN …] OUT
    std::string to, port_out, port, field_out;
    std::optional<double> pitch_mm, water_index;
    int camera_id = 0;
    bool json = false, force = false;
    ConvertRigOptions rig;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "convert",
      "Convert a calibration between porthole JSON, OpenCV YAML/XML, COLMAP, mrcal, Metashape and calibmar files");
  cmd->footer(
      "Formats (read: detected from the extension, else the content; write: from OUT's extension or "
      "--to):\n"
      "  json         porthole calibration JSON (.json), every camera model\n"
      "  opencv-yaml  OpenCV FileStorage (.yml/.yaml): camera_matrix, distortion_coefficients (or\n"
      "               cameraMatrix, distCoeffs); kannala-brandt as cv::fisheye's 4 coefficients\n"
      "               with fisheye_model: 1 (read too: K, D with 4 coefficients)\n"
      "  opencv-xml   the same as OpenCV FileStorage XML (read: detected; write: --to opencv-xml)\n"
      "  colmap       COLMAP cameras.txt (or a sparse-model directory holding it): SIMPLE_PINHOLE,\n"
      "               PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE; refractive\n"
      "               COLMAP's FLATPORT / DOMEPORT housing after the parameters (read, and written\n"
      "               when the input holds one or --port gives it)\n"
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
      "Several INs write one COLMAP cameras.txt/.bin with CAMERA_ID 1, 2, ... in their order.\n"
      "Rigs (a rig JSON of `porthole calibrate` with several cameras, or a rig file IN):\n"
      "  json               porthole rig JSON (.json)\n"
      "  opencv-stereo      OpenCV stereo FileStorage YAML: K1 D1 K2 D2 R T (x2 = R x1 + T), image size\n"
      "  opencv-stereo-xml  the same as XML (.xml)\n"
      "  viame-npz          VIAME's stereo .npz: cameraMatrixL/R, distCoeffsL/R, R, T (float64)\n"
      "  ros-camera-info    one ROS camera_info YAML per camera (OUT: a directory; IN: the two files,\n"
      "                     left then right), R and P the stereo rectification, metres\n"
      "  kalibr             Kalibr camchain YAML: pinhole-radtan / pinhole-equi, T_cn_cnm1 in metres\n"
      "  A .yaml OUT needs --to (opencv-stereo or kalibr). OpenCV's and VIAME's T have no stated unit:\n"
      "  porthole writes mm with T_unit: mm; reading another file needs --length-unit. Cameras of\n"
      "  other models are refit (RMS printed); cameras behind ports are refused (no refraction).\n"
      "Photogrammetric projects (--to detections): a PhotoModeler text export, or its 2-D and 3-D point\n"
      "  tables, [and DBAT's control-point file] -> a detection set OUT and a target field --field-out,\n"
      "  for calibrate --detections OUT --field FIELD (docs/interop.md)\n"
      "Examples: porthole convert calib.json sparse/0/cameras.txt\n"
      "          porthole convert left.json right.yml sparse/0/cameras.txt   # two cameras\n"
      "An existing OUT (or --port-out) is replaced only with --force, never an IN, and never a file porthole\n"
      "wrote for another purpose (detections, a render's ground truth) even with it.");
  cmd->add_option("IN...OUT", o->files,
                  "IN [IN ...] OUT: the calibration(s) to read (a file, or a COLMAP sparse-model directory), "
                  "then the file to write (an existing directory: its cameras.txt / cameras.bin)")
      ->required()
      ->expected(2, -1);
  cmd->add_option("--to", o->to, "Output format: " + interop::FormatNames() + "; rigs: " + interop::RigFormatNames() +
                                     "; detections (a PhotoModeler export, see --field-out) (default: from OUT's extension)");
  cmd->add_option("--pixel-pitch-mm", o->pitch_mm,
                  "Pixel pitch for inputs that have none (all but porthole JSON), mm; without it "
                  "pitch 1 (pixels are mm)");
  cmd->add_option("--camera-id", o->camera_id, "The camera to read from a COLMAP file holding several (its CAMERA_ID)");
  cmd->add_option("--port-out", o->port_out,
                  "calibmar or refractive COLMAP input: write its FLATPORT/DOMEPORT housing as a porthole port "
                  "TOML (cam frame, mm, with the housing's sigma where the file gives it)");
  cmd->add_option("--port", o->port,
                  "calibmar or COLMAP cameras.txt output: the housing to write (a port preset or TOML; a dome "
                  "must be concentric)");
  cmd->add_option("--water-index", o->water_index,
                  "With --port: the water index nw (default: seawater, Quan-Fry at 20 C, 35 PSU, 546.07 nm)");
  cmd->add_option("--length-unit", o->rig.length_unit,
                  "Rig files whose T has no stated unit (OpenCV stereo, VIAME npz not written by porthole): mm, cm or m")
      ->check(CLI::IsMember({"mm", "cm", "m"}));
  cmd->add_option("--image-size", o->rig.image_size,
                  "VIAME npz not written by porthole, PhotoModeler point tables or an export whose line 2 has none "
                  "(they hold no image size): WIDTHxHEIGHT, px");
  cmd->add_option("--field-out", o->field_out,
                  "--to detections: write the PhotoModeler export's 3-D points as a target-field file (for "
                  "calibrate --field)");
  cmd->add_flag("--json", o->json, "JSON summary for scripts");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o] {
    if (o->pitch_mm) {
      RequirePositive("--pixel-pitch-mm", *o->pitch_mm);
      WarnIfImplausible("--pixel-pitch-mm", *o->pitch_mm, kPixelPitchRange);
    }
    const std::vector<std::string> ins(o->files.begin(), o->files.end() - 1);
    const std::string out_arg = o->files.back();
    if (o->to == "detections") {  // a PhotoModeler export (+ DBAT control points): convert_photomodeler.h
      for (const auto& [flag, given] : {std::pair{"--port", !o->port.empty()}, {"--port-out", !o->port_out.empty()},
                                        {"--water-index", o->water_index.has_value()}, {"--camera-id", o->camera_id != 0},
                                        {"--pixel-pitch-mm", o->pitch_mm.has_value()}, {"--length-unit", !o->rig.length_unit.empty()}}) {
        if (given) throw InvalidInput(flag, "is not for --to detections (give the pitch to calibrate)");
      }
      return RunPhotoModelerConvert(ins, out_arg, o->field_out, o->rig.image_size.empty() ? std::nullopt
                                    : std::optional(ParseImageSize(o->rig.image_size)), o->json, o->force);
    }
    if (!o->field_out.empty()) throw InvalidInput("--field-out", "goes with --to detections");
    if (IsRigConversion(ins, out_arg, o->to)) {
      if (!o->port.empty() || !o->port_out.empty() || o->water_index || o->camera_id != 0) {
        throw InvalidInput(!o->port.empty() ? "--port" : !o->port_out.empty() ? "--port-out"
                           : o->water_index        ? "--water-index"
                                                   : "--camera-id",
                           "is for a single camera's calibration, not a rig");
      }
      return RunRig(ins, out_arg, o->to, o->pitch_mm, o->rig, o->json, o->force);
    }
    if (!o->rig.length_unit.empty() || !o->rig.image_size.empty()) {
      throw InvalidInput(o->rig.length_unit.empty() ? "--image-size" : "--length-unit", "is for rig files (IN is not one)");
    }
    std::vector<interop::ReadResult> reads;
    for (const auto& path : ins) reads.push_back(interop::ReadCalibrationFile(path, o->pitch_mm.value_or(1.0), "IN", o->camera_id));
    std::filesystem::path out = out_arg;
    const std::optional<std::string> to = o->to.empty() ? std::nullopt : std::optional(o->to);
    if (std::filesystem::is_directory(out)) {
      const auto dir_format = to ? interop::FormatFromName(*to, "--to") : interop::Format::kColmapText;
      if (dir_format != interop::Format::kColmapText && dir_format != interop::Format::kColmapBinary) {
        throw InvalidInput("OUT", "'" + out_arg + "' is a directory: only COLMAP writes into one");
      }
      out /= dir_format == interop::Format::kColmapText ? "cameras.txt" : "cameras.bin";
    }
    const auto format = interop::OutputFormat(out.string(), to, "OUT");
    const bool several = reads.size() > 1;
    if (several && format != interop::Format::kColmapText && format != interop::Format::kColmapBinary) {
      throw InvalidInput("OUT", fmt::format("{} INs: only COLMAP's cameras.txt / cameras.bin hold several cameras, "
                                            "not {}", reads.size(), interop::FormatName(format)));
    }
    // The refractive housing: the input's, or a porthole port given with --port (for every camera).
    if (o->water_index && o->port.empty()) throw InvalidInput("--water-index", "goes with --port");
    std::optional<interop::RefractiveHousing> port_housing;
    if (!o->port.empty()) {
      if (format != interop::Format::kCalibmar && format != interop::Format::kColmapText) {
        throw InvalidInput("--port", "only calibmar and COLMAP cameras.txt (refractive COLMAP) outputs hold a housing");
      }
      const ports::PortSpec port = io::LoadPort(o->port);
      const double n_water = o->water_index ? *o->water_index : materials::Index("seawater");
      port_housing = interop::RefractiveFromPort(port, materials::Index(port.material()), n_water, "--port");
    }
    const interop::ReadResult& in = reads.front();
    std::string port_toml;
    double port_water_index = NAN;
    if (!o->port_out.empty()) {
      if (several) throw InvalidInput("--port-out", "goes with one IN");
      if (!in.housing) {
        throw InvalidInput("--port-out", "IN has no housing (only calibmar files and refractive COLMAP cameras.txt hold one)");
      }
      ports::PortSpec port = interop::PortFromRefractive(*in.housing, "IN '" + ins.front() + "'", &port_water_index);
      port.description += fmt::format("; water index {:g} (give --water-index)", port_water_index);
      port_toml = io::PortToToml(port) + interop::HousingSigmaToml(*in.housing);
      io::ParsePortToml(port_toml, "--port-out");  // porthole reads what it writes
    }
    const std::string out_field = "OUT '" + out.string() + "'";
    interop::WriteResult w;
    if (several) {
      std::vector<interop::ColmapEntry> entries;
      for (std::size_t i = 0; i < reads.size(); ++i) {
        entries.push_back({reads[i].calibration, static_cast<int>(i) + 1,
                           port_housing ? port_housing : reads[i].housing});
        if (format == interop::Format::kColmapBinary) entries.back().housing.reset();  // cameras.txt only
      }
      w = interop::WriteColmapCameras(entries, format, out_field);
    } else {
      interop::WriteExtras extras{port_housing ? port_housing : in.housing, in.rt_fromref};  // where the output holds them
      w = interop::WriteCalibration(in.calibration, format, out_field, extras);
    }
    // The overwrite rule (core/output.h): never an IN (a COLMAP folder's cameras.txt/.bin included),
    // an existing file only with --force, both outputs checked before either is written.
    OutputRules rules{.force = o->force, .inputs = {}};
    if (!o->port.empty()) rules.inputs.emplace_back(o->port);
    for (const auto& path : ins) {
      rules.inputs.emplace_back(path);
      for (const char* name : {"cameras.txt", "cameras.bin"}) rules.inputs.push_back(std::filesystem::path(path) / name);
    }
    CheckOutput(out, "OUT", rules, KindOfText(w.content));
    if (!port_toml.empty()) CheckOutput(o->port_out, "--port-out", rules);
    WriteOutput(out, w.content, "OUT", rules);
    if (!port_toml.empty()) WriteOutput(o->port_out, port_toml, "--port-out", rules);

    // Reading (a Metashape model with terms porthole's lacks) or writing (Brown to a pixel format)
    // may be a refit: report the one that is, the largest if several are.
    bool exact = w.exact;
    camera::ConversionFit fit = w.fit;
    for (const auto& r : reads) {
      if (!r.exact && (exact || r.fit.rms_px > fit.rms_px)) fit = r.fit;
      exact = exact && r.exact;
    }
    const std::string how = exact ? "exact"
                                  : fmt::format("refit over the image: RMS {:.6f} px, max {:.6f} px "
                                                "({} points)", fit.rms_px, fit.max_px, fit.num_points);
    const bool housing_written = format == interop::Format::kCalibmar || format == interop::Format::kColmapText;
    if (o->json) {
      Json cameras = Json::array();
      for (std::size_t i = 0; i < reads.size(); ++i) {
        cameras.push_back({{"in", ins[i]},
                           {"in_format", std::string(interop::FormatName(reads[i].format))},
                           {"in_model", reads[i].format_model},
                           {"camera_id", several ? Json(i + 1) : Json(nullptr)}});
      }
      Json j = {{"in", ins.front()},
                {"in_format", std::string(interop::FormatName(in.format))},
                {"in_model", in.format_model},
                {"camera_model", std::string(in.camera().model_name())},
                {"cameras", cameras},
                {"out", out.string()},
                {"out_format", std::string(interop::FormatName(format))},
                {"out_model", w.format_model},
                {"exact", exact},
                {"refit_rms_px", exact ? Json(0.0) : Json(fit.rms_px)},
                {"refit_max_px", exact ? Json(0.0) : Json(fit.max_px)},
                {"sigma", w.sigma_written ? "written" : in.calibration.has_covariance ? "dropped: the format holds none"
                                                                                       : "unknown"},
                {"housing", in.housing ? Json(in.housing->model) : Json(nullptr)},
                {"housing_written", housing_written && (in.housing || port_housing)},
                {"port_out", o->port_out.empty() ? Json(nullptr) : Json(o->port_out)},
                {"water_index", std::isfinite(port_water_index) ? Json(port_water_index) : Json(nullptr)},
                {"in_rms_px", std::isfinite(in.file_rms_px) ? Json(in.file_rms_px) : Json(nullptr)},
                {"width_px", in.camera().sensor.width_px},
                {"height_px", in.camera().sensor.height_px}};
      return fmt::print("{}\n", PrintableJson(j));
    }
    std::string extra;
    if (!port_toml.empty()) {
      extra = fmt::format("\nhousing {} -> {} (porthole port, cam frame, mm); water index {:g}: give "
                          "--water-index {:g} to commands using it", in.housing->model, o->port_out,
                          port_water_index, port_water_index);
    } else if (in.housing && !housing_written) {
      extra = fmt::format("\nhousing {} not converted: give --port-out FILE.toml", in.housing->model);
    }
    if (format == interop::Format::kColmapText && w.format_model.find("PORT") != std::string::npos) {
      extra += "\nthe housing is refractive COLMAP's (COLMAP-Underwater reads it; stock COLMAP does not)";
    }
    if (several) {
      for (std::size_t i = 0; i < reads.size(); ++i) {
        fmt::print("{} ({} {}) -> camera {}\n", ins[i], interop::FormatName(reads[i].format), reads[i].format_model,
                   i + 1);
      }
      return fmt::print("{} cameras -> {} ({} {}): {}{}\n", reads.size(), out.string(), interop::FormatName(format),
                        w.format_model, how, extra);
    }
    fmt::print("{} ({} {}) -> {} ({} {}): {}{}\n", ins.front(), interop::FormatName(in.format),
               in.format_model, out.string(), interop::FormatName(format), w.format_model, how, extra);
  });
}

}  // namespace porthole::cli
