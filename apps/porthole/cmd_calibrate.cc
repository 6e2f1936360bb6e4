// `porthole calibrate`: self-calibration by bundle adjustment from images (detected here) or from
// saved detections, with any camera model of the list (--model); the parameter table with σ and
// significance as in the paper's Table 6, σ0, RMS, correlations; JSON (--json, --out) and OpenCV
// YAML (--opencv-yaml) outputs. With --port, the explicit refractive calibration (the lens behind
// the port, calib/refractive.h): the port block in the JSON, --port-out as-calibrated.toml. A rig
// (--images or --detections repeated) is calib::CalibrateRigJob (calib/rig_job.h).
#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>

#include "commands.h"
#include "common.h"
#include "frame_options.h"
#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include "porthole/calib/job.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/rig.h"
#include "porthole/calib/rig_job.h"
#include "porthole/calib/result_json.h"
#include "porthole/camera/camera.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"

namespace porthole::cli {
namespace {

// The parameter table: value, σ, |p|/σ, or "-" where not adjusted (the paper's Table 6).
std::string CalibrationTable(const calib::CalibrationResult& r, const calib::CalibrationOptions& o,
                             const calib::TargetSpec& target) {
  std::string t = fmt::format(
      "{} images, {} points ({} rejected), {} unknowns, redundancy {}; free: {}\n",
      r.n_images, r.n_points, r.n_rejected, r.n_unknowns, r.redundancy,
      calib::FreeParametersToString(r.camera.model, r.free));
  if (!target.field.empty()) t += fmt::format("target field {}: {} targets\n", target.field_file, target.field.size());
  if (r.datum.Set()) {  // --free-target: the datum and the largest change from the nominal points
    const auto nominal = calib::TargetPoints(target);
    int moved = -1, n_adjusted = 0;
    double most = -1;
    for (std::size_t id = 0; id < r.target_sigma_mm.size(); ++id) {
      if (!r.target_sigma_mm[id].allFinite()) continue;
      ++n_adjusted;
      const double d = (r.target_points_mm[id] - nominal[id]).norm();
      if (d > most) most = d, moved = static_cast<int>(id);
    }
    t += r.datum.control.empty()
             ? fmt::format("free target: {} points adjusted (JSON target_adjusted); datum: ids {} and {} fixed, the {} of {}",
                           n_adjusted, r.datum.a, r.datum.b, "xyz"[r.datum.axis], r.datum.c)
             : fmt::format("free target: {} points adjusted (JSON target_adjusted); datum: {} control points", n_adjusted,
                           r.datum.control.size());
    if (moved >= 0) {
      const Eigen::Vector3d& s = r.target_sigma_mm[moved];
      t += fmt::format("; largest change from the nominal {:.3f} mm (id {}, sigma {:.3f} {:.3f} {:.3f} mm)", most, moved,
                       s.x(), s.y(), s.z());
    }
    t += "\n";
  }
  const camera::ModelInfo& m = r.camera.info();
  t += fmt::format("model {}: {}\n", m.name, m.description);
  if (m.caps.image_mm && o.pixel_pitch_mm == 1.0) {
    t += "no --pixel-pitch-mm: pitch 1, so millimetres are pixels\n";
  }
  t += fmt::format("{:<10} {:>14} {:>11} {:>8}  {}\n", "parameter", "value", "std", "|p|/std",
                   "unit");
  const std::vector<double>& v = r.camera.params;
  for (int i = 0; i < m.num_params; ++i) {
    const auto& info = m.params[i];
    if (!r.free[i]) {
      t += fmt::format("{:<10} {:>14} {:>11} {:>8}  {}\n", info.json_key,
                       v[i] != 0 ? fmt::format("{:.6g}", v[i]) : "-", "-", "", info.unit);
      continue;
    }
    std::string tt;
    for (const auto& s : r.significance) {
      if (s.index == i) tt = fmt::format("{:.1f}{}", s.t, s.significant ? "" : "*");
    }
    t += fmt::format("{:<10} {:>14.6g} {:>11.2g} {:>8}  {}\n", info.json_key, v[i], r.sigma[i], tt,
                     info.unit);
  }
  for (const auto& d : r.dropped) {
    t += fmt::format("dropped {} = {:.3g} ± {:.2g} (|p|/std {:.2f} < {:g}): not significant\n",
                     m.params[d.index].json_key, d.value, d.sigma, d.t,
                     o.significance_t);
  }
  t += fmt::format("sigma0 {:.4f} px   RMS {:.4f} px   ({} iterations, {:.3f} s)\n", r.sigma0_px,
                   r.rms_px, r.iterations, r.seconds);
  std::string high;
  for (int i = 0; i < m.num_params; ++i) {
    for (int j = i + 1; j < m.num_params; ++j) {
      if (r.free[i] && r.free[j] && std::abs(r.correlation(i, j)) > 0.9) {
        high += fmt::format(" {}/{} {:+.2f}", m.params[i].name, m.params[j].name,
                            r.correlation(i, j));
      }
    }
  }
  if (!high.empty()) t += "correlations beyond 0.9:" + high + "\n";
  // Every image up to 30; beyond (a calibration from video has thousands of frames) the median and
  // the five worst, every image in the JSON.
  constexpr std::size_t kListImages = 30;
  if (r.images.size() <= kListImages) {
    t += "per-image RMS (px):";
    for (const auto& im : r.images) t += fmt::format(" {} {:.3f};", im.image, im.rms_px);
  } else {
    std::vector<const calib::ImageResult*> by_rms;
    for (const auto& im : r.images) by_rms.push_back(&im);
    std::sort(by_rms.begin(), by_rms.end(), [](const auto* a, const auto* b) { return a->rms_px > b->rms_px; });
    t += fmt::format("per-image RMS (px), {} images: median {:.3f}; the 5 worst:", r.images.size(),
                     by_rms[by_rms.size() / 2]->rms_px);
    for (std::size_t k = 0; k < 5; ++k) t += fmt::format(" {} {:.3f};", by_rms[k]->image, by_rms[k]->rms_px);
    t += " every image in --json";
  }
  t += "\nstatus: " + CliWords(r.message) + "\n";
  return t;
}

// The port block of a refractive calibration: estimate, σ, prediction, χ², model choice.
std::string PortTable(const calib::RefractiveResult& r, const calib::RefractiveOptions& o) {
  const auto& names = refraction::PortParams(r.kind);
  std::string t = fmt::format(
      "port {} ({}, water n = {:.5f}, glass n = {:.5f}), lens intrinsics {}\n", o.port.spec.name,
      refraction::PortParamsMeaning(r.kind),
      o.port.n_water, o.port.n_glass, calib::ToString(r.intrinsics));
  // The name column fits the longest parameter name (a cylinder's), 16 at least.
  std::size_t w = 16;
  for (const auto& n : names) w = std::max(w, n.json_key.size() + 1);
  t += fmt::format("{:<{}} {:>11} {:>9} {:>11} {:>9}  {}\n", "port", w, "estimate", "std",
                   "predicted", "std", "unit");
  for (int i = 0; i < refraction::kPortNumParams; ++i) {
    t += fmt::format("{:<{}} {:>11.4f} {:>9} {:>11.4f} {:>9.3g}  {}\n", names[i].json_key, w, r.port[i],
                     r.port_free[i] ? fmt::format("{:.2g}", r.port_sigma[i]) : "fixed",
                     r.predicted[i], r.predicted_sigma[i], names[i].unit);
  }
  const auto& shell_names = refraction::ShellParams(r.kind);
  for (int i = 0; i < refraction::kShellNumParams; ++i) {
    if (!r.shell_free[i]) continue;
    t += fmt::format("{:<{}} {:>11.5f} {:>9.2g} {:>11.5f} {:>9}  {}{}\n", shell_names[i].json_key, w,
                     r.shell[i], r.shell_sigma[i], r.shell_predicted[i],
                     i == 0 ? "" : "file", shell_names[i].unit,
                     i == 0 ? fmt::format(" (water n = {:.5f})", r.n_water) : "");
  }
  if (std::isfinite(r.normal_tilt_from_predicted_deg)) {
    t += fmt::format("normal {:.4f} deg from the predicted one\n", r.normal_tilt_from_predicted_deg);
  }
  if (r.dof > 0) {
    t += fmt::format("estimate vs prediction: chi2 {:.2f} on {} dof, p = {:.3g}: {}\n", r.chi2,
                     r.dof, r.p_value,
                     r.port_differs ? "the port differs from its prediction"
                                    : "consistent with the prediction");
  }
  const camera::ModelInfo& m = r.lens.camera.info();
  std::string high;
  const int n = m.num_params;
  for (int i = n; i < r.correlation.rows(); ++i) {  // port and shell rows
    for (int k = 0; k < i; ++k) {
      const double c = r.correlation(i, k);
      if (std::isfinite(c) && std::abs(c) > 0.9) {
        high += fmt::format(" {}/{} {:+.2f}", calib::JointParamName(m.id, r.kind, i, false),
                            calib::JointParamName(m.id, r.kind, k, false), c);
      }
    }
  }
  if (!high.empty()) t += "port correlations beyond 0.9:" + high + "\n";
  const calib::CentralPrediction& cp = r.central_prediction;
  if (cp.available) {
    t += fmt::format("water c, x0, y0 (simulate's central fit at {:.0f}-{:.0f} mm): predicted "
                     "port + in-air lens vs estimated port + lens; central calibration beside\n",
                     cp.distances_mm.front(), cp.distances_mm.back());
    const char* names3[] = {"c_mm", "x0_mm", "y0_mm"};
    t += fmt::format("{:<16} {:>11} {:>9} {:>11} {:>9} {:>11} {:>9}\n", "", "estimated", "std",
                     "predicted", "std", "central", "std");
    for (int k = 0; k < 3; ++k) {
      t += fmt::format("{:<16} {:>11.4f} {:>9.2g} {:>11.4f} {:>9.2g} {:>11.4f} {:>9.2g}\n",
                       names3[k], cp.estimated[k], cp.estimated_sigma[k], cp.predicted[k],
                       cp.predicted_sigma[k], cp.central[k], cp.central_sigma[k]);
    }
    t += fmt::format("c, x0, y0 estimate vs prediction: chi2 {:.2f} on {} dof, p = {:.3g}: {}\n",
                     cp.chi2, cp.dof, cp.p_value,
                     cp.differs ? "the water calibration differs from its prediction"
                                : "consistent with the prediction");
  } else {
    t += "water c, x0, y0 vs the simulate prediction: not compared: " + CliWords(cp.why_not) + "\n";
  }
  t += fmt::format("model choice (BIC, lower is better): refractive {:.1f} (k {}) vs central {} "
                   "{:.1f} (k {}, RMS {:.4f} px): {} preferred\n",
                   r.bic, r.k, m.name, r.central_bic, r.central_k, r.central_rms_px, r.preferred);
  return t;
}

// Network advice (--plan-only): the σ the design gives, the ranges, the warning.
std::string PlanTable(const calib::RefractivePlan& p, const calib::RefractiveOptions& o) {
  const auto& names = refraction::PortParams(p.kind);
  const camera::ModelInfo& m = camera::Info(p.model);
  std::string t = fmt::format(
      "network advice for port {} (lens intrinsics {}): {} images, {} points, targets at "
      "{:.0f}-{:.0f} mm, pixel noise {:g} px\n",
      o.port.spec.name, calib::ToString(o.intrinsics), p.n_images, p.n_points, p.min_range_mm,
      p.max_range_mm, p.sigma0_px);
  t += fmt::format("{:<16} {:>11}  {}\n", "port", "std", "unit");
  for (int i = 0; i < refraction::kPortNumParams; ++i) {
    t += fmt::format("{:<16} {:>11}  {}\n", names[i].json_key,
                     !p.port_free[i] ? "fixed" : fmt::format("{:.3g}", p.port_sigma[i]), names[i].unit);
  }
  std::string lens;
  for (int i = 0; i < m.num_params; ++i) {
    if (std::isfinite(p.lens_sigma[i])) lens += fmt::format(" {} {:.3g};", m.params[i].name, p.lens_sigma[i]);
  }
  if (!lens.empty()) t += "lens std:" + lens + "\n";
  std::string shell;
  for (int i = 0; i < refraction::kShellNumParams; ++i) {
    if (p.shell_free[i]) shell += fmt::format(" {} {:.3g};", refraction::ShellParams(p.kind)[i].json_key, p.shell_sigma[i]);
  }
  if (!shell.empty()) t += "shell std:" + shell + "\n";
  const int n = m.num_params;
  std::string high;
  for (int i = n; i < p.correlation.rows(); ++i) {
    for (int k = 0; k < i; ++k) {
      const double c = p.correlation(i, k);
      if (std::isfinite(c) && std::abs(c) > 0.9) {
        high += fmt::format(" {}/{} {:+.2f}", calib::JointParamName(p.model, p.kind, i, false),
                            calib::JointParamName(p.model, p.kind, k, false), c);
      }
    }
  }
  if (!high.empty()) t += "port correlations beyond 0.9:" + high + "\n";
  t += "status: " + (p.warning.empty() ? std::string("ok") : "warning: " + p.warning) + "\n";
  return t;
}

// The options of `porthole calibrate` as parsed.
struct CalibrateCliOptions {
  std::vector<std::string> image_dirs, detection_paths;  // one per camera (a rig: several)
  std::string datum = "auto";
  std::string target, field, model = "brown", free = "default", loss = "none", out, yaml, field_out;
  double pitch_mm = 1.0;
  std::vector<double> pitches_mm;  // --pixel-pitch-mm as given: one, or a rig's one per camera
  calib::CalibrationOptions calib;
  calib::FrameOptions frames;  // --every, --max-frames (a video's frames)
  bool json = false, quiet = false, force = false;
  // Refractive calibration (--port).
  PortOptions port;
  WaterOptions water;
  std::string air, intrinsics, free_port = "all", port_out, air_detections, air_images, stereo_out;
  bool air_lens_bare = false;
  bool air_refocused = false;
  std::vector<double> port_sigma;
  bool plan_only = false, free_water_index = false, free_shell = false;
  double plan_sigma_px = 0.3;
  std::string centre_correction = "auto";
  bool free_port_given = false;  // --free-port given (a rig refuses it)
};

// A comma list's items ("a,b" → a, b; "" → one empty item).
std::vector<std::string> SplitList(const std::string& list) {
  std::vector<std::string> items;
  for (std::size_t a = 0, b; a <= list.size(); a = b + 1) {
    b = list.find(',', a);
    if (b == std::string::npos) b = list.size();
    items.push_back(list.substr(a, b - a));
  }
  return items;
}

// A rig (issue 26): --images or --detections repeated, one per camera; --model, --pixel-pitch-mm,
// --port one for all or a comma list, --air-calibration a comma list or a rig file, --air-images
// or --air-detections a comma list. The options as calib::CalibrateRigJob takes them, then its
// result printed and written.
void CalibrateRigCommand(const CalibrateCliOptions& o, const OutputRules& rules) {
  calib::CalibrateRigJobOptions job;
  job.images = o.image_dirs;
  job.detections = o.detection_paths;
  job.target = o.target;
  job.field = o.field;
  job.frames = o.frames;
  job.model = SplitList(o.model);
  job.free = o.free;
  job.loss = o.loss;
  job.centre_correction = o.centre_correction;
  job.lens = o.calib;
  job.lens.progress = [quiet = o.quiet](const std::string& m) {
    if (!quiet) fmt::print(stderr, "calibrate: {}\n", m);
  };
  job.pixel_pitch_mm = o.pitches_mm;
  job.warn = [](const std::string& w) { fmt::print(stderr, "porthole: warning: {}\n", CliWords(w)); };
  if (!o.port.port.empty()) job.port = SplitList(o.port.port);
  job.water = o.water.ToEnvironment();
  if (!o.air.empty()) job.air_calibration = SplitList(o.air);
  job.air_lens_bare = o.air_lens_bare;
  job.air_refocused = o.air_refocused;
  if (!o.air_images.empty()) job.air_images = SplitList(o.air_images);
  if (!o.air_detections.empty()) job.air_detections = SplitList(o.air_detections);
  job.ep_mm = o.port.Ep();  // every camera's pupil
  job.intrinsics = !o.intrinsics.empty();
  // --port-out: one file per camera (a comma list, in the order of the cameras).
  const std::vector<std::string> port_outs = o.port_out.empty() ? std::vector<std::string>{} : SplitList(o.port_out);
  const std::size_t n_cameras = std::max(o.image_dirs.size(), o.detection_paths.size());
  if (!port_outs.empty() && port_outs.size() != n_cameras) {
    throw InvalidInput("--port-out", fmt::format("{} {} for {} cameras: one per camera (a comma list, in the "
                                                 "order of the cameras)", port_outs.size(),
                                                 port_outs.size() == 1 ? "file" : "files", n_cameras));
  }
  job.port_out = !port_outs.empty();
  job.free_water_index = o.free_water_index;
  job.free_shell = o.free_shell;
  job.port_sigma = !o.port_sigma.empty();
  job.opencv_yaml = !o.yaml.empty();
  job.field_out = !o.field_out.empty();
  job.plan_only = o.plan_only;
  job.datum = o.datum;
  job.free_port = o.free_port_given;
  job.stereo_out = o.stereo_out;
  job.check_outputs = [&] {
    if (!o.out.empty()) CheckOutput(o.out, "--out", rules, FileKind::kCalibration);
    if (!o.stereo_out.empty()) CheckOutput(o.stereo_out, "--stereo-out", rules);
    for (const std::string& f : port_outs) CheckOutput(f, "--port-out", rules);
    if (!o.field_out.empty()) CheckOutput(o.field_out, "--field-out", rules);
  };
  const calib::CalibrateRigJobResult result = calib::CalibrateRigJob(job);
  const calib::RigResult& r = result.rig;
  const calib::RigOptions& ro = result.rig_options;
  auto j = calib::CalibrateRigJobJson(result);
  CliWordsInJson(&j);  // the library's `field` in the CLI's words
  std::string written_note;
  if (!o.stereo_out.empty()) {  // the first two cameras as cv::stereoCalibrate's K1 D1 K2 D2 R T (interop/rig_files.h)
    WriteOutput(o.stereo_out, result.stereo_text, "--stereo-out", rules);
    j["rig"]["stereo_out"] = o.stereo_out;
    written_note = fmt::format("OpenCV stereo file (K1 D1 K2 D2 R T) written to {}\n", o.stereo_out);
  }
  for (std::size_t k = 0; k < port_outs.size(); ++k) {  // each camera's estimated port as a port TOML
    WriteOutput(port_outs[k], result.port_tomls[k], "--port-out", rules);
    j["rig"]["cameras"][k]["port"]["port_out"] = port_outs[k];
    written_note += fmt::format("estimated port of {} written to {}\n", r.cameras[k].name, port_outs[k]);
  }
  if (!o.field_out.empty()) {  // the free target's adjusted points, as one camera's --field-out
    WriteOutput(o.field_out, result.field_text, "--field-out", rules);
    j["field_out"] = o.field_out;
    written_note += fmt::format("adjusted target field written to {}\n", o.field_out);
  }
  if (!o.out.empty()) WriteOutput(o.out, j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "--out", rules);
  if (o.json) return fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
  const calib::TargetSpec& target = result.target;
  const std::vector<calib::SkippedImage>& skipped = result.skipped;
  std::string t = fmt::format("rig of {} cameras (rig frame: camera {}'s), {} frames, {} points ({} rejected), "
                              "sigma0 {:.4f} px, RMS {:.4f} px ({} iterations, {:.3f} s)\n",
                              r.cameras.size(), r.cameras[0].name, r.frames.size(), r.n_points, r.n_rejected,
                              r.sigma0_px, r.rms_px, r.iterations, r.seconds);
  t += fmt::format("{:<14} {:<15} {:>6} {:>9} {:>22} {:>18}\n", "camera", "model", "frames", "RMS px", "baseline mm",
                   "convergence deg");
  for (std::size_t k = 0; k < r.cameras.size(); ++k) {
    const auto& c = r.cameras[k];
    t += fmt::format("{:<14} {:<15} {:>6} {:>9.4f} {:>22} {:>18}\n", c.name, c.calibration.camera.model_name(),
                     c.n_frames, c.calibration.rms_px,
                     k == 0 ? "-" : fmt::format("{:.3f} +- {:.3f}", c.baseline_mm, c.baseline_sigma_mm),
                     k == 0 ? "-" : fmt::format("{:.4f}", c.convergence_deg));
  }
  for (std::size_t k = 1; k < r.cameras.size(); ++k) {
    const auto& c = r.cameras[k];
    const double deg = 180 / M_PI;
    t += fmt::format("cam_from_rig {}: rotation ({:.5f}, {:.5f}, {:.5f}) +- ({:.5f}, {:.5f}, {:.5f}) deg, "
                     "translation ({:.3f}, {:.3f}, {:.3f}) +- ({:.3f}, {:.3f}, {:.3f}) mm\n",
                     c.name, c.rotation_rad.x() * deg, c.rotation_rad.y() * deg, c.rotation_rad.z() * deg,
                     c.pose_sigma(0) * deg, c.pose_sigma(1) * deg, c.pose_sigma(2) * deg, c.translation_mm.x(),
                     c.translation_mm.y(), c.translation_mm.z(), c.pose_sigma(3), c.pose_sigma(4), c.pose_sigma(5));
  }
  for (std::size_t k = 0; k < r.cameras.size(); ++k) {
    const auto& c = r.cameras[k];
    t += fmt::format("--- {} ---\n", c.name) +
         CalibrationTable(c.calibration, ro.cameras[ro.cameras.size() == 1 ? 0 : k], target);
    if (c.has_port) {
      const auto& names = refraction::PortParams(c.port_kind);
      t += fmt::format("port {} in water:", ro.ports[ro.ports.size() == 1 ? 0 : k].spec.name);
      for (int i = 0; i < refraction::kPortNumParams; ++i) {
        t += fmt::format(" {} {:.4f} +- {:.2g} (predicted {:.4f});", names[i].json_key, c.port[i], c.port_sigma[i],
                         c.port_predicted[i]);
      }
      t += "\n";
    }
    if (!c.air_images.empty()) {
      t += fmt::format("air images: {} through the port in air, adjusted with the rig, RMS {:.4f} px\n",
                       c.air_images.size(), c.air_rms_px);
    }
  }
  t += "rig status: " + CliWords(r.message) + "\n" + written_note;
  for (const auto& s : skipped) t += fmt::format("skipped {}: {}\n", s.image, s.reason);
  fmt::print("{}", t);
}

// One camera: the options as calib::CalibrateJob takes them, then its result printed and written.
void CalibrateSingle(const CalibrateCliOptions& o, bool pitch_given, const OutputRules& rules) {
  calib::CalibrateJobOptions job;
  if (!o.image_dirs.empty()) job.images = o.image_dirs.front();
  if (!o.detection_paths.empty()) job.detections = o.detection_paths.front();
  job.target = o.target;
  job.field = o.field;
  job.frames = o.frames;
  job.model = o.model;
  job.free = o.free;
  job.loss = o.loss;
  job.centre_correction = o.centre_correction;
  job.datum = o.datum;
  job.lens = o.calib;
  // Captures the flag, not `o`: a callback holding `o` was a reference cycle (a leak).
  job.lens.progress = [quiet = o.quiet](const std::string& m) {
    if (!quiet) fmt::print(stderr, "calibrate: {}\n", m);
  };
  if (pitch_given) job.pixel_pitch_mm = o.pitch_mm;
  job.warn = [](const std::string& w) { fmt::print(stderr, "porthole: warning: {}\n", CliWords(w)); };
  job.port = o.port.port;
  job.ep_mm = o.port.Ep();
  if (!job.port.empty()) job.water = o.water.ToEnvironment();
  job.air_calibration = o.air;
  job.air_lens_bare = o.air_lens_bare;
  job.air_refocused = o.air_refocused;
  job.air_images = o.air_images;
  job.air_detections = o.air_detections;
  job.intrinsics = o.intrinsics;
  job.free_port = o.free_port;
  if (!o.port_sigma.empty()) job.port_sigma = std::array<double, 3>{o.port_sigma[0], o.port_sigma[1], o.port_sigma[2]};
  job.free_water_index = o.free_water_index;
  job.free_shell = o.free_shell;
  job.plan_only = o.plan_only;
  job.plan_sigma_px = o.plan_sigma_px;
  job.opencv_yaml = !o.yaml.empty();
  job.field_out = !o.field_out.empty();
  job.port_out = !o.port_out.empty();
  job.check_outputs = [&] {
    if (!o.out.empty()) CheckOutput(o.out, "--out", rules, FileKind::kCalibration);
    if (!o.yaml.empty()) CheckOutput(o.yaml, "--opencv-yaml", rules);
    if (!o.field_out.empty()) CheckOutput(o.field_out, "--field-out", rules);
    if (!o.port_out.empty()) CheckOutput(o.port_out, "--port-out", rules);
  };
  const calib::CalibrateJobResult r = calib::CalibrateJob(job);
  auto j = calib::CalibrateJobJson(r);
  CliWordsInJson(&j);  // the library's `field` in the CLI's words
  const auto print_json = [&] {
    if (!o.out.empty()) WriteOutput(o.out, j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "--out", rules);
    if (o.json) fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
  };
  std::string skipped;
  for (const auto& s : r.skipped) skipped += fmt::format("skipped {}: {}\n", s.image, s.reason);
  if (r.plan) {
    print_json();
    if (!o.json) fmt::print("{}", PlanTable(*r.plan, *r.refractive_options));
    return;
  }
  if (r.refractive) {
    std::string port_note;
    if (!o.port_out.empty()) {
      WriteOutput(o.port_out, r.port_toml, "--port-out", rules);
      j["port"]["port_out"] = o.port_out;
      port_note = fmt::format("estimated port written to {}\n", o.port_out);
    }
    if (!o.field_out.empty()) {
      WriteOutput(o.field_out, r.field_text, "--field-out", rules);
      j["field_out"] = o.field_out;
      port_note += fmt::format("adjusted target field written to {}\n", o.field_out);
    }
    print_json();
    if (o.json) return;
    const calib::RefractiveResult& rr = *r.refractive;
    std::string text = CalibrationTable(rr.lens, r.lens, r.target) + PortTable(rr, *r.refractive_options) + port_note;
    if (!r.air_note.empty()) text += "air calibration " + CliWords(r.air_note) + "\n";
    if (!rr.air_images.empty()) {
      text += fmt::format("air images: {} through the port in air, adjusted with the water images (one lens): "
                          "RMS {:.4f} px in air, {:.4f} px in water\n",
                          rr.air_images.size(), rr.air_rms_px, rr.water_rms_px);
    }
    return fmt::print("{}", text + skipped);
  }
  std::string yaml_note, field_note;
  if (!o.yaml.empty()) {
    WriteOutput(o.yaml, r.opencv_yaml, "--opencv-yaml", rules);
    j["opencv_yaml"] = {{"file", o.yaml}, {"refit_rms_px", r.opencv_yaml_fit.rms_px},
                        {"refit_max_px", r.opencv_yaml_fit.max_px}};
    yaml_note = fmt::format("OpenCV YAML {}: refit RMS {:.4f} px, max {:.4f} px\n", o.yaml, r.opencv_yaml_fit.rms_px,
                            r.opencv_yaml_fit.max_px);
  }
  if (!o.field_out.empty()) {
    WriteOutput(o.field_out, r.field_text, "--field-out", rules);
    j["field_out"] = o.field_out;
    field_note = fmt::format("adjusted target field written to {}\n", o.field_out);
  }
  print_json();
  if (!o.json) fmt::print("{}", CalibrationTable(*r.central, r.lens, r.target) + yaml_note + field_note + skipped);
}

}  // namespace

void RegisterCalibrate(CLI::App& app) {
  auto o = std::make_shared<CalibrateCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Self-calibrate a camera (bundle adjustment, any camera model) with statistics");
  auto* img = cmd->add_option("--images", o->image_dirs,
                              "A directory of images, one image, or a video: detect the target. Repeated, one per "
                              "camera of a rig (frames matched by file name; a video's by frame index)")
                  ->expected(1)
                  ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  auto* det = cmd->add_option("--detections", o->detection_paths,
                              "Detections from 'porthole detect' (set file, file or directory). Repeated, one per "
                              "camera of a rig")
                  ->expected(1)
                  ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  img->excludes(det);
  AddFrameOptions(cmd, &o->frames, /*for_calibration=*/true);
  cmd->add_option("--target", o->target,
                  "Target spec (required with --images), e.g. chessboard:9x6:25 or coded:14:2.5 (porthole detect --help)");
  cmd->add_option("--field", o->field,
                  "Coded targets: a target-field file (lines 'id x_mm y_mm z_mm', e.g. from porthole target-sheet, or "
                  "measured; Z != 0 for raised targets; 'id x_mm y_mm z_mm nx ny nz' for a dot facing another way "
                  "than -Z) instead of the default sheet");
  cmd->add_option("--pixel-pitch-mm", o->pitches_mm,
                  "Pixel pitch, mm; without it millimetres are pixels. A rig: one for all or a comma list, one per camera")
      ->delimiter(',')
      ->default_str("1");
  std::string models;
  for (const auto& m : camera::CameraModels()) models += (models.empty() ? "" : " | ") + std::string(m.name);
  cmd->add_option("--model", o->model,
                  "Camera model: " + models +
                      ". A rig: one for all or a comma list, one per camera (so too --port, and --air-calibration "
                      "one file per camera)")
      ->capture_default_str();
  cmd->add_option("--free", o->free,
                  "Adjusted parameters, by name (brown: c,x0,y0,K1,K2,K3,P1,P2,B1,B2; opencv: "
                  "fx,fy,cx,cy,k1..k6,p1,p2; kannala-brandt: fx,fy,cx,cy,k1..k4), all, or default "
                  "(brown c,x0,y0,K1,K2,P1,P2; opencv without k3..k6; fisheyes all)")
      ->capture_default_str();
  cmd->add_option("--reject-k", o->calib.reject_k,
                  "Reject points beyond k*sigma0 (2-D residual), iterated; 0 = off")
      ->capture_default_str();
  cmd->add_option("--loss", o->loss, "Robust loss: none | huber | cauchy")
      ->check(CLI::IsMember({"none", "huber", "cauchy"}))
      ->capture_default_str();
  cmd->add_option("--loss-scale-px", o->calib.loss_scale_px, "Robust loss scale, px")
      ->capture_default_str();
  cmd->add_flag("--free-target", o->calib.target_free,
                "Adjust the target points too (self-calibration, also behind --port and in a rig; datum: --datum; the points and their "
                "std in the JSON's target_adjusted)");
  cmd->add_option("--datum", o->datum,
                  "--free-target: the datum. auto (the field's control points when 3 or more are observed, else "
                  "minimal) | minimal (7 coordinates of 3 points) | control (the field's control points: '# control' "
                  "or '# sigma_mm SX SY SZ control' after a point)")
      ->check(CLI::IsMember({"auto", "minimal", "control"}))
      ->capture_default_str();
  cmd->add_option("--centre-correction", o->centre_correction,
                  "Circular targets: compare each centre with the centre of the dot's image through the camera, not the "
                  "image of the dot's centre: auto (on for coded targets) | on | off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  cmd->add_flag("--drop-insignificant", o->calib.drop_insignificant,
                "Drop additional parameters with |p|/std < --significance-t, stepwise");
  cmd->add_option("--significance-t", o->calib.significance_t, "Significance threshold |p|/std")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Write the calibration JSON to this file");
  cmd->add_option("--field-out", o->field_out,
                  "Coded targets with --free-target (one camera or a rig): write the adjusted target field to this file ('id x_mm y_mm "
                  "z_mm' lines, the sigma in comments), for --field of the next calibration or render");
  cmd->add_option("--stereo-out", o->stereo_out,
                  "A rig of opencv-model cameras: write the first two as OpenCV's stereo file (K1 D1 K2 D2 R T, as "
                  "cv::stereoCalibrate gives and cv::stereoRectify takes; .xml for XML, else YAML)");
  cmd->add_option("--opencv-yaml", o->yaml,
                  "Write an OpenCV YAML: exact for --model opencv; a Brown calibration refit to k1 k2 p1 p2 k3 "
                  "(RMS reported)");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  // The explicit refractive calibration.
  o->port.port.clear();
  o->port.Add(cmd);
  o->water.Add(cmd);
  const std::string group = "Refractive calibration (with --port)";
  auto* air_det = cmd->add_option("--air-detections", o->air_detections,
                                  "Detections of the same target in air through the same port (the housing on, "
                                  "the focus unchanged: the paper's protocol): adjusted with the water images, "
                                  "the air ones modelled through the port in air; one lens, one port. A rig: a "
                                  "comma list, one per camera")
                      ->group(group);
  auto* air_img = cmd->add_option("--air-images", o->air_images,
                                  "As --air-detections, from a directory of air images, one image or a video (the target detected here)")
                      ->group(group);
  air_det->excludes(air_img);
  auto* air_cal = cmd->add_option("--air-calibration", o->air,
                                  "In-air calibration, any format of 'porthole convert' (porthole JSON, OpenCV "
                                  "YAML, COLMAP, mrcal, Metashape, calibmar): made with the housing on (the "
                                  "default, the paper's protocol: modelled as the lens behind the port in air, "
                                  "a prior on both), or of the lens alone with --air-lens-bare. A prior needs "
                                  "its sigma. A rig: one per camera (a comma list) or a rig file")
                      ->group(group);
  air_cal->excludes(air_det)->excludes(air_img);
  cmd->add_flag("--air-refocused", o->air_refocused,
                "The air images (--air-images, --air-detections) were taken at another focus: they get "
                "their own focal length, a factor on the water images' adjusted with the rest")
      ->group(group);
  cmd->add_flag("--air-lens-bare", o->air_lens_bare,
                "--air-calibration was made without the housing: the bare lens")
      ->group(group);
  cmd->add_option("--intrinsics", o->intrinsics,
                  "Lens under the port: free | fixed (the air calibration of the lens alone) | "
                  "prior (the default with --air-calibration: its covariance as a prior; of the "
                  "lens alone with its focal length free, through the port on the lens and port)")
      ->check(CLI::IsMember({"free", "fixed", "prior"}))->group(group);
  cmd->add_option("--free-port", o->free_port,
                  "Adjusted port parameters: dome ep_x,ep_y,ep_z; flat n_x,n_y,distance; all; or none")
      ->capture_default_str()->group(group);
  cmd->add_option("--port-sigma", o->port_sigma,
                  "1-sigma of the predicted port parameters (dome mm; flat normal, normal, mm) for "
                  "the chi2 test; default dome 0.5,0.5,0.5, flat 0.005,0.005,1")
      ->delimiter(',')->expected(3)->group(group);
  cmd->add_option("--port-out", o->port_out,
                  "Write the estimated port as a port TOML. A rig: one file per camera (a comma list)")
      ->group(group);
  cmd->add_flag("--free-water-index", o->free_water_index,
                "Adjust a factor on the water index too (no prior; its sigma and correlations "
                "say whether the images determine it)")->group(group);
  cmd->add_flag("--free-shell", o->free_shell,
                "Adjust the shell values the port file's [sigma] table gives a sigma for "
                "(outer_radius_mm, inner_radius_mm, thickness_mm, inner_offset_mm), each with that "
                "Gaussian prior")->group(group);
  cmd->add_flag("--plan-only", o->plan_only,
                "Network advice, no adjustment: the sigma these images' poses will give the port "
                "(and lens) parameters at --plan-sigma-px noise, and a warning for one range")
      ->group(group);
  cmd->add_option("--plan-sigma-px", o->plan_sigma_px,
                  "Pixel noise (1-sigma per coordinate) --plan-only assumes")
      ->capture_default_str()->group(group);
  AddForceFlag(cmd, &o->force);
  cmd->callback([o, cmd] {
    const OutputRules rules{.force = o->force,
                            .inputs = InputFiles(cmd, {"--out", "--opencv-yaml", "--field-out", "--port-out",
                                                       "--stereo-out"})};
    if (!o->pitches_mm.empty()) o->pitch_mm = o->pitches_mm.front();
    o->free_port_given = cmd->count("--free-port") > 0;
    if (o->image_dirs.size() > 1 || o->detection_paths.size() > 1) return CalibrateRigCommand(*o, rules);
    if (o->pitches_mm.size() > 1) {
      throw InvalidInput("--pixel-pitch-mm", fmt::format("{} pitches for one camera (a comma list is a rig's, one per "
                                                         "camera)", o->pitches_mm.size()));
    }
    if (!o->stereo_out.empty()) throw InvalidInput("--stereo-out", "only for a rig (--detections or --images repeated)");
    CalibrateSingle(*o, cmd->get_option("--pixel-pitch-mm")->count() > 0, rules);
  });
}

}  // namespace porthole::cli
