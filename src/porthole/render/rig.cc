#include "porthole/render/rig.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <system_error>

#include "porthole/core/error.h"
#include "porthole/housing/housed.h"

namespace porthole::render {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

Json PoseJson(const Pose& p) {
  Json rot = Json::array();
  for (int i = 0; i < 3; ++i) rot.push_back({p.rotation(i, 0), p.rotation(i, 1), p.rotation(i, 2)});
  const Eigen::AngleAxisd aa(p.rotation);
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  return {{"rotation", rot},
          {"rotation_rad", {r.x(), r.y(), r.z()}},
          {"translation_mm", {p.translation_mm.x(), p.translation_mm.y(), p.translation_mm.z()}}};
}

// The focus on a subject `subject_mm` in front of the pupil: on its virtual image behind the port,
// on the subject itself for a bare lens.
housing::Focused FocusOn(const Scene& scene, double subject_mm) {
  if (!scene.bare) return housing::FocusOnSubject(scene.housed, subject_mm);
  const housing::Focused f = housing::SolveFocus(scene.housed, [&](const ports::PortSystem&) { return subject_mm; });
  if (!f.focus.focus_distance_mm) {
    throw InvalidInput("subject_distance_mm", fmt::format("the {} focuses no closer than {:g} mm", scene.housed.lens.name,
                                                          scene.housed.lens.min_focus_mm));
  }
  return f;
}

void MakeDirectory(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw InvalidInput("out", dir.string() + " exists and is not a directory");
    return;
  }
  if (!fs::create_directories(dir, ec) && !fs::is_directory(dir, ec)) {
    throw InvalidInput("out", fmt::format("cannot create {}: {}", dir.string(), ec ? ec.message() : "unknown error"));
  }
}

fs::path TruthPathOf(const fs::path& png) {
  fs::path j = png;
  j.replace_extension(".json");
  return j;
}

}  // namespace

