// A calibration as JSON (the output of `porthole calibrate --json`, the input of
// `porthole compare`), and OpenCV YAML export. Every command reads calibration files through
// interop::ReadCalibrationFile (every format, docs/interop.md), which uses CalibrationFromJson.
//
// JSON keys (units per docs/conventions.md; the `units` object repeats them):
//   model: the camera model's name (camera/models.h; absent = "brown", as files before the list);
//   camera {the model's parameter keys, e.g. c_mm, x0_mm, y0_mm, K1 … B2 for Brown}: adjusted
//     values; a parameter that was not adjusted is null (fixed at 0) or its fixed value (listed in
//     `fixed`);
//   sigma {same keys}: 1σ = sqrt(σ0²·(JᵀJ)⁻¹ diagonal), null when not adjusted;
//   correlation {parameters: [keys of the adjusted ones], matrix: [[…]]}; covariance likewise;
//   sigma0_px, rms_px, sensor {width_px, height_px, pixel_pitch_mm}, pixels_are_mm,
//   dot_radius_mm, max_centre_offset_px: the centre correction of circular targets
//     (CalibrationOptions::centre_correction): the dot radius the centres were corrected for (0:
//     no correction) and the largest offset applied (dot-image centre − projected centre, px);
//   significance [{parameter, t, significant}], dropped [{parameter, value, sigma, t}],
//   images [{image, n_points, n_rejected, rms_px, rotation_rad, translation_mm}], counts, status;
//   field (a coded target with a field file only): {file: the path as given, n_points, points:
//     [[id, x_mm, y_mm, z_mm], …] as read}, enough to rerun the calibration without the file;
//   target_adjusted (--free-target only): {datum {fixed: [id, id], one_coordinate: id, axis},
//     points [{id, xyz_mm, sigma_mm, nominal_mm}] for every observed point}.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "porthole/calib/calibrate.h"
#include "porthole/camera/opencv_model.h"

namespace porthole::calib {

// The fields compare and the format conversions need.
struct CalibrationRecord {
  std::string label;
  camera::Camera camera;  // model, sensor, parameters
  FreeMask free;          // one flag per parameter: adjusted
  Eigen::MatrixXd covariance;  // n×n in the model's order (0 for fixed parameters)
  bool has_covariance = false;
  std::string covariance_note;  // "" (full), or "diagonal from sigma" when the file had only σ
  double sigma0_px = NAN;
  double dot_radius_mm = 0;         // the centre correction's dot radius (0: none, or not stated)
  double max_centre_offset_px = 0;  // the largest centre offset it applied, px
};

// {key: unit} for every parameter of the model.
nlohmann::ordered_json CameraUnitsJson(camera::CameraModelId model);
// {parameters: [keys of the adjusted ones], matrix: [[…]]} of a matrix in the model's order (the
// `covariance` and `correlation` objects); non-finite entries null.
nlohmann::ordered_json CovarianceJson(const camera::ModelInfo& m, const FreeMask& free,
                                      const Eigen::MatrixXd& matrix);

// The `field` and `target_adjusted` objects above.
nlohmann::ordered_json FieldJson(const TargetSpec& target);
nlohmann::ordered_json AdjustedTargetJson(const CalibrationResult& r, const TargetSpec& target);
// A coded target self-calibrated (--free-target) as a target-field file (`calibrate --field-out`;
// coded::ParseField reads it): a header naming the target, its source and the datum, then every
// point of the target in ID order, "id x_mm y_mm z_mm" to 1e-6 mm, the adjusted coordinates of the
// observed points with their σ in a trailing comment, the others as given (marked). Throws
// InvalidInput("field_out") unless the target is coded and the result adjusted it.
std::string AdjustedFieldText(const CalibrationResult& r, const TargetSpec& target);

// The per-image array of a calibration JSON: image, n_points, n_rejected, rms_px, rotation_rad and
// translation_mm (cam_from_target).
nlohmann::ordered_json ImagesJson(const std::vector<ImageResult>& images);

nlohmann::ordered_json CalibrationToJson(const CalibrationResult& r, const TargetSpec& target,
                                         const CalibrationOptions& options);
// Reads what CalibrationToJson wrote, or a hand-written {"camera": {…}, "sigma": {…}, "sensor":
// {…}} (e.g. the paper's Table 6: null or absent = not adjusted; without a covariance the σ give a
// diagonal one).
// Throws InvalidInput(field, …) naming the offending key.
CalibrationRecord CalibrationFromJson(const nlohmann::json& j, const std::string& field);

// OpenCV FileStorage YAML (camera_matrix, distortion_coefficients k1 k2 p1 p2 k3, image size), in
// OpenCV's pixel convention. Export of a Brown calibration refits OpenCV's forward model to the
// Brown correction over the image (camera::BrownToOpenCV; `fit` receives the refit RMS/max in px);
// of an OpenCV-model calibration it is exact (k1 k2 p1 p2 k3 k4 k5 k6). Other models throw
// InvalidInput("opencv_yaml").
std::string ExportOpenCVYaml(const CalibrationRecord& rec, camera::ConversionFit* fit);

}  // namespace porthole::calib
