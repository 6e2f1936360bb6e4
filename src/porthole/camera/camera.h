// A camera as a value: which model of the closed list (camera/models.h), the sensor, and the
// model's parameters in its own order and units. The one type calibration, simulation, interop and
// the report exchange; model-specific code stays inside camera/.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/camera/models.h"

namespace porthole::camera {

// What the list says of one model, as run-time data.
struct ModelInfo {
  CameraModelId id;
  std::string_view name;
  std::string_view description;
  int num_params;
  int num_focal;         // params [0, num_focal) are focal lengths (c in mm, or f/fx/fy in px)
  int first_distortion;  // params [num_focal, first_distortion) the principal point, then distortion
  std::span<const ParamInfo> params;
  ModelCaps caps;
};

// Every model, in list order.
const std::vector<ModelInfo>& CameraModels();
const ModelInfo& Info(CameraModelId id);
// The model named `name`: its kName, or a name other tools use for it (COLMAP's OPENCV,
// FULL_OPENCV, OPENCV_FISHEYE; "fisheye" for OpenCV's fisheye module), case-insensitive.
// Throws InvalidInput(field, "unknown camera model … (known: …)").
CameraModelId ModelFromName(std::string_view name, const std::string& field = "model");
// The index of the parameter called `name` (ParamInfo::name or json_key, case-sensitive) in the
// model's order; nullopt when the model has no such parameter.
std::optional<int> ParamIndex(CameraModelId id, std::string_view name);

struct Camera {
  CameraModelId model = CameraModelId::kBrown;
  Sensor sensor;
  std::vector<double> params;  // Info(model).num_params values

  const ModelInfo& info() const { return Info(model); }
  std::string_view model_name() const { return Info(model).name; }

  // Point in the camera frame (mm; X right, Y down, Z forward) → pixel; nullopt outside the
  // model's valid field (behind the camera, beyond a fisheye's reach, where the distortion folds).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& point_in_cam) const;
  // Pixel → unit ray in the camera frame; nullopt where the model cannot be inverted.
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& uv) const;
  double FocalLengthPx() const;
  Eigen::Vector2d PrincipalPointPx() const;

  // The undistorted camera of this model with focal length f_px, principal point at the centre.
  static Camera Ideal(CameraModelId model, const Sensor& sensor, double f_px);
};

// Sets the focal-length parameters to f_px (in the model's unit: c = f_px·pitch for Brown).
void SetFocalLengthPx(Camera* camera, double f_px);

// Throws InvalidInput unless the sensor is valid, the parameter count matches the model, every
// parameter is finite and the focal length is positive.
void ValidateCamera(const Camera& camera, const std::string& where = "camera");

// The camera of model `model` closest to the ideal projection `projection` with focal length f_px
// and the principal point at the image centre, over the field 0 … max_field_rad off axis: all its
// parameters fitted by least squares to the ideal image positions of rays on that field (the
// focal length stays f_px when the model has the projection itself). A calibration's start for a
// fisheye (a Kannala–Brandt camera close to an equisolid lens), and a planning lens as a camera.
// `fit_rms_px` (optional) receives the RMS misfit in px.
Camera FitToProjection(CameraModelId model, const Sensor& sensor, Projection projection,
                       double f_px, double max_field_rad, double* fit_rms_px = nullptr);

// Brown parameters ↔ a Camera of the Brown model.
Camera FromBrown(const BrownParams& brown, const Sensor& sensor);
// Throws InvalidInput(field) when the camera is not of the Brown model.
BrownParams ToBrown(const Camera& camera, const std::string& field = "model");

}  // namespace porthole::camera
