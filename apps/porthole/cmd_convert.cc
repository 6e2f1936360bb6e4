// `porthole convert IN [IN …] OUT [--to FORMAT]`: a calibration from one tool's file format to
// another's (porthole JSON, OpenCV YAML/XML, COLMAP cameras.txt/.bin, mrcal .cameramodel, Metashape
// XML, calibmar; several INs: one COLMAP file holding them all; docs/interop.md), and a rig between
// porthole's rig JSON and OpenCV stereo, VIAME npz, ROS camera_info and Kalibr files. The format
// rules are the library's (interop/convert.h); here the options are parsed and the result printed.
#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <string_view>

#include "commands.h"
#include "common.h"
#include "convert_photomodeler.h"
#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/interop/convert.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/rig_files.h"

namespace porthole::cli {
namespace {

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

// --image-size WIDTHxHEIGHT, parsed only where Convert reads it: a rig conversion whose options Convert
// accepts up to there (else it is refused first, as the image size of no rig or behind another error).
std::pair<int, int> ImageSizeWhenUsed(const interop::ConvertOptions& c, const std::string& text) {
  const bool pitch_ok = !c.pixel_pitch_mm || (std::isfinite(*c.pixel_pitch_mm) && *c.pixel_pitch_mm > 0);
  const bool rig_ok = c.port.empty() && c.port_out.empty() && !c.water_index && c.camera_id == 0;
  if (pitch_ok && rig_ok && interop::IsRigConversion(c)) return ParseImageSize(text);
  return {1, 1};  // Convert refuses the options before it uses the size
}

// The library's fields in convert's words: the positional IN and OUT, --image-size (WIDTHxHEIGHT for
// image_size_px), and every other field the flag of its name (FlagOfField: port_out → --port-out).
std::optional<std::string> ConvertWord(std::string_view field) {
  if (field == "inputs") return "IN";
  if (field == "out") return "OUT";
  if (field == "image_size_px") return "--image-size";
  return FlagOfField(field);
}

std::string RefitText(bool exact, const camera::ConversionFit& fit) {
  return exact ? std::string("exact")
               : fmt::format("refit over the image: RMS {:.6f} px, max {:.6f} px ({} points)", fit.rms_px, fit.max_px,
                             fit.num_points);
}

void PrintRig(const interop::ConvertResult& r) {
  const std::string in_text = r.inputs.size() == 1 ? r.inputs.front() : fmt::format("{} files", r.inputs.size());
  fmt::print("rig of {} cameras: {} ({}) -> {} ({})\n", r.rig_in.cameras.size(), in_text,
             interop::RigFormatName(r.rig_in.format), r.out, interop::RigFormatName(r.rig_format));
  for (const auto& c : r.rig_written.cameras) fmt::print("  {}: {} {}\n", c.name, c.format_model, RefitText(c.exact, c.fit));
  if (r.rig_in.format != interop::RigFormat::kJson) {
    fmt::print("T in {}; no sigma (the format holds no covariance)\n", r.rig_in.length_unit_note);
  } else if (r.rig_format != interop::RigFormat::kJson) {
    fmt::print("sigma and the rig's covariance not written ({} holds none)\n", interop::RigFormatName(r.rig_format));
  }
}

void PrintCalibration(const interop::ConvertResult& r) {
  const interop::ReadResult& in = r.reads.front().read;
  const std::string how = RefitText(r.exact, r.fit);
  std::string extra;
  if (!r.port_out.empty()) {
    extra = fmt::format("\nhousing {} -> {} (porthole port, cam frame, mm); water index {:g}: give "
                        "--water-index {:g} to commands using it", in.housing->model, r.port_out,
                        r.port_water_index, r.port_water_index);
  } else if (in.housing && !r.housing_written) {
    extra = fmt::format("\nhousing {} not converted: give --port-out FILE.toml", in.housing->model);
  }
  if (r.format == interop::Format::kColmapText && r.written.format_model.find("PORT") != std::string::npos) {
    extra += "\nthe housing is refractive COLMAP's (COLMAP-Underwater reads it; stock COLMAP does not)";
  }
  const std::string_view out_format = interop::FormatName(r.format);
  if (r.several) {
    for (std::size_t i = 0; i < r.reads.size(); ++i) {
      fmt::print("{} ({} {}) -> camera {}\n", r.reads[i].path, interop::FormatName(r.reads[i].read.format),
                 r.reads[i].read.format_model, i + 1);
    }
    return fmt::print("{} cameras -> {} ({} {}): {}{}\n", r.reads.size(), r.out, out_format, r.written.format_model,
                      how, extra);
  }
  fmt::print("{} ({} {}) -> {} ({} {}): {}{}\n", r.reads.front().path, interop::FormatName(in.format), in.format_model,
             r.out, out_format, r.written.format_model, how, extra);
}

}  // namespace

void RegisterConvert(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;  // IN [IN …] OUT
    std::string to, port_out, port, length_unit, image_size, field_out;
    std::optional<double> pitch_mm, water_index;
    int camera_id = 0;
    bool json = false, force = false;
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
  cmd->add_option("--length-unit", o->length_unit,
                  "Rig files whose T has no stated unit (OpenCV stereo, VIAME npz not written by porthole): mm, cm or m")
      ->check(CLI::IsMember({"mm", "cm", "m"}));
  cmd->add_option("--image-size", o->image_size,
                  "VIAME npz not written by porthole, PhotoModeler point tables or an export whose line 2 has none "
                  "(they hold no image size): WIDTHxHEIGHT, px");
  cmd->add_option("--field-out", o->field_out,
                  "--to detections: write the PhotoModeler export's 3-D points as a target-field file (for "
                  "calibrate --field)");
  cmd->add_flag("--json", o->json, "JSON summary for scripts");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o] {
    if (o->to == "detections") {  // a PhotoModeler export (+ DBAT control points): convert_photomodeler.h
      for (const auto& [flag, given] : {std::pair{"--port", !o->port.empty()}, {"--port-out", !o->port_out.empty()},
                                        {"--water-index", o->water_index.has_value()}, {"--camera-id", o->camera_id != 0},
                                        {"--pixel-pitch-mm", o->pitch_mm.has_value()}, {"--length-unit", !o->length_unit.empty()}}) {
        if (given) throw InvalidInput(flag, "is not for --to detections (give the pitch to calibrate)");
      }
      const std::vector<std::string> ins(o->files.begin(), o->files.end() - 1);
      return RunPhotoModelerConvert(ins, o->files.back(), o->field_out, o->image_size.empty() ? std::nullopt
                                    : std::optional(ParseImageSize(o->image_size)), o->json, o->force);
    }
    interop::ConvertOptions c;
    c.inputs.assign(o->files.begin(), o->files.end() - 1);
    c.out = o->files.back();
    if (!o->to.empty()) c.to = o->to;
    c.pixel_pitch_mm = o->pitch_mm;
    c.camera_id = o->camera_id;
    c.port_out = o->port_out;
    c.port = o->port;
    c.water_index = o->water_index;
    c.length_unit = o->length_unit;
    c.force = o->force;
    c.words = [](std::string_view text) { return CliWords(text); };
    for (const std::string& w : interop::ConvertWarnings(c)) {  // "pixel_pitch_mm: …" → "--pixel-pitch-mm: …"
      const std::string field = w.substr(0, w.find(':'));
      fmt::print(stderr, "porthole: warning: {}{}\n", ConvertWord(field).value_or(field), w.substr(field.size()));
    }
    if (!o->field_out.empty()) throw InvalidInput("--field-out", "goes with --to detections");
    interop::ConvertResult r;
    try {
      if (!o->image_size.empty()) c.image_size_px = ImageSizeWhenUsed(c, o->image_size);
      r = interop::Convert(c);
    } catch (const InvalidInput& e) {
      throw RenameFieldsBy(ConvertWord, e);
    }
    if (o->json) {
      Json j = interop::ConvertJson(r);
      if (r.rig) j["pitch"] = CliWords(j["pitch"].get<std::string>());  // `pixel_pitch_mm` → --pixel-pitch-mm
      return fmt::print("{}\n", PrintableJson(j));
    }
    r.rig ? PrintRig(r) : PrintCalibration(r);
  });
}

}  // namespace porthole::cli
