#include "porthole/render/job.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <system_error>

#include "porthole/calib/result_json.h"
#include "porthole/calib/target.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/housing/plausible.h"
#include "porthole/interop/interop.h"
#include "porthole/catalogue/presets.h"
#include "porthole/lens/lens.h"
#include "porthole/measure/rig_model.h"
#include "porthole/simulate/simulate.h"

namespace porthole::render {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

fs::path TruthPath(const fs::path& png) {
  fs::path json = png;
  json.replace_extension(".json");
  return json;
}

// The text of a ground truth as written, and read back (the replacement of bad UTF-8 included).
std::string TruthText(const Json& truth) { return truth.dump(1, ' ', false, Json::error_handler_t::replace) + "\n"; }

void Say(const std::function<void(const std::string&)>& f, const std::string& line) {
  if (f) f(line);
}

// A directory, made if missing, that this process can write into.
void EnsureDirectory(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw InvalidInput("out", dir.string() + " exists and is not a directory");
  } else if (!fs::create_directories(dir, ec) && !fs::is_directory(dir)) {
    throw InvalidInput("out", fmt::format("cannot create {}: {}", dir.string(), ec ? ec.message() : "unknown error"));
  }
  if (!fs::is_directory(dir)) throw InvalidInput("out", dir.string() + " is not a directory");
  if (access(dir.c_str(), W_OK | X_OK) != 0) throw InvalidInput("out", dir.string() + " is not writable");
}

// A calibration (any format of docs/interop.md), or the camera of a render's ground truth (its
// "camera"), checked against the body and lens it renders through (simulate::CheckAirCalibration).
camera::Camera LoadCameraModel(const std::string& path, const housing::HousedCamera& h) {
  const auto cam = [&] {
    if (fs::path(path).extension() == ".json") {
      // Through the same limits as every calibration reader (it had none: 283 MB took 6.5 GB).
      const std::string text = ReadInputFile(path, "camera_model", kMaxCalibrationFileBytes);
      nlohmann::json j;
      try {
        j = ParseJsonText(text, "camera_model", path);
      } catch (const InvalidInput&) {  // not JSON: the calibration readers below say why
      }
      if (j.is_object() && j.contains("points") && j.contains("camera") && j["camera"].is_object()) {
        return std::pair{calib::CalibrationFromJson(j["camera"], "camera_model").camera, true};
      }
    }
    const interop::ReadResult r = interop::ReadCalibrationFile(path, h.camera.sensor.pixel_pitch_mm, "camera_model");
    return std::pair{r.camera(), r.pitch_known};
  }();
  simulate::CheckAirCalibration(cam.first, cam.second, h, "camera_model '" + path + "'");
  return cam.first;
}

// The scene and the render options the job's options describe, checked in the order the CLI always
// had: target, medium, focus, outputs (before anything is read), camera model, image options.
struct Prepared {
  Scene scene;
  RenderOptions render;
  bool rig = false;
};

Prepared Prepare(const RenderJobOptions& o) {
  Prepared p;
  Scene& scene = p.scene;
  scene.housed = o.housed;
  scene.bare = o.bare;
  p.rig = !o.rig.empty() || o.rig_json.has_value() || o.baseline_mm.has_value();
  if (int(!o.rig.empty()) + int(o.rig_json.has_value()) + int(o.baseline_mm.has_value()) > 1) {
    throw InvalidInput("rig", "give a rig file or `baseline_mm`, not both");
  }
  if (o.set_count < 0 || o.set_count > 10000) throw InvalidInput("count", "must be 1 to 10000 (0: one image)");
  scene.target = calib::ParseTarget(o.target);
  if (!o.field.empty()) calib::LoadTargetField(o.field, &scene.target);
  if (o.medium != "water" && o.medium != "air") throw InvalidInput("medium", "must be water or air");
  scene.medium = o.medium == "air" ? Medium::kAir : Medium::kWater;
  if (o.focus_distance_mm && !(*o.focus_distance_mm > 0)) {
    throw InvalidInput("focus_distance_mm", "must be > 0 mm (infinity: focused at infinity; unset: on the target)");
  }
  scene.focus_distance_mm = o.focus_distance_mm;
  if (o.f_number && !(*o.f_number > 0)) throw InvalidInput("f_number", "must be > 0 (infinity: a pinhole)");
  scene.f_number = o.f_number ? *o.f_number : lens::DefaultFNumber(scene.housed.lens);
  scene.natural_vignetting = o.natural_vignetting;
  scene.vignetting_pa = o.vignetting_pa;
  // Outputs are checked before anything is read or rendered: an input named as an output is refused
  // as that, whatever else is wrong with it.
  if (o.out.empty()) throw InvalidInput("out", "is required: the PNG file (single image) or a directory (`set`)");
  if (o.set_count == 0 && !p.rig) {
    if (o.out.extension() != ".png") throw InvalidInput("out", "must name a .png file");
    CheckOutput(o.out, "out", o.rules);  // before the long work: both files, the .json as a ground truth
    CheckOutput(TruthPath(o.out), "out", o.rules, FileKind::kGroundTruth);
  }
  if (!o.camera_model.empty()) scene.camera = LoadCameraModel(o.camera_model, scene.housed);
  scene.c_mm = o.c_mm;
  scene.bands_nm = o.bands_nm;
  if (o.white_on_black) std::swap(scene.style.black, scene.style.white);
  p.render = o.render;
  p.render.progress = nullptr;
  if (o.noise_e) {
    p.render.full_well_e = RequirePositive("noise_e", (*o.noise_e)[0]);
    p.render.read_noise_e = (*o.noise_e)[1];
  }
  if (o.color != "grey" && o.color != "rgb") throw InvalidInput("color", "must be grey or rgb");
  p.render.color = o.color == "rgb" ? ColorMode::kRgb : ColorMode::kGrey;
  Validate(p.render);
  if (o.bit_depth != 8 && o.bit_depth != 16) throw InvalidInput("bit_depth", "must be 8 or 16");
  return p;
}