std::vector<RigCamera> DescribedRig(int n, double baseline_mm, double convergence_deg) {
  if (n < 2) throw InvalidInput("cameras", "a rig needs 2 or more cameras");
  if (!(baseline_mm > 0) || !std::isfinite(baseline_mm)) throw InvalidInput("baseline_mm", "must be > 0 mm");
  if (!(convergence_deg >= 0 && convergence_deg < 45)) throw InvalidInput("convergence_deg", "must be in [0, 45) degrees");
  std::vector<RigCamera> rig;
  for (int k = 0; k < n; ++k) {
    RigCamera c;
    c.name = fmt::format("cam{}", k);
    if (k > 0) {
      c.cam_from_rig.rotation =
          Eigen::AngleAxisd(convergence_deg * std::numbers::pi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
      c.cam_from_rig.translation_mm = -c.cam_from_rig.rotation * Eigen::Vector3d(baseline_mm * k, 0, 0);
    }
    rig.push_back(std::move(c));
  }
  return rig;
}

void ValidateRig(const std::vector<RigCamera>& cameras) {
  if (cameras.empty()) throw InvalidInput("cameras", "a rig needs at least one camera");
  std::set<std::string> names;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const RigCamera& c = cameras[k];
    const std::string f = fmt::format("camera {}", k);
    bool ok = !c.name.empty() && c.name.size() <= 64 && c.name.front() != '.' && c.name.front() != '-';
    for (char ch : c.name) {
      ok = ok && (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.');
    }
    if (!ok) {
      throw InvalidInput("cameras", fmt::format("{}: its name '{}' is not a usable folder name (1-64 letters, digits, "
                                                "'_', '-', '.'; not starting with '.' or '-')", f, c.name));
    }
    if (!names.insert(c.name).second) throw InvalidInput("cameras", fmt::format("'{}' names two cameras", c.name));
    if (c.camera) camera::ValidateCamera(*c.camera, "cameras." + c.name + ".camera");
    if (c.port_use == RigCamera::PortUse::kOwn) ports::Validate(c.port, "cameras." + c.name + ".port");
    if (!c.cam_from_rig.rotation.allFinite() || !c.cam_from_rig.translation_mm.allFinite() ||
        (c.cam_from_rig.rotation.transpose() * c.cam_from_rig.rotation - Eigen::Matrix3d::Identity()).norm() > 1e-9 ||
        !(c.cam_from_rig.rotation.determinant() > 0)) {
      throw InvalidInput("cameras." + c.name + ".cam_from_rig", "must be a rotation and a finite translation (mm)");
    }
  }
}

Scene CameraScene(const Scene& base, const RigCamera& cam, const Pose& rig_from_target) {
  Scene s = base;
  if (cam.camera) s.camera = cam.camera;
  if (cam.port_use == RigCamera::PortUse::kOwn) s.housed.port = cam.port;
  s.bare = cam.port_use == RigCamera::PortUse::kNone || (cam.port_use == RigCamera::PortUse::kScene && base.bare);
  s.pose = Compose(cam.cam_from_rig, rig_from_target);
  return s;
}

double SetFocusDistanceMm(const Scene& scene, const SetOptions& so, double baseline_mm, bool* closest,
                          double* middle_mm) {
  if (closest) *closest = false;
  Scene probe = scene;
  probe.focus_distance_mm = std::numeric_limits<double>::infinity();
  const Setup s = Resolve(probe);
  // The middle of the distances the set will use: the given ones, or those SetPoses chooses.
  double mid = 0.5 * (so.near_mm + so.far_mm);
  if (mid == 0) {
    const auto pts = calib::TargetPoints(scene.target);
    double span = 0;
    for (const auto& p : pts) span = std::max(span, (p - pts.front()).norm());
    mid = (0.5 * (1 / 0.8 + 1 / 0.3) * span + baseline_mm) * s.camera.FocalLengthPx() / s.camera.sensor.width_px;
  }
  if (middle_mm) *middle_mm = mid;
  try {
    return *FocusOn(scene, mid).focus.focus_distance_mm;
  } catch (const InvalidInput&) {  // closer than the lens focuses: its closest focus, as a camera would
    if (closest) *closest = true;
    return scene.housed.lens.min_focus_mm;
  }
}

nlohmann::ordered_json RigTruthJson(const Scene& scene, const RenderOptions& options, const Rendered& r,
                                    const std::string& image_file, int bit_depth, const RigCamera& cam, int index,
                                    const Pose& rig_from_target) {
  Json j = TruthJson(scene, options, r, image_file, bit_depth);
  j["rig"] = {{"camera", cam.name},
              {"index", index},
              {"frame", "rig: the first camera's camera frame; cam_from_rig: x_cam = R x_rig + t (rotation_rad: "
                        "angle-axis); pose above = cam_from_rig rig_from_target"},
              {"port", cam.port_use == RigCamera::PortUse::kNone || scene.bare ? "none (the lens alone)"
                       : cam.port_use == RigCamera::PortUse::kOwn             ? "the camera's own"
                                                                              : "the scene's"},
              {"cam_from_rig", PoseJson(cam.cam_from_rig)},
              {"rig_from_target", PoseJson(rig_from_target)}};
  return j;
}

nlohmann::ordered_json RenderRig(const Scene& base, const std::vector<RigCamera>& cameras, const RigRenderOptions& o) {
  ValidateRig(cameras);
  Validate(o.render);
  if (o.bit_depth != 8 && o.bit_depth != 16) throw InvalidInput("bit_depth", "must be 8 or 16");
  if (o.set_count < 0) throw InvalidInput("count", "must be 1 to 10000");
  if (o.out.empty()) throw InvalidInput("out", "give a directory");
  const auto log = [&](const std::string& line) {
    if (o.log) o.log(line);
  };

  // What each image is: camera, medium, frame (rig_from_target), file.
  struct Job {
    int camera = 0;
    Scene scene;
    Pose rig_from_target;
    std::string medium, frame;
    fs::path png;
    std::uint64_t seed = 1;
  };
  std::vector<Job> jobs;
  Json focus = Json::array();
  int frames = 0;
  if (o.set_count == 0) {
    frames = 1;
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      Job j;
      j.camera = static_cast<int>(k);
      j.scene = CameraScene(base, cameras[k], base.pose);
      j.rig_from_target = base.pose;
      j.medium = j.scene.medium == Medium::kWater && !j.scene.bare ? "water" : "air";
      j.frame = "render";
      j.png = o.out / cameras[k].name / "render.png";
      j.seed = o.render.seed;
      // Checked before any image: the target is where this camera sees it whole.
      GroundTruth(j.scene, Resolve(j.scene, o.render.color));
      jobs.push_back(std::move(j));
    }
  } else {
    SetOptions so = o.set;
    so.count = o.set_count;
    so.seed = o.render.seed;
    double baseline = 0;  // the largest distance between two pupils (SetPosesSeenBy's distances)
    for (const RigCamera& a : cameras) {
      for (const RigCamera& b : cameras) {
        const Eigen::Vector3d pa = -a.cam_from_rig.rotation.transpose() * a.cam_from_rig.translation_mm;
        const Eigen::Vector3d pb = -b.cam_from_rig.rotation.transpose() * b.cam_from_rig.translation_mm;
        baseline = std::max(baseline, (pa - pb).norm());
      }
    }
    std::vector<SetView> views;
    bool any_port = false;
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      Scene s = CameraScene(base, cameras[k], Pose{});
      if (!s.focus_distance_mm) {
        bool closest = false;
        s.focus_distance_mm = SetFocusDistanceMm(s, so, cameras.size() > 1 ? baseline : 0.0, &closest);
        if (closest) {
          log(fmt::format("note: {}: the lens cannot focus on the set's middle distance; focused at its closest, {:g} mm",
                          cameras[k].name, *s.focus_distance_mm));
        }
      }
      focus.push_back(*s.focus_distance_mm);
      any_port = any_port || !s.bare;
      views.push_back({s, cameras[k].cam_from_rig});
    }
    const std::vector<Pose> poses = SetPosesSeenBy(views, so);
    frames = static_cast<int>(poses.size());
    std::vector<Medium> media = {Medium::kWater, Medium::kAir};
    if (!any_port) media = {Medium::kAir};  // bare cameras: water would be the same images
    for (std::size_t i = 0; i < poses.size(); ++i) {
      for (const Medium m : media) {
        for (std::size_t k = 0; k < cameras.size(); ++k) {
          Job j;
          j.camera = static_cast<int>(k);
          j.scene = views[k].scene;
          j.scene.medium = m;
          j.scene.pose = Compose(cameras[k].cam_from_rig, poses[i]);
          j.rig_from_target = poses[i];
          j.medium = m == Medium::kWater ? "water" : "air";
          j.frame = fmt::format("pose_{:03d}", i);
          j.png = o.out / j.medium / cameras[k].name / (j.frame + ".png");
          j.seed = o.render.seed + i;
          jobs.push_back(std::move(j));
        }
      }
    }
  }
  if (o.prepare) o.prepare();
  // The folders, then every output checked under the rules before the first render.
  for (const Job& j : jobs) MakeDirectory(j.png.parent_path());
  for (const Job& j : jobs) {
    CheckOutput(j.png, "out", o.rules);
    CheckOutput(TruthPathOf(j.png), "out", o.rules, FileKind::kGroundTruth);
  }

  Json images = Json::array();
  for (std::size_t n = 0; n < jobs.size(); ++n) {
    const Job& j = jobs[n];
    RenderOptions ro = o.render;
    ro.seed = j.seed;
    const Rendered r = Render(j.scene, ro);
    const std::string bytes = EncodePng(r.image, o.bit_depth);
    const fs::path json = TruthPathOf(j.png);
    const std::string truth =
        RigTruthJson(j.scene, ro, r, j.png.filename().string(), o.bit_depth, cameras[j.camera], j.camera,
                     j.rig_from_target)
            .dump(1, ' ', false, Json::error_handler_t::replace) +
        "\n";
    WriteOutput(json, truth, "out", o.rules);
    WriteOutput(j.png, bytes, "out", o.rules);
    const std::string rel = fs::relative(j.png, o.out).generic_string();
    log(fmt::format("{} ({}/{}) {}x{} px, {} points, {:.1f} s; {:.2f} % of rays blocked by the housing", rel, n + 1,
                    jobs.size(), r.image.width, r.image.height, r.truth.size(), r.seconds, 100 * r.blocked_fraction));
    Json summary = {{"camera", cameras[j.camera].name},
                    {"medium", j.medium},
                    {"frame", j.frame},
                    {"image", j.png.string()},
                    {"truth", json.string()},
                    {"points", r.truth.size()},
                    {"left_out_partial", r.left_out.partial.size()},
                    {"blocked_fraction", r.blocked_fraction},
                    {"seconds", r.seconds}};
    if (o.written) o.written(RigImage{j.camera, j.medium, j.frame, r, truth, summary});
    images.push_back(std::move(summary));
  }
  Json names = Json::array();
  for (const RigCamera& c : cameras) names.push_back(c.name);
  Json out = {{"cameras", names}, {"frames", frames}, {"images", images}};
  if (o.set_count > 0) out["focus_distance_mm"] = focus;
  return out;
}

}  // namespace porthole::render
