// `porthole render`: what the camera sees through the port — a calibration target at a pose,
// rendered through the camera model, the thin lens and the port in water or air, with a
// ground-truth JSON beside each image (docs/render.md). `--set N` renders N seeded poses in water
// and in air, ready for `porthole detect` and `porthole calibrate`.
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <cctype>

#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "porthole/calib/result_json.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/io/presets.h"
#include "porthole/measure/rig_model.h"
#include "porthole/render/render.h"
#include "porthole/render/rig.h"
#include "porthole/simulate/simulate.h"

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

// The ground truth beside a PNG: the same name, .json.
fs::path TruthPath(const fs::path& png) {
  fs::path json = png;
  json.replace_extension(".json");
  return json;
}

// Renders one scene and writes <png> and <png minus .png>.json, both whole or not at all, under the
// overwrite rule (`rules`, checked before rendering by the caller); returns what --json prints of it.
Json RenderOne(const render::Scene& scene, const render::RenderOptions& ro, int bit_depth, const fs::path& png,
               const std::string& label, bool quiet, const OutputRules& rules) {
  render::RenderOptions o = ro;
  int last_decile = 0;
  if (!quiet) {
    o.progress = [&](double f) {  // one line per tenth done
      const int decile = static_cast<int>(f * 10);
      if (decile > last_decile) fmt::print(stderr, "render: {} {}%\n", label, 10 * decile);
      last_decile = std::max(last_decile, decile);
    };
  }
  const render::Rendered r = render::Render(scene, o);
  const std::string bytes = render::EncodePng(r.image, bit_depth);
  const fs::path json = TruthPath(png);
  const std::string truth =
      render::TruthJson(scene, o, r, png.filename().string(), bit_depth).dump(1, ' ', false, Json::error_handler_t::replace) +
      "\n";
  WriteOutput(json, truth, "--out", rules);
  WriteOutput(png, bytes, "--out", rules);
  if (!quiet) {
    const std::string edges = o.edge_samples_per_pixel > o.samples_per_pixel
                                  ? fmt::format(" ({} near edges: {:.1f} % of the pixels)", o.edge_samples_per_pixel,
                                                100 * r.refined_fraction)
                                  : "";
    fmt::print(stderr, "render: {} {}x{} px, {} spp{}, {} bands in {:.1f} s; {:.2f} % of rays blocked by the housing\n",
               label, r.image.width, r.image.height, o.samples_per_pixel, edges, r.setup.bands.size(), r.seconds,
               100 * r.blocked_fraction);
    if (!r.left_out.partial.empty() || !r.left_out.occluded.empty()) {
      fmt::print(stderr, "render: {} {} targets in the truth; left out: {} not whole in the frame, {} hidden\n", label,
                 r.truth.size(), r.left_out.partial.size(), r.left_out.occluded.size());
    }
  }
  return Json{{"image", png.string()},        {"truth", json.string()},
              {"width_px", r.image.width},    {"height_px", r.image.height},
              {"points", r.truth.size()},     {"left_out_partial", r.left_out.partial.size()},
              {"left_out_occluded", r.left_out.occluded.size()}, {"blocked_fraction", r.blocked_fraction},
              {"refined_fraction", r.refined_fraction},
              {"seconds", r.seconds}};
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

// A calibration (any format of docs/interop.md), or the camera of a render's ground truth (its "camera"),
// checked against the body and lens it renders through (simulate::CheckAirCalibration).
camera::Camera LoadCameraModel(const std::string& path, const housing::HousedCamera& h) {
  const auto cam = [&] {
    if (fs::path(path).extension() == ".json") {
      // Through the same limits as every calibration reader (it had none: 283 MB took 6.5 GB).
      const std::string text = ReadInputFile(path, "--camera-model", kMaxCalibrationFileBytes);
      nlohmann::json j;
      try {
        j = ParseJsonText(text, "--camera-model", path);
      } catch (const InvalidInput&) {  // not JSON: the calibration readers below say why
      }
      if (j.is_object() && j.contains("points") && j.contains("camera") && j["camera"].is_object()) {
        return std::pair{calib::CalibrationFromJson(j["camera"], "--camera-model").camera, true};
      }
    }
    const interop::ReadResult r = interop::ReadCalibrationFile(path, h.camera.sensor.pixel_pitch_mm, "--camera-model");
    return std::pair{r.camera(), r.pitch_known};
  }();
  simulate::CheckAirCalibration(cam.first, cam.second, h, "--camera-model '" + path + "'");
  return cam.first;
}

// Whether `name` is one render --set writes: pose_NNN.png or pose_NNN.json.
bool IsSetFileName(const std::string& name) {
  const std::size_t dot = name.rfind('.');
  if (name.rfind("pose_", 0) != 0 || dot == std::string::npos || dot < 8) return false;
  const std::string ext = name.substr(dot);
  if (ext != ".png" && ext != ".json") return false;
  for (std::size_t i = 5; i < dot; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) return false;
  }
  return true;
}

