// `porthole measure --rig RIG.json --points FILE…`: 3-D points and lengths through a calibrated rig,
// each with σ (measure/measure.h). The CLI reads the files and prints; the library does the rest.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include "commands.h"
#include "common.h"
#include "porthole/calib/detections_json.h"
#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/measure/measure.h"

namespace porthole::cli {
namespace {

bool IsCsv(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext == ".csv" || ext == ".txt";
}

// The numbers of a comma list ("1,2.5,3"); a part that is not a whole number gives NaN there.
std::vector<double> Numbers(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) v.back() = NAN;
    } catch (const std::exception&) {
      v.push_back(NAN);
    }
  }
  return v;
}

std::pair<int, int> ParsePair(const std::string& s, const std::string& field, const std::string& what) {
  const auto comma = s.find(',');
  const auto whole = [&](const std::string& t) {
    std::size_t used = 0;
    int v = -1;
    try {
      v = std::stoi(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != t.size() || v < 0) throw InvalidInput(field, fmt::format("'{}': give {}", s, what));
    return v;
  };
  if (comma == std::string::npos) throw InvalidInput(field, fmt::format("'{}': give {}", s, what));
  return {whole(s.substr(0, comma)), whole(s.substr(comma + 1))};
}

}  // namespace

void RegisterMeasure(CLI::App& app) {
  struct Options {
    std::string rig, out;
    std::vector<std::string> points, lengths;
    std::string scale_bar;
    std::string plane, camera;
    std::optional<double> range_mm;
    std::string laser_pair;
    double plane_sigma_mm = 0;
    measure::MeasureOptions measure;
    bool no_calibration_sigma = false, json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "measure", "3-D points and lengths through a calibrated rig (exact rays through each port), with sigma");
  cmd->add_option("--rig", o->rig, "Rig calibration JSON (calibrate with one --images/--detections per camera)")
      ->required();
  cmd->add_option("--points", o->points,
                  "Image points: a CSV frame,camera,id,u_px,v_px (camera by name or index), or porthole "
                  "detections (file or folder) per camera, as CAMERA=PATH or in the rig's camera order; repeat")
      ->required();
  cmd->add_option("--length", o->lengths, "Length between point ids A,B (in every frame holding both); repeat");
  cmd->add_option("--scale-bar", o->scale_bar,
                  "A,B,LENGTH_MM: a bar of known length between ids A and B: its error in every frame, by range, "
                  "and whether the rig calibration holds");
  auto* plane = cmd->add_option("--plane", o->plane,
                                 "NX,NY,NZ,D_MM: one camera and a known plane n.x = D in its frame (mm) instead of "
                                 "two cameras; --rig may then be one camera's calibration")
                    ->group("One camera");
  cmd->add_option("--range-mm", o->range_mm, "Or: a known range, the plane square to the camera's axis this far, mm")
      ->excludes(plane)
      ->group("One camera");
  cmd->add_option("--laser-pair", o->laser_pair,
                  "A,B,SEPARATION_MM: or the range in each frame from a laser scaler's two dots (ids A and B), beams "
                  "parallel to the camera's axis this far apart")
      ->excludes(plane)
      ->group("One camera");
  cmd->add_option("--plane-sigma-mm", o->plane_sigma_mm, "Sigma of the plane's distance (or range), mm")
      ->capture_default_str()
      ->group("One camera");
  cmd->add_option("--camera", o->camera, "The camera of the plane (a rig's camera by name or index; default the first)")
      ->group("One camera");
  cmd->add_option("--sigma-px", o->measure.sigma_px,
                  "Image-point sigma of the points, px (default: the rig calibration's sigma0)");
  cmd->add_flag("--no-calibration-sigma", o->no_calibration_sigma,
                "Leave the rig calibration's uncertainty out of the sigma (image noise only)");
  cmd->add_flag("--skip-unpaired", o->measure.skip_unpaired,
                "Skip points seen by one camera only (default: refused, naming the point)");
  cmd->add_option("--out", o->out, "Write the JSON result to this file");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o, cmd] {
    WithFieldNames({{"points", "--points"}, {"lengths", "--length"}, {"sigma_px", "--sigma-px"}, {"plane", "--plane"}, {"laser_pair", "--laser-pair"},
                    {"range_mm", "--range-mm"}, {"plane_sigma_mm", "--plane-sigma-mm"},
                    {"skip_unpaired", "--skip-unpaired"}, {"camera", "--points"}},
                   [&] {
      const OutputRules rules{.force = o->force, .inputs = InputFiles(cmd, {"--out"})};
      if (!o->out.empty()) CheckOutput(o->out, "--out", rules);
      if (o->measure.sigma_px < 0 || !std::isfinite(o->measure.sigma_px)) {
        throw InvalidInput("--sigma-px", "must be a positive number of pixels");
      }
      if (cmd->count("--sigma-px") > 0 && o->measure.sigma_px == 0) {
        throw InvalidInput("--sigma-px", "must be > 0 (leave it out to take the rig's sigma0)");
      }
      const bool one_camera = !o->plane.empty() || o->range_mm.has_value() || !o->laser_pair.empty();
      if (o->range_mm && !o->laser_pair.empty()) throw InvalidInput("--laser-pair", "excludes --range-mm");
      for (const char* only : {"--plane-sigma-mm", "--camera"}) {
        if (!one_camera && cmd->count(only) > 0) throw InvalidInput(only, "goes with --plane or --range-mm");
      }
      const measure::Rig rig = one_camera ? measure::LoadCamera(o->rig, "--rig") : measure::LoadRig(o->rig, "--rig");
      if (one_camera) {
        if (cmd->count("--plane-sigma-mm") > 0 && !o->laser_pair.empty()) {
          throw InvalidInput("--plane-sigma-mm", "the laser pair gives each frame's range with its own sigma");
        }
        measure::SetOneCamera(&o->measure,
                              o->plane.empty() ? std::nullopt : std::optional<std::vector<double>>(Numbers(o->plane)),
                              o->range_mm,
                              o->laser_pair.empty() ? std::nullopt
                                                    : std::optional<std::vector<double>>(Numbers(o->laser_pair)),
                              o->plane_sigma_mm);
        o->measure.plane_camera = o->camera.empty() ? 0 : measure::CameraIndex(rig, o->camera, "--camera");
      }
      o->measure.calibration_sigma = !o->no_calibration_sigma;
      for (const auto& l : o->lengths) o->measure.lengths.push_back(ParsePair(l, "--length", "two point ids A,B"));
      std::optional<measure::ScaleBar> bar;
      if (!o->scale_bar.empty()) {
        const std::string what = "A,B,LENGTH_MM (two point ids and the bar's length in mm)";
        if (std::count(o->scale_bar.begin(), o->scale_bar.end(), ',') != 2) {
          throw InvalidInput("--scale-bar", fmt::format("'{}': give {}", o->scale_bar, what));
        }
        const auto last = o->scale_bar.rfind(',');
        const auto ids = last == std::string::npos ? std::pair<int, int>{-1, -1}
                                                   : ParsePair(o->scale_bar.substr(0, last), "--scale-bar", what);
        double len = NAN;
        try {
          std::size_t used = 0;
          len = std::stod(o->scale_bar.substr(last + 1), &used);
          if (used != o->scale_bar.size() - last - 1) len = NAN;
        } catch (const std::exception&) {
        }
        if (last == std::string::npos || ids.first < 0 || !(len > 0) || !std::isfinite(len)) {
          throw InvalidInput("--scale-bar", fmt::format("'{}': give {}", o->scale_bar, what));
        }
        bar = measure::ScaleBar{ids.first, ids.second, len};
        o->measure.lengths.push_back(ids);
      }
      // Inputs: CSVs, or detections per camera (CAMERA=PATH, or in order).
      std::vector<measure::ImagePoint> points;
      int n_csv = 0, n_det = 0, n_named = 0;
      for (const auto& p : o->points) {
        if (IsCsv(p)) {
          ++n_csv;
        } else {
          ++n_det;
          if (p.find('=') != std::string::npos && !std::filesystem::exists(p)) ++n_named;
        }
      }
      if (n_det > 0 && n_named > 0 && n_named != n_det) {
        throw InvalidInput("--points", "give every detections file as CAMERA=PATH, or none (then in the rig's camera "
                                       "order)");
      }
      if (n_det > 0 && n_named == 0 && one_camera && n_det == 1) {
        // One camera: its detections, whatever the rig's size (the camera of the plane).
      } else if (n_det > 0 && n_named == 0 && n_det != static_cast<int>(rig.cameras.size())) {
        std::string names;
        for (const auto& c : rig.cameras) names += (names.empty() ? "" : ", ") + c.name;
        throw InvalidInput("--points", fmt::format("{} detections files for the rig's {} cameras ({}): give one per "
                                                   "camera in that order, or name each as CAMERA=PATH",
                                                   n_det, rig.cameras.size(), names));
      }
      int order = 0;
      calib::TargetSpec target;  // filled by the first detections file that names one
      for (const auto& p : o->points) {
        if (IsCsv(p)) {
          const std::string text = ReadInputFile(p, "--points");
          const auto got = measure::ParsePointsCsv(text, rig, "--points", p);
          points.insert(points.end(), got.begin(), got.end());
          continue;
        }
        int camera = one_camera && n_det == 1 && n_named == 0 ? o->measure.plane_camera : order++;
        std::string path = p;
        if (n_named > 0) {
          const auto eq = p.find('=');
          camera = measure::CameraIndex(rig, p.substr(0, eq), "--points");
          path = p.substr(eq + 1);
        }
        // One target for every camera's file: the same id must be the same point of it.
        const auto det = calib::LoadDetections(path, "--points", &target);
        for (const auto& d : det) {
          const auto& s = rig.cameras[camera].camera.sensor;
          if (d.width_px > 0 && (d.width_px != s.width_px || d.height_px != s.height_px)) {
            throw InvalidInput("--points", fmt::format("{}: image {} is {} × {} px but camera {} ({}) is {} × {}: is "
                                                       "this file that camera's?", path, d.image, d.width_px,
                                                       d.height_px, camera, rig.cameras[camera].name, s.width_px,
                                                       s.height_px));
          }
        }
        const auto got = measure::PointsFromDetections(det, camera, path);
        points.insert(points.end(), got.begin(), got.end());
      }
      const measure::MeasureResult r = measure::Measure(rig, points, o->measure);
      Json j = measure::MeasureToJson(r, rig);
      std::optional<measure::ScaleBarCheck> check;
      if (bar) {
        check = measure::CheckScaleBar(r, *bar);
        j["measure"]["scale_bar"] = measure::ScaleBarToJson(*check);
      }
      if (!o->out.empty()) WriteOutput(o->out, PrintableJson(j) + "\n", "--out", rules);
      for (const auto& w : r.warnings) {
        fmt::print(stderr, "porthole: warning: {}\n", RenameQuotedFields({{"sigma_px", "--sigma-px"}}, w));
      }
      if (o->json) return fmt::print("{}\n", PrintableJson(j));
      fmt::print("rig {}: {} cameras; calibration uncertainty: {}\n", o->rig, rig.cameras.size(), r.covariance_note);
      fmt::print("image-point sigma {:.3g} px: {}\n", r.sigma_px,
                 RenameQuotedFields({{"sigma_px", "--sigma-px"}}, r.sigma_px_from));
      fmt::print("points (rig frame = {}'s camera frame, mm): {} triangulated, {} failed, {} with rays that do "
                 "not meet\n", rig.cameras[0].name, r.points.size() - r.n_failed, r.n_failed, r.n_mismatched);
      const std::size_t show = r.points.size() <= 30 ? r.points.size() : 10;
      if (show > 0) {
        fmt::print("{:>10} {:>6} {:>10} {:>10} {:>10} {:>7} {:>7} {:>7} {:>8}\n", "frame", "id", "x_mm", "y_mm", "z_mm",
                   "sx_mm", "sy_mm", "sz_mm", "miss_mm");
      }
      for (std::size_t i = 0; i < show; ++i) {
        const auto& m = r.points[i];
        if (!m.point.ok) {
          fmt::print("{:>10} {:>6}  not triangulated: {}\n", m.frame, m.id, m.point.why);
          continue;
        }
        const Eigen::Vector3d s = m.point.covariance_mm2.diagonal().cwiseSqrt();
        fmt::print("{:>10} {:>6} {:>10.2f} {:>10.2f} {:>10.2f} {:>7.3f} {:>7.3f} {:>7.3f} {:>8.3f}{}\n", m.frame, m.id,
                   m.point.x_mm.x(), m.point.x_mm.y(), m.point.x_mm.z(), s.x(), s.y(), s.z(), m.point.miss_mm,
                   m.point.mismatched ? "  rays do not meet" : "");
      }
      if (show < r.points.size()) fmt::print("… {} more points (--json or --out for all)\n", r.points.size() - show);
      const bool only_bar = check && o->lengths.empty();
      if (!r.lengths.empty() && !only_bar) {
        fmt::print("lengths:\n{:>10} {:>6} {:>6} {:>11} {:>9} {:>8} {:>9} {:>9}\n", "frame", "A", "B", "length_mm",
                   "sigma_mm", "sigma_%", "image_mm", "calib_mm");
      }
      for (const auto& l : r.lengths) {
        if (only_bar) break;  // the scale bar's table below
        if (!l.ok) {
          fmt::print("{:>10} {:>6} {:>6}  not measured: {}\n", l.frame, l.id_a, l.id_b, l.why);
          continue;
        }
        fmt::print("{:>10} {:>6} {:>6} {:>11.3f} {:>9.3f} {:>8.3f} {:>9.3f} {:>9.3f}\n", l.frame, l.id_a, l.id_b,
                   l.length.length_mm, l.length.sigma_mm, 100 * l.length.sigma_mm / l.length.length_mm,
                   l.length.sigma_image_mm, l.length.sigma_calibration_mm);
      }
      if (check) {
        const auto& c = *check;
        fmt::print("scale bar {}-{}, {:g} mm, in {} frames, by range from the rig:\n{:>15} {:>4} {:>14} {:>13} "
                   "{:>13}\n", c.bar.id_a, c.bar.id_b, c.bar.length_mm, c.rows.size(), "range_mm", "n", "mean_error_mm",
                   "rms_error_mm", "rms_sigma_mm");
        for (const auto& b : c.by_range) {
          fmt::print("{:>7.0f}-{:<7.0f} {:>4} {:>14.3f} {:>13.3f} {:>13.3f}\n", b.range_min_mm, b.range_max_mm, b.n,
                     b.mean_error_mm, b.rms_error_mm, b.rms_sigma_mm);
        }
        fmt::print("{}\n", c.verdict);
        if (!c.consistent) fmt::print(stderr, "porthole: warning: {}\n", c.verdict);
      }
    });
  });
}

}  // namespace porthole::cli