SetOptions SetOptionsOf(const RenderJobOptions& o) {
  SetOptions so;
  so.count = o.set_count;
  so.seed = o.render.seed;
  so.max_tilt_deg = o.max_tilt_deg;
  so.max_roll_deg = 15;
  so.min_whole_fraction = o.min_whole_fraction;
  if (o.distances_mm) {
    so.near_mm = (*o.distances_mm)[0];
    so.far_mm = (*o.distances_mm)[1];
  }
  return so;
}

Pose PoseOf(const RenderJobOptions& o, const calib::TargetSpec& target) {
  RequireFinite("distance_mm", o.distance_mm);
  return PoseFacing(target, o.distance_mm, o.shift_mm, o.tilt_deg.x(), o.tilt_deg.y(), o.roll_deg);
}

// A set goes into an empty (or new) folder: an earlier set's poses mixed with this one's would be
// calibrated together. Under `force` the earlier set's own files (water/ and air/ pose_NNN.png and
// .json, the .json a render ground truth; for a rig, in their camera folders) are removed first,
// all checked before the first is removed; anything else is left, and an input or another
// command's file stops the run.
void ClearEarlierSet(const fs::path& out, const OutputRules& rules) {
  std::error_code ec;
  if (!fs::is_directory(out, ec) || fs::is_empty(out, ec)) return;
  if (!rules.force) {
    throw InvalidInput("out", out.string() + " is not empty (an earlier set?): `force` removes the earlier set's "
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
        throw InvalidInput("out", e.path().string() + " is not a regular file: not removed");
      }
      // The one overwrite rule (core/output.h) decides: never an input, a .json only a ground truth.
      CheckOutput(e.path(), "out", rules, e.path().extension() == ".json" ? FileKind::kGroundTruth : FileKind::kOther);
      remove.push_back(e.path());
    }
  }
  for (const fs::path& p : remove) fs::remove(p);
}

// Renders one scene and writes <png> and <png minus .png>.json, both whole or not at all; returns
// what --json lists of it. `label` names it in the progress lines.
JobImage RenderOne(const Scene& scene, const RenderOptions& ro, const RenderJobOptions& o, const fs::path& png,
                   const std::string& label) {
  RenderOptions opts = ro;
  int last_decile = 0;
  if (o.log) {
    opts.progress = [&](double f) {  // one line per tenth done
      const int decile = static_cast<int>(f * 10);
      if (decile > last_decile) o.log(fmt::format("{} {}%", label, 10 * decile));
      last_decile = std::max(last_decile, decile);
    };
  }
  Rendered r = Render(scene, opts);
  const std::string bytes = EncodePng(r.image, o.bit_depth);
  JobImage out;
  out.image = png;
  out.truth = TruthPath(png);
  const std::string truth = TruthText(TruthJson(scene, opts, r, png.filename().string(), o.bit_depth));
  WriteOutput(out.truth, truth, "out", o.rules);
  WriteOutput(png, bytes, "out", o.rules);
  if (o.log) {
    const std::string edges = opts.edge_samples_per_pixel > opts.samples_per_pixel
                                  ? fmt::format(" ({} near edges: {:.1f} % of the pixels)",
                                                opts.edge_samples_per_pixel, 100 * r.refined_fraction)
                                  : "";
    o.log(fmt::format("{} {}x{} px, {} spp{}, {} bands in {:.1f} s; {:.2f} % of rays blocked by the housing", label,
                      r.image.width, r.image.height, opts.samples_per_pixel, edges, r.setup.bands.size(), r.seconds,
                      100 * r.blocked_fraction));
    if (!r.left_out.partial.empty() || !r.left_out.occluded.empty()) {
      o.log(fmt::format("{} {} targets in the truth; left out: {} not whole in the frame, {} hidden", label,
                        r.truth.size(), r.left_out.partial.size(), r.left_out.occluded.size()));
    }
  }
  out.medium = scene.medium == Medium::kWater && !scene.bare ? "water" : "air";
  out.frame = png.stem().string();
  out.summary = Json{{"image", png.string()},
                     {"truth", out.truth.string()},
                     {"width_px", r.image.width},
                     {"height_px", r.image.height},
                     {"points", r.truth.size()},
                     {"left_out_partial", r.left_out.partial.size()},
                     {"left_out_occluded", r.left_out.occluded.size()},
                     {"blocked_fraction", r.blocked_fraction},
                     {"refined_fraction", r.refined_fraction},
                     {"seconds", r.seconds}};
  if (o.keep_truth) out.ground_truth = Json::parse(truth);
  if (o.keep_pixels) out.pixels = std::move(r.image);
  return out;
}