// A set goes into an empty (or new) folder: an earlier set's poses mixed with this one's would be
// calibrated together. Under --force the earlier set's own files (water/ and air/ pose_NNN.png and
// .json, the .json a render ground truth) are removed first, all checked before the first is
// removed; anything else is left, and an input or another command's file stops the run.
void ClearEarlierSet(const fs::path& out, const OutputRules& rules) {
  std::error_code ec;
  if (!fs::is_directory(out, ec) || fs::is_empty(out, ec)) return;
  if (!rules.force) {
    throw InvalidInput("--out", out.string() + " is not empty (an earlier set?): --force removes the earlier set's "
                                "images and ground truth first, or choose an empty folder");
  }
  std::vector<fs::path> remove;
  std::vector<fs::path> dirs;  // water/, air/ and, for a rig, their camera folders
  for (const char* medium : {"water", "air"}) {
    const fs::path dir = out / medium;
    if (!fs::is_directory(fs::symlink_status(dir, ec))) continue;
    dirs.push_back(dir);
    for (const auto& e : fs::directory_iterator(dir)) {
      if (fs::is_directory(fs::symlink_status(e.path(), ec))) dirs.push_back(e.path());
    }
  }
  for (const fs::path& dir : dirs) {
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      if (!IsSetFileName(name)) continue;
      if (!fs::is_regular_file(fs::symlink_status(e.path(), ec))) {
        throw InvalidInput("--out", e.path().string() + " is not a regular file: not removed");
      }
      // The one overwrite rule (core/output.h) decides: never an input, a .json only a ground truth.
      CheckOutput(e.path(), "--out", rules, e.path().extension() == ".json" ? FileKind::kGroundTruth : FileKind::kOther);
      remove.push_back(e.path());
    }
  }
  for (const fs::path& p : remove) fs::remove(p);
}

// The rig of --rig (a rig JSON: each camera's calibration, cam_from_rig and port, when it has one) or
// of --baseline/--convergence (two of the scene's camera behind the scene's port).
std::vector<render::RigCamera> RigCameras(const RenderCliOptions& o, const render::Scene& scene) {
  if (o.baseline_mm) return render::DescribedRig(2, *o.baseline_mm, o.convergence_deg);
  const measure::Rig rig = measure::LoadRig(o.rig, "--rig");
  // The ports' names (their glass's dispersion), which the rig model does not keep.
  const nlohmann::json j = ParseJsonText(ReadInputFile(o.rig, "--rig", kMaxCalibrationFileBytes), "--rig", o.rig);
  std::vector<render::RigCamera> cams;
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    const measure::RigCamera& rc = rig.cameras[k];
    render::RigCamera c;
    c.name = rc.name;
    c.camera = rc.camera;
    c.cam_from_rig.rotation = rc.CamFromRigRotation();
    c.cam_from_rig.translation_mm = rc.translation_mm;
    c.port_use = render::RigCamera::PortUse::kNone;
    if (rc.shell) {
      const auto& pj = j["rig"]["cameras"][k]["port"];
      const std::string name = pj.contains("name") && pj["name"].is_string() ? pj["name"].get<std::string>() : "";
      std::string material = scene.housed.port.material();
      try {
        material = io::LoadPort(name).material();
      } catch (const InvalidInput&) {
        if (!o.quiet) {
          fmt::print(stderr, "porthole: note: --rig: camera {}'s port '{}' is no preset or port file here: its glass "
                             "taken as {} (--port's)\n", rc.name, name, material);
        }
      }
      c.port_use = render::RigCamera::PortUse::kOwn;
      c.port = refraction::PortSpecOf(*rc.shell, rc.port, material, name.empty() ? rc.name + "-port" : name);
    }
    cams.push_back(std::move(c));
  }
  return cams;
}

