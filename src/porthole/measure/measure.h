// `measure`: object points seen by two or more cameras of a calibrated rig → 3-D points in the rig
// frame and lengths between them, each with σ (triangulate.h). What the CLI and Python both call.
//
// Input: image points, each (frame, camera, id, pixel): from porthole detections (one set per
// camera; frames matched by image file name without folder and extension, as the rig calibration
// matches them) or from a CSV `frame,camera,id,u_px,v_px` as measurement tools export (camera by
// its name in the rig or its index; a header line and lines starting with # are skipped). Every
// (frame, id) seen by two or more cameras is triangulated; lengths are asked for by id pairs and
// measured in every frame that holds both.
//
// Bad input throws InvalidInput naming the field and, for a file, the file and line: a pixel
// outside its camera's image, the same (frame, camera, id) twice, a point seen by one camera only
// (by frame and id; MeasureOptions::skip_unpaired skips them instead, counted), a length between
// ids no frame holds both of.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "porthole/calib/observations.h"
#include "porthole/measure/triangulate.h"

namespace porthole::measure {

struct ImagePoint {
  std::string frame;
  int camera = 0;  // index in the rig
  int id = 0;
  Eigen::Vector2d pixel_px = Eigen::Vector2d::Zero();
  std::string where;  // "file:line" or "file, image …" for messages
};

// The CSV `frame,camera,id,u_px,v_px` (text already read from `origin`); throws
// InvalidInput(field, "origin:line: …").
std::vector<ImagePoint> ParsePointsCsv(std::string_view text, const Rig& rig, const std::string& field,
                                       const std::string& origin);
// Detections of one camera (calib::LoadDetections) as image points of camera `camera`.
std::vector<ImagePoint> PointsFromDetections(const std::vector<calib::ImageDetections>& detections, int camera,
                                             const std::string& origin);

struct MeasureOptions {
  // Image-point σ (px) of the points measured; 0: the rig calibration's σ0 (the detector's noise on
  // the calibration target; points clicked by hand are usually worse: give their σ).
  double sigma_px = 0;
  bool calibration_sigma = true;  // add the rig calibration's uncertainty
  double mismatch_p = 1e-3;
  std::vector<std::pair<int, int>> lengths;  // id pairs
  bool skip_unpaired = false;                // skip points seen by one camera only (counted)
  int num_threads = 0;                       // 0: the machine's cores
  // One camera and a known plane (a seafloor, or the range a laser pair gives) instead of two
  // cameras: every point is the ray of its image in `plane_camera` met with `plane` (IntersectPlane).
  std::optional<Plane> plane;
  int plane_camera = 0;
  // Or a laser scaler (RangeFromLaserPair): in each frame, the range from the dots of ids laser_a
  // and laser_b, `laser_separation_mm` apart; the plane square to the axis at that range, its σ a
  // parameter of that frame.
  std::optional<std::array<double, 3>> laser_pair;  // id_a, id_b, separation_mm
};

struct MeasuredPoint {
  std::string frame;
  int id = 0;
  std::vector<int> cameras;
  std::vector<Eigen::Vector2d> pixels_px;  // its image in each of `cameras`
  Point point;
};

struct MeasuredLength {
  std::string frame;
  int id_a = 0, id_b = 0;
  bool ok = false;
  std::string why;
  Length length;
};

struct FrameRange {
  std::string frame;
  double range_mm = 0, sigma_mm = 0;
};

struct MeasureResult {
  std::vector<MeasuredPoint> points;  // by frame, then id
  std::vector<MeasuredLength> lengths;
  double sigma_px = 0;
  std::string sigma_px_from;  // "given", "the rig calibration's sigma0"
  int n_unpaired = 0;         // points seen by one camera only, skipped
  int n_failed = 0;           // points that could not be triangulated (why in each)
  int n_mismatched = 0;
  std::vector<std::string> warnings;
  std::string covariance_note;
  std::vector<FrameRange> laser_ranges;  // with MeasureOptions::laser_pair
};

MeasureResult Measure(const Rig& rig, const std::vector<ImagePoint>& points, const MeasureOptions& options);

// The one-camera options from the values a front end read, checked (InvalidInput naming `plane`,
// `range_mm`, `laser_pair` or `plane_sigma_mm`): at most one of plane (nx, ny, nz, d_mm, the normal
// of any length), range_mm (the plane square to the axis that far) and laser_pair (id_a, id_b,
// separation_mm); sets options->plane or options->laser_pair. Returns whether one was given.
bool SetOneCamera(MeasureOptions* options, const std::optional<std::vector<double>>& plane,
                  std::optional<double> range_mm, const std::optional<std::vector<double>>& laser_pair,
                  double plane_sigma_mm);

// The scale-bar check users run after a dive: a bar of known length between ids A and B, seen in
// many frames; each frame's measured length against the known one, by range and position in the
// field, and whether the errors are what the σ says.
struct ScaleBar {
  int id_a = 0, id_b = 0;
  double length_mm = 0;
};

struct ScaleBarCheck {
  ScaleBar bar;
  struct Row {
    std::string frame;
    double range_mm = 0;        // the bar's centre from the rig origin (the first camera's pupil)
    Eigen::Vector2d image_px;   // the bar's centre in the first camera that saw both ends (mean of the ends)
    double length_mm = 0, error_mm = 0, sigma_mm = 0, sigma_image_mm = 0, sigma_calibration_mm = 0;
  };
  std::vector<Row> rows;  // frames holding both ends, by frame
  struct Bin {
    double range_min_mm = 0, range_max_mm = 0;
    int n = 0;
    double mean_error_mm = 0, rms_error_mm = 0, rms_sigma_mm = 0;
  };
  std::vector<Bin> by_range;  // 500 mm bins over the ranges seen
  // The mean error and its σ: the calibration part of the σ is common to every frame (it does not
  // average out), the image part falls as 1/√n: σ_mean² = mean(σ_cal)² + mean(σ_img²)/n.
  double mean_error_mm = 0, mean_error_percent = 0, sigma_mean_mm = 0, sd_error_mm = 0;
  double z = 0;           // mean_error / sigma_mean
  bool consistent = true;  // |z| <= 3
  std::string verdict;
};

// Throws InvalidInput("scale_bar", …) when the length is not positive, the ids are equal, or no
// frame measured both ends.
ScaleBarCheck CheckScaleBar(const MeasureResult& r, const ScaleBar& bar);
nlohmann::ordered_json ScaleBarToJson(const ScaleBarCheck& c);
// The check read back from ScaleBarToJson's object, or from a whole `measure --json` output
// holding one (measure.scale_bar), for the report. Throws InvalidInput(field, …) naming the key.
ScaleBarCheck ScaleBarFromJson(const nlohmann::json& j, const std::string& field);

// {"measure": {sigma_px, sigma_px_from, counts, covariance_note, warnings, frame: "rig …",
//  points: [{frame, id, cameras, x_mm, sigma_mm, sigma_image_mm, covariance_mm2, miss_mm,
//  residual_px, range_mm, chi2, dof, p_value, mismatched | ok:false, why}], lengths: [{frame,
//  id_a, id_b, length_mm, sigma_mm, sigma_percent, sigma_image_mm, sigma_calibration_mm}]}}.
nlohmann::ordered_json MeasureToJson(const MeasureResult& r, const Rig& rig);

}  // namespace porthole::measure