// A length for JSON as the CLI writes it: a number, "inf" for infinity.
Json LengthJson(double mm) { return std::isinf(mm) ? Json("inf") : Json(mm); }

// N seeded poses of one camera, each in water and in air (the lens alone: air only).
RenderJobResult RenderSet(Scene scene, const RenderOptions& ro, const RenderJobOptions& o) {
  const SetOptions so = SetOptionsOf(o);
  if (!scene.focus_distance_mm) {
    // One focus for every image: on the middle distance under water (the lens alone: on the
    // distance itself); closer than the lens focuses: its closest focus, as a camera would.
    bool closest = false;
    double middle_mm = 0;
    scene.focus_distance_mm = SetFocusDistanceMm(scene, so, 0, &closest, &middle_mm);
    if (closest) {
      Say(o.note, fmt::format("the lens cannot focus on the set's middle distance ({:.0f} mm){}; focused at its "
                              "closest, {:g} mm",
                              middle_mm, scene.bare ? "" : " under water", scene.housed.lens.min_focus_mm));
    }
  }
  const std::vector<Pose> poses = SetPoses(scene, so);  // bad options fail here, before any directory exists
  ClearEarlierSet(o.out, o.rules);
  EnsureDirectory(o.out);
  // The lens alone: the water images would be the air ones.
  const std::vector<Medium> media =
      scene.bare ? std::vector<Medium>{Medium::kAir} : std::vector<Medium>{Medium::kWater, Medium::kAir};
  for (const Medium m : media) EnsureDirectory(o.out / (m == Medium::kWater ? "water" : "air"));
  RenderJobResult result;
  Json images = {{"water", Json::array()}, {"air", Json::array()}};
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (const Medium m : media) {
      Scene sc = scene;
      sc.pose = poses[i];
      sc.medium = m;
      RenderOptions r = ro;
      r.seed = o.render.seed + i;
      const std::string dir = m == Medium::kWater ? "water" : "air";
      const fs::path png = o.out / dir / fmt::format("pose_{:03d}.png", i);
      JobImage image = RenderOne(sc, r, o, png, dir + "/" + png.filename().string());
      image.medium = dir;
      images[dir].push_back(image.summary);
      result.images.push_back(std::move(image));
    }
  }
  result.frames = static_cast<int>(poses.size());
  result.focus_distance_mm = {*scene.focus_distance_mm};
  result.summary = Json{{"poses", poses.size()}, {"focus_distance_mm", LengthJson(*scene.focus_distance_mm)},
                        {"images", images}};
  return result;
}