void RunRender(const RenderCliOptions& o) {
  render::Scene scene;
  const bool bare = o.port == "none";  // the lens alone: the port only places the pupil
  scene.housed = o.camera.ToHoused(PortOptions{bare ? PortOptions{}.port : o.port, o.ep}, o.water);
  scene.bare = bare;
  const bool rig = !o.rig.empty() || o.baseline_mm.has_value();
  scene.target = calib::ParseTarget(o.target);
  if (!o.field.empty()) calib::LoadTargetField(o.field, &scene.target);
  if (o.medium != "water" && o.medium != "air") throw InvalidInput("--medium", "must be water or air");
  scene.medium = o.medium == "air" ? render::Medium::kAir : render::Medium::kWater;
  if (o.focus != "target") scene.focus_distance_mm = ParseLengthOrInf(o.focus, "--focus");
  scene.f_number = o.f_number == "lens" ? lens::DefaultFNumber(scene.housed.lens) : ParseFNumber(o.f_number);
  if (o.vignetting != "none" && o.vignetting != "natural") throw InvalidInput("--vignetting", "must be none or natural");
  scene.natural_vignetting = o.vignetting == "natural";
  if (!o.vignetting_pa.empty()) scene.vignetting_pa = {o.vignetting_pa[0], o.vignetting_pa[1], o.vignetting_pa[2]};
  // Outputs are checked before anything is read or rendered: an input named as an output is refused
  // as that, whatever else is wrong with it.
  if (o.out.empty()) throw InvalidInput("--out", "is required: the PNG file (single image) or a directory (--set)");
  const OutputRules rules{.force = o.force, .inputs = o.inputs};
  if (o.set == 0 && !rig) {
    if (fs::path(o.out).extension() != ".png") throw InvalidInput("--out", "must name a .png file");
    CheckOutput(o.out, "--out", rules);  // before the long work: both files, the .json as a ground truth
    CheckOutput(TruthPath(o.out), "--out", rules, FileKind::kGroundTruth);
  }
  if (!o.camera_model.empty()) scene.camera = LoadCameraModel(o.camera_model, scene.housed);
  scene.c_mm = o.c_mm;
  scene.bands_nm = o.bands;
  if (o.white_on_black) std::swap(scene.style.black, scene.style.white);
  render::RenderOptions ro;
  ro.samples_per_pixel = o.spp;
  ro.edge_samples_per_pixel = o.edge_spp;
  ro.seed = o.seed;
  ro.exposure = o.exposure;
  if (!o.noise.empty()) {
    ro.full_well_e = RequirePositive("--noise", o.noise[0]);
    ro.read_noise_e = o.noise[1];
  }
  if (o.color != "grey" && o.color != "rgb") throw InvalidInput("--color", "must be grey or rgb");
  ro.color = o.color == "rgb" ? render::ColorMode::kRgb : render::ColorMode::kGrey;
  render::Validate(ro);
  if (o.bit_depth != 8 && o.bit_depth != 16) throw InvalidInput("--bit-depth", "must be 8 or 16");
  if (o.shift.size() != 2 || o.tilt.size() != 2) throw InvalidInput("--shift", "--shift and --tilt take X,Y");

  if (rig) {  // every camera of the rig: the library renders and writes (render/rig.h)
    const std::vector<render::RigCamera> cams = RigCameras(o, scene);
    render::RigRenderOptions ro_rig;
    ro_rig.render = ro;
    ro_rig.bit_depth = o.bit_depth;
    ro_rig.set_count = o.set;
    ro_rig.set.max_tilt_deg = o.max_tilt_deg;
    ro_rig.set.max_roll_deg = 15;
    ro_rig.set.min_whole_fraction = o.partial;
    if (!o.distances.empty()) {
      const auto d = ParseLengthList(o.distances, "--distances");
      if (d.size() != 2) throw InvalidInput("--distances", "takes NEAR,FAR in mm");
      ro_rig.set.near_mm = d[0];
      ro_rig.set.far_mm = d[1];
    }
    ro_rig.out = o.out;
    ro_rig.rules = rules;
    if (!o.quiet) ro_rig.log = [](const std::string& line) { fmt::print(stderr, "render: {}\n", line); };
    if (o.set > 0) ro_rig.prepare = [&] { ClearEarlierSet(o.out, rules); };
    if (o.set == 0) {  // the target's pose in the rig frame (the first camera's)
      RequireFinite("--distance", o.distance_mm);
      scene.pose = render::PoseFacing(scene.target, o.distance_mm, {o.shift[0], o.shift[1]}, o.tilt[0], o.tilt[1],
                                      o.roll_deg);
    }
    const Json j = render::RenderRig(scene, cams, ro_rig);
    if (o.json) fmt::print("{}\n", PrintableJson(j));
    if (!o.quiet) {
      std::string names;
      for (const auto& c : cams) names += (names.empty() ? "" : ", ") + c.name;
      fmt::print(stderr, "render: {} frame{} of {} cameras ({}) in {}\n", j["frames"].get<int>(),
                 j["frames"].get<int>() == 1 ? "" : "s", cams.size(), names, o.out);
    }
    return;
  }

  if (o.set == 0) {
    const fs::path png = o.out;
    RequireFinite("--distance", o.distance_mm);
    scene.pose = render::PoseFacing(scene.target, o.distance_mm, {o.shift[0], o.shift[1]}, o.tilt[0], o.tilt[1],
                                    o.roll_deg);
    const Json j = RenderOne(scene, ro, o.bit_depth, png, png.filename().string(), o.quiet, rules);
    if (o.json) fmt::print("{}\n", PrintableJson(j));
    return;
  }

  // A set: one focus for every image (on the middle distance under water unless --focus gives
  // FD), the same poses in water and in air.
  render::SetOptions so;
  so.count = o.set;
  so.seed = o.seed;
  so.max_tilt_deg = o.max_tilt_deg;
  so.max_roll_deg = 15;
  so.min_whole_fraction = o.partial;
  if (!o.distances.empty()) {
    const auto d = ParseLengthList(o.distances, "--distances");
    if (d.size() != 2) throw InvalidInput("--distances", "takes NEAR,FAR in mm");
    so.near_mm = d[0];
    so.far_mm = d[1];
  }
  if (!scene.focus_distance_mm) {
    render::Scene probe = scene;
    probe.focus_distance_mm = std::numeric_limits<double>::infinity();
    const render::Setup s = render::Resolve(probe);
    // The middle of the distances the set will use: the given ones, or those SetPoses chooses.
    double mid = 0.5 * (so.near_mm + so.far_mm);
    if (mid == 0) {
      const auto pts = calib::TargetPoints(scene.target);
      double span = 0;
      for (const auto& p : pts) span = std::max(span, (p - pts.front()).norm());
      mid = 0.5 * (1 / 0.8 + 1 / 0.3) * s.camera.FocalLengthPx() * span / s.camera.sensor.width_px;
    }
    // On its virtual image under water (the lens alone: on the distance itself); closer than the
    // lens focuses: its closest focus, as a camera would.
    bool closest = false;
    scene.focus_distance_mm = render::SetFocusDistanceMm(scene, so, 0, &closest);
    if (closest && !o.quiet) {
      fmt::print(stderr, "porthole: note: the lens cannot focus on the set's middle distance ({:.0f} mm){}; focused "
                         "at its closest, {:g} mm\n", mid, bare ? "" : " under water", scene.housed.lens.min_focus_mm);
    }
  }
  const auto poses = render::SetPoses(scene, so);  // bad options fail here, before any directory exists
  ClearEarlierSet(o.out, rules);
  EnsureOutputDirectory(o.out, "--out");
  // The lens alone (--port none): the water images would be the air ones.
  const std::vector<render::Medium> media =
      bare ? std::vector<render::Medium>{render::Medium::kAir}
           : std::vector<render::Medium>{render::Medium::kWater, render::Medium::kAir};
  for (const render::Medium m : media) {
    EnsureOutputDirectory((fs::path(o.out) / (m == render::Medium::kWater ? "water" : "air")).string(), "--out");
  }
  Json images = {{"water", Json::array()}, {"air", Json::array()}};
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (const render::Medium m : media) {
      render::Scene sc = scene;
      sc.pose = poses[i];
      sc.medium = m;
      render::RenderOptions r = ro;
      r.seed = o.seed + i;
      const std::string dir = m == render::Medium::kWater ? "water" : "air";
      const fs::path png = fs::path(o.out) / dir / fmt::format("pose_{:03d}.png", i);
      images[dir].push_back(RenderOne(sc, r, o.bit_depth, png, dir + "/" + png.filename().string(), o.quiet, rules));
    }
  }
  if (o.json) {
    fmt::print("{}\n", PrintableJson(Json{{"poses", poses.size()}, {"focus_distance_mm", Length(*scene.focus_distance_mm)},
                                          {"images", images}}));
  }
  if (!o.quiet) {
    const std::string where = bare ? (fs::path(o.out) / "air").string() + " (the lens alone: no water set)"
                                   : (fs::path(o.out) / "water").string() + " and " + (fs::path(o.out) / "air").string();
    fmt::print(stderr, "render: {} poses in {}; focus scale {:.1f} mm\n", poses.size(), where, *scene.focus_distance_mm);
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
    WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"subject_distance_mm", "--distance"}, {"focus_distance_mm", "--focus"},
                    {"focus", "--focus"}, {"f_number", "--f-number"}, {"c_mm", "--c"}, {"bands_nm", "--bands"}, {"lambda_nm", "--bands"},
                    {"samples_per_pixel", "--spp"}, {"edge_samples_per_pixel", "--edge-spp"}, {"exposure", "--exposure"},
                    {"full_well_e", "--noise"}, {"vignetting_pa", "--vignetting-pa"}, {"read_noise_e", "--noise"}, {"pose", "pose"}, {"target", "--target"},
                    {"bit_depth", "--bit-depth"}, {"count", "--count"}, {"max_tilt_deg", "--max-tilt"},
                    {"max_roll_deg", "--max-roll"}, {"min_whole_fraction", "--partial"}, {"near_mm", "--distances"},
                    {"far_mm", "--distances"}, {"field", "--field"}, {"baseline_mm", "--baseline"},
                    {"convergence_deg", "--convergence"}, {"out", "--out"}, {"cameras", "--rig"}},
                   [&] { RunRender(*o); });
  });
}

}  // namespace porthole::cli
