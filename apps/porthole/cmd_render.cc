// `porthole render`: what the camera sees through the port — a calibration target at a pose,
// rendered through the camera model, the thin lens and the port in water or air, with a
// ground-truth JSON beside each image (docs/render.md). `--set N` renders N seeded poses in water
// and in air, ready for `porthole detect` and `porthole calibrate`; `--rig`, `--baseline` every
// camera of a rig. The steps are the library's (render::RenderJob, render/job.h), as Python's.
#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>

#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "porthole/render/job.h"

namespace porthole::cli {
namespace {

namespace fs = std::filesystem;

struct RenderCliOptions {
  std::string port = "nimar-ni320";
  std::vector<double> ep;
  CameraLensOptions camera;
  WaterOptions water;
  std::string target = "chessboard:9x6:40";
  std::string field;
  std::string medium = "water";
  double distance_mm = 1000;
  std::vector<double> shift = {0, 0}, tilt = {0, 0};
  double roll_deg = 0;
  std::string focus = "target";
  std::string f_number = "lens";  // f/8, or the nearest the lens has (lens::DefaultFNumber)
  std::string vignetting = "none";
  std::vector<double> vignetting_pa;
  std::string camera_model;
  std::optional<double> c_mm;
  std::vector<double> bands = render::kDefaultBandsNm;
  std::string color = "grey";
  int bit_depth = 8;
  int spp = 16;
  int edge_spp = 0;
  std::uint64_t seed = 1;
  double exposure = 1;
  std::vector<double> noise;
  std::string out;
  int set = 0;
  std::vector<std::string> distances;
  double max_tilt_deg = 35;
  double partial = 1;
  bool quiet = false, json = false;
  bool white_on_black = false;
  bool force = false;
  std::string rig;                  // a rig JSON (calibrate's): render every camera
  std::optional<double> baseline_mm;  // or two of the camera, this far apart
  double convergence_deg = 0;
  std::vector<fs::path> inputs;  // the files the options name: never replaced
};

double ParseLengthOrInf(const std::string& text, const std::string& field) {
  return ParseLengthList({text}, field).front();
}

// "inf" (a pinhole) or a number > 0.
double ParseFNumber(const std::string& text) {
  if (text == "inf") return std::numeric_limits<double>::infinity();
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !(v > 0) || !std::isfinite(v)) {
    throw InvalidInput("--f-number", "'" + text + "' is not an f-number > 0 (or 'inf' for a pinhole)");
  }
  return v;
}

// The options in the library's words (render/job.h); the words of the command line parsed here.
render::RenderJobOptions JobOptions(const RenderCliOptions& o) {
  render::RenderJobOptions j;
  const bool bare = o.port == "none";  // the lens alone: the port only places the pupil
  j.housed = o.camera.ToHoused(PortOptions{bare ? PortOptions{}.port : o.port, o.ep}, o.water);
  j.bare = bare;
  j.target = o.target;
  j.field = o.field;
  j.medium = o.medium;
  if (o.focus != "target") j.focus_distance_mm = ParseLengthOrInf(o.focus, "--focus");
  if (o.f_number != "lens") j.f_number = ParseFNumber(o.f_number);
  if (o.vignetting != "none" && o.vignetting != "natural") throw InvalidInput("--vignetting", "must be none or natural");
  j.natural_vignetting = o.vignetting == "natural";
  if (!o.vignetting_pa.empty()) j.vignetting_pa = {o.vignetting_pa[0], o.vignetting_pa[1], o.vignetting_pa[2]};
  j.camera_model = o.camera_model;
  j.c_mm = o.c_mm;
  j.bands_nm = o.bands;
  j.white_on_black = o.white_on_black;
  if (o.shift.size() != 2 || o.tilt.size() != 2) throw InvalidInput("--shift", "--shift and --tilt take X,Y");
  j.distance_mm = o.distance_mm;
  j.shift_mm = {o.shift[0], o.shift[1]};
  j.tilt_deg = {o.tilt[0], o.tilt[1]};
  j.roll_deg = o.roll_deg;
  j.render.samples_per_pixel = o.spp;
  j.render.edge_samples_per_pixel = o.edge_spp;
  j.render.seed = o.seed;
  j.render.exposure = o.exposure;
  j.color = o.color;
  if (!o.noise.empty()) j.noise_e = std::array<double, 2>{o.noise[0], o.noise[1]};
  j.bit_depth = o.bit_depth;
  j.set_count = o.set;
  if (!o.distances.empty()) {
    const auto d = ParseLengthList(o.distances, "--distances");
    if (d.size() != 2) throw InvalidInput("--distances", "takes NEAR,FAR in mm");
    j.distances_mm = std::array<double, 2>{d[0], d[1]};
  }
  j.max_tilt_deg = o.max_tilt_deg;
  j.min_whole_fraction = o.partial;
  j.rig = o.rig;
  j.baseline_mm = o.baseline_mm;
  j.convergence_deg = o.convergence_deg;
  j.out = o.out;
  j.rules = OutputRules{.force = o.force, .inputs = o.inputs};
  if (!o.quiet) {
    j.log = [](const std::string& line) { fmt::print(stderr, "render: {}\n", line); };
    j.note = [](const std::string& line) { fmt::print(stderr, "porthole: note: {}\n", CliWords(line)); };
  }
  return j;
}

void RunRender(const RenderCliOptions& o) {
  const render::RenderJobOptions job = JobOptions(o);
  const render::RenderJobResult r = render::RenderJob(job);
  if (o.json) fmt::print("{}\n", PrintableJson(Json(r.summary)));
  if (o.quiet) return;
  if (!o.rig.empty() || o.baseline_mm) {
    std::string names;
    for (const auto& c : r.cameras) names += (names.empty() ? "" : ", ") + c;
    fmt::print(stderr, "render: {} frame{} of {} cameras ({}) in {}\n", r.frames, r.frames == 1 ? "" : "s",
               r.cameras.size(), names, o.out);
  } else if (o.set > 0) {
    const std::string where = job.bare ? (fs::path(o.out) / "air").string() + " (the lens alone: no water set)"
                                       : (fs::path(o.out) / "water").string() + " and " + (fs::path(o.out) / "air").string();
    fmt::print(stderr, "render: {} poses in {}; focus scale {:.1f} mm\n", r.frames, where, r.focus_distance_mm.front());
  }
}

}  // namespace