// Every camera of the rig (RenderRig), one frame or a set.
RenderJobResult RenderRigJob(Scene scene, const RenderOptions& ro, const RenderJobOptions& o) {
  std::vector<RigCamera> cams;
  if (o.baseline_mm) {
    cams = DescribedRig(2, *o.baseline_mm, o.convergence_deg);
  } else if (o.rig_json) {
    cams = RigCamerasOf(*o.rig_json, scene.housed.port.material(), o.note);
  } else {
    cams = LoadRigCameras(o.rig, scene.housed.port.material(), o.note);
  }
  RigRenderOptions rro;
  rro.render = ro;
  rro.bit_depth = o.bit_depth;
  rro.set_count = o.set_count;
  rro.set = SetOptionsOf(o);
  rro.out = o.out;
  rro.rules = o.rules;
  rro.log = o.log;
  if (o.set_count > 0) rro.prepare = [&] { ClearEarlierSet(o.out, o.rules); };
  if (o.set_count == 0) scene.pose = PoseOf(o, scene.target);  // the target's pose in the rig frame
  RenderJobResult result;
  rro.written = [&](const RigImage& w) {
    JobImage image;
    image.camera = cams[w.camera].name;
    image.medium = w.medium;
    image.frame = w.frame;
    image.image = w.summary["image"].get<std::string>();
    image.truth = w.summary["truth"].get<std::string>();
    image.summary = w.summary;
    if (o.keep_truth) image.ground_truth = Json::parse(w.truth_text);
    if (o.keep_pixels) image.pixels = w.rendered.image;
    result.images.push_back(std::move(image));
  };
  result.summary = RenderRig(scene, cams, rro);
  for (const RigCamera& c : cams) result.cameras.push_back(c.name);
  result.frames = result.summary["frames"].get<int>();
  if (result.summary.contains("focus_distance_mm")) {
    for (const auto& f : result.summary["focus_distance_mm"]) result.focus_distance_mm.push_back(f.get<double>());
  }
  return result;
}

// The render cameras of a rig read by measure/: each camera's calibration, cam_from_rig and port
// (or none); the port's glass from the preset or port file the rig JSON `j` names (else
// `fallback_material`, with a note).
std::vector<RigCamera> CamerasOf(const measure::Rig& rig, const nlohmann::json* j, const std::string& fallback_material,
                                 const std::function<void(const std::string&)>& note) {
  std::vector<RigCamera> cams;
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    const measure::RigCamera& rc = rig.cameras[k];
    RigCamera c;
    c.name = rc.name;
    c.camera = rc.camera;
    c.cam_from_rig.rotation = rc.CamFromRigRotation();
    c.cam_from_rig.translation_mm = rc.translation_mm;
    c.port_use = RigCamera::PortUse::kNone;
    if (rc.shell) {
      // The port's name (its glass's dispersion), which the rig model does not keep.
      std::string name;
      if (j && (*j)["rig"]["cameras"][k].contains("port")) {
        const auto& pj = (*j)["rig"]["cameras"][k]["port"];
        if (pj.is_object() && pj.contains("name") && pj["name"].is_string()) name = pj["name"].get<std::string>();
      }
      std::string material = fallback_material;
      try {
        material = catalogue::LoadPort(name).material();
      } catch (const InvalidInput&) {
        Say(note, fmt::format("`rig`: camera {}'s port '{}' is no preset or port file here: its glass taken as {} "
                              "(`port`'s)", rc.name, name, material));
      }
      c.port_use = RigCamera::PortUse::kOwn;
      c.port = refraction::PortSpecOf(*rc.shell, rc.port, material, name.empty() ? rc.name + "-port" : name);
    }
    cams.push_back(std::move(c));
  }
  return cams;
}

}  // namespace

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

std::vector<RigCamera> RigCamerasOf(const nlohmann::json& j, const std::string& fallback_material,
                                    const std::function<void(const std::string&)>& note) {
  return CamerasOf(measure::RigFromJson(j, "rig"), &j, fallback_material, note);
}

std::vector<RigCamera> LoadRigCameras(const std::string& path, const std::string& fallback_material,
                                      const std::function<void(const std::string&)>& note) {
  const measure::Rig rig = measure::LoadRig(path, "rig");  // any rig format
  const bool ports = std::any_of(rig.cameras.begin(), rig.cameras.end(), [](const auto& c) { return c.shell; });
  if (!ports) return CamerasOf(rig, nullptr, fallback_material, note);
  // The ports' names, which only porthole's rig JSON holds.
  const nlohmann::json j = ParseJsonText(ReadInputFile(path, "rig", kMaxCalibrationFileBytes), "rig", path);
  return CamerasOf(rig, &j, fallback_material, note);
}

RenderJobResult RenderJob(const RenderJobOptions& o) {
  Prepared p = Prepare(o);
  RenderJobResult result;
  if (p.rig) {
    result = RenderRigJob(p.scene, p.render, o);
  } else if (o.set_count > 0) {
    result = RenderSet(p.scene, p.render, o);
  } else {
    p.scene.pose = PoseOf(o, p.scene.target);
    JobImage image = RenderOne(p.scene, p.render, o, o.out, o.out.filename().string());
    result.summary = image.summary;
    result.frames = 1;
    result.images.push_back(std::move(image));
  }
  result.warnings = housing::PlausibilityWarnings(o.housed);
  return result;
}

}  // namespace porthole::render
