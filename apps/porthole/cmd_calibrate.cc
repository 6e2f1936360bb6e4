// `porthole calibrate`: self-calibration by bundle adjustment from images (detected here) or from
// saved detections, with any camera model of the list (--model); the parameter table with σ and
// significance as in the paper's Table 6, σ0, RMS, correlations; JSON (--json, --out) and OpenCV
// YAML (--opencv-yaml) outputs.
#include <fmt/format.h>

#include <cmath>

#include "commands.h"
#include "common.h"
#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/result_json.h"
#include "porthole/camera/camera.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"

namespace porthole::cli {
namespace {

// The parameter table: value, σ, |p|/σ, or "-" where not adjusted (the paper's Table 6).
std::string CalibrationTable(const calib::CalibrationResult& r, const calib::CalibrationOptions& o) {
  std::string t = fmt::format(
      "{} images, {} points ({} rejected), {} unknowns, redundancy {}; free: {}\n",
      r.n_images, r.n_points, r.n_rejected, r.n_unknowns, r.redundancy,
      calib::FreeParametersToString(r.camera.model, r.free));
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
  t += "per-image RMS (px):";
  for (const auto& im : r.images) t += fmt::format(" {} {:.3f};", im.image, im.rms_px);
  t += "\nstatus: " + r.message + "\n";
  return t;
}

}  // namespace

void RegisterCalibrate(CLI::App& app) {
  struct Options {
    std::string images, detections, target, model = "brown", free = "default", loss = "none", out,
                                                            yaml;
    double pitch_mm = 1.0;
    calib::CalibrationOptions calib;
    bool json = false, quiet = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Self-calibrate a camera (bundle adjustment, any camera model) with statistics");
  auto* img = cmd->add_option("--images", o->images, "Directory of images: detect the target");
  auto* det = cmd->add_option("--detections", o->detections,
                              "Detections from 'porthole detect' (set file, file or directory)");
  img->excludes(det);
  cmd->add_option("--target", o->target,
                  "Target spec (required with --images), e.g. chessboard:9x6:25");
  cmd->add_option("--pixel-pitch-mm", o->pitch_mm,
                  "Pixel pitch, mm; without it millimetres are pixels")
      ->capture_default_str();
  std::string models;
  for (const auto& m : camera::CameraModels()) models += (models.empty() ? "" : " | ") + std::string(m.name);
  cmd->add_option("--model", o->model, "Camera model: " + models)->capture_default_str();
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
                "Adjust the target points too (self-calibration; datum: 7 coordinates of 3 points)");
  cmd->add_flag("--drop-insignificant", o->calib.drop_insignificant,
                "Drop additional parameters with |p|/std < --significance-t, stepwise");
  cmd->add_option("--significance-t", o->calib.significance_t, "Significance threshold |p|/std")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Write the calibration JSON to this file");
  cmd->add_option("--opencv-yaml", o->yaml,
                  "Write an OpenCV YAML: exact for --model opencv; a Brown calibration refit to k1 k2 p1 p2 k3 "
                  "(RMS reported)");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->callback([o] {
    if (o->images.empty() && o->detections.empty()) {
      throw InvalidInput("--images", "give --images DIR or --detections PATH");
    }
    calib::TargetSpec target;
    if (!o->target.empty()) target = calib::ParseTarget(o->target);
    if (!o->images.empty() && o->target.empty()) {
      throw InvalidInput("--target", "required with --images");
    }
    o->calib.model = camera::ModelFromName(o->model, "--model");
    o->calib.free = calib::ParseFreeParameters(o->calib.model, o->free);
    o->calib.pixel_pitch_mm = RequirePositive("--pixel-pitch-mm", o->pitch_mm);
    if (o->pitch_mm != 1.0) WarnIfImplausible("--pixel-pitch-mm", o->pitch_mm, kPixelPitchRange);
    if (!o->out.empty()) CheckOutputFile(o->out, "--out");
    if (!o->yaml.empty()) CheckOutputFile(o->yaml, "--opencv-yaml");
    o->calib.loss = o->loss == "huber"    ? calib::LossKind::kHuber
                    : o->loss == "cauchy" ? calib::LossKind::kCauchy
                                          : calib::LossKind::kNone;
    // Captures the flag, not `o`: o->calib.progress holding `o` was a reference cycle (a leak).
    const auto say = [quiet = o->quiet](const std::string& m) {
      if (!quiet) fmt::print(stderr, "calibrate: {}\n", m);
    };
    o->calib.progress = say;
    std::vector<calib::ImageDetections> dets;
    std::vector<calib::SkippedImage> skipped;
    if (!o->images.empty()) {
      auto run = calib::DetectAll(calib::ListImages(o->images), target, say);
      dets = std::move(run.detections);
      skipped = std::move(run.skipped);
    } else {
      dets = calib::LoadDetections(o->detections, "--detections", &target);
      if (target.cols == 0) throw InvalidInput("--target", "the detections name no target");
    }
    const auto r = calib::Calibrate(dets, target, o->calib);
    auto j = calib::CalibrationToJson(r, target, o->calib);
    Json skip = Json::array();
    for (const auto& s : skipped) skip.push_back({{"image", s.image}, {"reason", s.reason}});
    j["skipped"] = skip;
    std::string yaml_note;
    if (!o->yaml.empty()) {
      camera::ConversionFit fit;
      const auto yaml = calib::ExportOpenCVYaml(
          calib::CalibrationFromJson(nlohmann::json::parse(j.dump()), "--opencv-yaml"), &fit);
      WriteFileAtomically(o->yaml, yaml, "--opencv-yaml");
      j["opencv_yaml"] = {{"file", o->yaml}, {"refit_rms_px", fit.rms_px},
                          {"refit_max_px", fit.max_px}};
      yaml_note = fmt::format("OpenCV YAML {}: refit RMS {:.4f} px, max {:.4f} px\n", o->yaml,
                              fit.rms_px, fit.max_px);
    }
    if (!o->out.empty()) WriteFileAtomically(o->out, j.dump(1) + "\n", "--out");
    if (o->json) return fmt::print("{}\n", j.dump(2));
    std::string text = CalibrationTable(r, o->calib) + yaml_note;
    for (const auto& s : skipped) text += fmt::format("skipped {}: {}\n", s.image, s.reason);
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