void RegisterRender(CLI::App& app) {
  auto o = std::make_shared<RenderCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render what the camera sees through the port: a target at a pose, the lens's depth of field, the "
      "port's refraction and dispersion; ground truth JSON beside each PNG; --set N for calibration sets");
  cmd->add_option("--out", o->out, "Output PNG (the ground truth goes to the same name .json); with --set a directory")
      ->required();
  cmd->add_option("--target", o->target,
                  "chessboard:COLSxROWS:SQUARE_MM | charuco:SQXxSQY:SQUARE_MM:MARKER_MM[:DICT] | circles:COLSxROWS:MM | "
                  "acircles:COLSxROWS:MM | coded:BITS:RADIUS_MM[:PROFILE] (the default sheet of 'porthole target-sheet')")
      ->capture_default_str();
  cmd->add_option("--field", o->field,
                  "Coded targets: a target-field file (ID X Y Z mm per line, 'porthole target-sheet' writes one) "
                  "drawn instead of the default sheet; Z < 0 raises a target toward the camera on a plate");
  cmd->add_option("--port", o->port,
                  "Port: a preset name ('porthole presets') or a TOML file; none: the lens alone (no refraction, in "
                  "air: an in-air calibration of the bare lens)")
      ->capture_default_str()->group("Port");
  cmd->add_option("--rig", o->rig,
                  "Render a rig: a rig JSON (porthole calibrate with one --images per camera): every camera, its "
                  "calibration and its port (none when the file gives none), the target posed in the rig frame (the "
                  "first camera's); --out is a directory: DIR/<camera>/render.png, with --set DIR/water/<camera>/ "
                  "and DIR/air/<camera>/pose_NNN.png")
      ->group("Rig");
  cmd->add_option("--baseline", o->baseline_mm,
                  "Render a rig of two of this camera behind --port, the second this far (mm) to the right of the first")
      ->group("Rig");
  cmd->add_option("--convergence", o->convergence_deg,
                  "With --baseline: the second camera turned this far (deg) towards the first (axes crossing in front)")
      ->group("Rig");
  cmd->add_option("--ep", o->ep, "Entrance pupil X,Y,Z in the housing frame, mm (default: the lens's)")
      ->delimiter(',')->expected(3)->group("Port");
  cmd->add_option("--medium", o->medium, "What is outside the port: water, or air (the in-air calibration)")
      ->capture_default_str();
  o->camera.Add(cmd);
  o->water.Add(cmd);
  cmd->add_option("--distance", o->distance_mm, "Target centre's distance from the entrance pupil, mm")
      ->capture_default_str()->group("Pose");
  cmd->add_option("--shift", o->shift, "Target centre X,Y off the axis (cam frame: X right, Y down), mm")
      ->delimiter(',')->expected(2)->group("Pose");
  cmd->add_option("--tilt", o->tilt, "Target tilt about its X, then its Y axis, deg")->delimiter(',')->expected(2)->group("Pose");
  cmd->add_option("--roll", o->roll_deg, "Target roll about the optical axis, deg")->group("Pose");
  cmd->add_option("--focus", o->focus, "'target' (focus on the target's virtual image) or the focus-scale distance FD, mm")
      ->capture_default_str()->group("Lens");
  cmd->add_option("--f-number", o->f_number, "Aperture (inf: a pinhole, no depth of field); lens: f/8, or the nearest the lens has (a fixed-aperture lens its own)")
      ->capture_default_str()->group("Lens");
  cmd->add_option("--vignetting", o->vignetting,
                  "The lens's natural vignetting: none, or natural (cos^4 for a rectilinear lens: the solid angle "
                  "each pixel sees times the pupil's foreshortening)")
      ->capture_default_str()->group("Lens");
  cmd->add_option("--vignetting-pa", o->vignetting_pa,
                  "The lens's own vignetting K1,K2,K3: lensfun's pa model 1 + K1 r^2 + K2 r^4 + K3 r^6, r = 1 at the "
                  "frame's corners (default none)")
      ->delimiter(',')->expected(3)->group("Lens");
  cmd->add_option("--camera-model", o->camera_model,
                  "Calibration of the camera, any format of porthole convert (any model; default: the ideal camera of the lens)")
      ->group("Lens");
  cmd->add_option("--c", o->c_mm, "Principal distance of the ideal camera, mm (default: thin lens at the focus)")
      ->group("Lens");
  cmd->add_option("--bands", o->bands, "Wavelength bands, nm (RGB: blue < 500, green 500-590, red >= 590)")
      ->delimiter(',')->capture_default_str()->group("Image");
  cmd->add_option("--color", o->color, "grey or rgb")->capture_default_str()->group("Image");
  cmd->add_option("--bit-depth", o->bit_depth, "PNG bits per channel: 8 or 16")->capture_default_str()->group("Image");
  cmd->add_option("--spp", o->spp, "Samples per pixel, a square (1, 4, 9, 16, ...)")->capture_default_str()->group("Image");
  cmd->add_option("--edge-spp", o->edge_spp,
                  "Samples per pixel near edges, a square above --spp (adaptive: pixels whose samples or neighbours "
                  "differ are rendered again with this many; 0: off)")
      ->capture_default_str()->group("Image");
  cmd->add_option("--seed", o->seed, "Random seed (the same seed gives the same image)")->capture_default_str()->group("Image");
  cmd->add_option("--exposure", o->exposure, "Pixel value = exposure x reflectance (white paper 0.9)")
      ->capture_default_str()->group("Image");
  cmd->add_flag("--white-on-black", o->white_on_black, "Print white on black: the ink reflects as the paper and back "
                "(coded targets under water)")->group("Image");
  cmd->add_option("--noise", o->noise, "Sensor noise FULL_WELL,READ in electrons (shot + read; default none)")
      ->delimiter(',')->expected(2)->group("Image");
  cmd->add_option("--set", o->set, "Render N seeded poses in water and in air into --out/water and --out/air")
      ->group("Set");
  cmd->add_option("--distances", o->distances, "Set: NEAR,FAR target distances, mm (default: the target fills 30-80 %)")
      ->delimiter(',')->group("Set");
  cmd->add_option("--max-tilt", o->max_tilt_deg, "Set: largest tilt about either axis, deg")->capture_default_str()->group("Set");
  cmd->add_option("--partial", o->partial,
                  "Set, coded targets: partial views, each pose showing at least this fraction of the targets whole "
                  "(the rest cut by the frame and left out of the truth); 1: the whole target")
      ->capture_default_str()->group("Set");
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->add_flag("--json", o->json, "Print what was written (files, size, time, rays blocked) as JSON");
  AddForceFlag(cmd, &o->force);
  cmd->footer("Outputs: --out NAME.png writes NAME.png and NAME.json (the ground truth); neither replaces an existing "
              "file without --force, nor an input (a --camera-model NAME.json) or a file another command wrote (a "
              "calibration, detections) even with it. --set N needs an empty or new folder; --force removes an "
              "earlier set's pose_NNN.png/.json first, so two sets never mix. A rig (--rig, --baseline): --out is a "
              "directory, DIR/<camera>/render.png and .json, or with --set N DIR/water/<camera>/ and "
              "DIR/air/<camera>/pose_NNN.png, one name per frame in every camera's folder.");
  cmd->callback([o, cmd] {
    o->inputs = InputFiles(cmd, {"--out"});
    if (!o->rig.empty() && o->baseline_mm) throw InvalidInput("--rig", "give a rig file or --baseline, not both");
    if (cmd->count("--convergence") > 0 && !o->baseline_mm) throw InvalidInput("--convergence", "goes with --baseline");
    // A camera model that is not of this camera: the library names it with its file.
    const std::string model_field = "camera_model '" + o->camera_model + "'";
    const std::string model_flag = "--camera-model '" + o->camera_model + "'";
    WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"subject_distance_mm", "--distance"}, {"focus_distance_mm", "--focus"},
                    {"focus", "--focus"}, {"f_number", "--f-number"}, {"c_mm", "--c"}, {"bands_nm", "--bands"}, {"lambda_nm", "--bands"},
                    {"samples_per_pixel", "--spp"}, {"edge_samples_per_pixel", "--edge-spp"}, {"exposure", "--exposure"},
                    {"full_well_e", "--noise"}, {"vignetting_pa", "--vignetting-pa"}, {"read_noise_e", "--noise"}, {"pose", "pose"}, {"target", "--target"},
                    {"bit_depth", "--bit-depth"}, {"count", "--set"}, {"max_tilt_deg", "--max-tilt"},
                    {"max_roll_deg", "--max-roll"}, {"min_whole_fraction", "--partial"}, {"near_mm", "--distances"},
                    {"far_mm", "--distances"}, {"field", "--field"}, {"baseline_mm", "--baseline"},
                    {"convergence_deg", "--convergence"}, {"out", "--out"}, {"cameras", "--rig"}, {"rig", "--rig"},
                    {"medium", "--medium"}, {"color", "--color"}, {"noise_e", "--noise"}, {"distance_mm", "--distance"},
                    {"camera_model", "--camera-model"}, {model_field, model_flag}},
                   [&] { RunRender(*o); });
  });
}

}  // namespace porthole::cli
