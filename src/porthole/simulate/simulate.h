// Port-induced distortion, predicted: trace a grid of image points out of the camera through a
// port, place object points along the traced rays, and fit the central Brown–Conrady model
// (docs/conventions.md) to them by least squares, as a self-calibration would. docs/simulate.md.
//
// Frames and units: the housing frame of docs/conventions.md (mm; origin at the lens-mount flange,
// +Z toward the scene, +X right, +Y down); image mm with y UP; Brown parameters in the units of
// camera::kBrownParamInfo; residuals in µm in the image.
//
// The camera behind the port is the in-air lens model (an ideal pinhole of principal distance c, or
// an in-air calibration) with its perspective centre at the entrance pupil. In water the port makes
// the bundle of rays non-central unless it is a dome concentric with the pupil: the fit absorbs
// what a central model can (c, principal point, K, P, and the pose of the perspective centre) and
// leaves the rest in the residual.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/camera/brown.h"
#include "porthole/camera/camera.h"
#include "porthole/camera/projection.h"
#include "porthole/camera/sensor.h"
#include "porthole/camera/validate.h"
#include "porthole/housing/housed.h"
#include "porthole/lens/lens.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/port.h"

namespace porthole::simulate {

using Vec3 = Eigen::Vector3d;

// The camera behind the port.
struct CameraSetup {
  camera::Sensor sensor;
  // The lens in air: an ideal pinhole (only c_mm set) or an in-air calibration. The ray of a
  // measured image point leaves the entrance pupil along camera::Unproject(lens, x, y).
  camera::BrownParams lens;
  Vec3 ep_in_housing_mm = Vec3::Zero();  // the entrance pupil (perspective centre in air)
};

struct FitOptions {
  int grid_cols = 25;  // image points along x, spanning the frame edge to edge (>= 3)
  int grid_rows = 17;  // image points along y (>= 3); 25×17 keeps the D300's pixel aspect
  // Object points lie on planes at these distances from the entrance pupil along +Z, mm (the
  // depth range of a calibration network). Empty: near…far × reference_distance_mm.
  std::vector<double> distances_mm;
  double reference_distance_mm = 1000;  // the focus distance the factors scale (Predict: the spec's)
  double near_factor = 0.8;             // 0.8–1.3 × focus: a typical calibration network depth
  double far_factor = 1.3;
  int num_distances = 3;  // >= 2: one depth alone cannot separate c from the centre's Z
  bool fit_k3 = true;     // the model has K3; off reproduces a K1/K2-only calibration
  // The perspective centre's position is always free. Its rotation is free by default, as every
  // image's exterior orientation is in a self-calibration: a port that tilts the whole bundle (a
  // decentred or wedged dome) is absorbed by the pose, and the residual is then the non-central
  // part alone. A small rotation and a principal-point shift move the image alike to first order,
  // so x0/y0 (and P1/P2, which share the second-order terms) are the parameters that depend on
  // this datum choice; false holds the camera's axes at the housing's and puts the tilt into them
  // (docs/simulate.md compares both with the paper's Table 6).
  bool free_rotation = true;
  int max_iterations = 100;  // Ceres iterations per stage
};

// Throws InvalidInput naming the option.
void Validate(const FitOptions& o);
// The object distances the options describe (mm from the pupil).
std::vector<double> Distances(const FitOptions& o);

// One fitted central camera.
struct BrownFit {
  camera::BrownParams params;  // B1 = B2 = 0 (held)
  Vec3 center_in_housing_mm = Vec3::Zero();  // fitted perspective centre
  Vec3 rotation_deg = Vec3::Zero();  // cam_from_housing rotation, angle-axis in degrees
  double rms_um = 0;  // RMS of the 2-D image residual: the non-central part Brown cannot absorb
  double max_um = 0;
  int num_points = 0;  // observations used (grid points × distances)
  int num_failed = 0;  // grid rays that could not be traced (beyond a rim, total reflection)
  bool converged = false;
  // Per grid point (row-major, top row first): RMS residual over the distances, µm; NaN if failed.
  std::vector<double> residual_um;
};

// Grid of measured image points (image mm), row-major from the top-left corner (v = 0, u = 0).
std::vector<Eigen::Vector2d> ImageGrid(const camera::Sensor& s, int cols, int rows);

// Traces the grid out through `sys` (whose pupil must be camera.ep_in_housing_mm) and fits the
// central Brown model to the object points at Distances(options). Throws InvalidInput for bad
// options, a camera whose rays point backwards, or when fewer than half the rays get through.
BrownFit SimulateFit(const ports::PortSystem& sys, const CameraSetup& camera,
                     const FitOptions& options = {});

// One model of the camera list (camera/camera.h) fitted to rays traced through a port: the
// fisheye path (a Kannala–Brandt fit for a fisheye lens), in pixels.
struct CameraFit {
  camera::Camera camera;  // the fitted model and its parameters (units in camera::Info(model))
  Vec3 center_in_housing_mm = Vec3::Zero();
  Vec3 rotation_deg = Vec3::Zero();  // cam_from_housing, angle-axis in degrees
  double rms_px = 0, max_px = 0;     // image residual: what the central model cannot absorb
  int num_points = 0, num_failed = 0;
  bool converged = false;
  std::vector<double> residual_px;   // per grid point (row-major), RMS over the distances; NaN: failed
};

// The grid's chief rays (the lens's projection at principal distance c_mm, leaving the pupil of
// `sys`) traced out through the port; object points on spheres about the pupil at
// Distances(options) (a fisheye sees beyond 90°); `model` fitted with its pose by Ceres automatic
// differentiation through the model's Project<T> (camera pose free as FitOptions says; the
// model's parameters all free). With `lens_camera` (an in-air calibration of the lens, its
// sensor = `sensor`), the grid's chief rays are that camera's unprojected rays instead of the
// ideal projection's (c_mm then only names the start), and the fit starts from it when the models
// match. Throws InvalidInput as SimulateFit.
CameraFit SimulateCameraFit(const ports::PortSystem& sys, const lens::LensSpec& lens, const camera::Sensor& sensor,
                            double c_mm, camera::CameraModelId model, const FitOptions& options = {},
                            const camera::Camera* lens_camera = nullptr);

// One fit as the sweeps, the maps and the report read it, whatever its model: the Brown fit of a
// rectilinear lens or the fitted model (Kannala–Brandt) of a fisheye. The correction is image mm
// (x right, y up), ideal − measured as Brown's (camera/brown.h): for a model other than Brown the
// ideal point is the lens's own projection (camera/projection.h) at the fitted focal lengths about
// the fitted principal point, so a fisheye that keeps its projection has zero correction. A view
// refers to its fit: it must not outlive it.
class FitView {
 public:
  explicit FitView(const BrownFit& fit) : brown_(&fit) {}
  FitView(const CameraFit& fit, camera::Projection lens_projection) : model_(&fit), projection_(lens_projection) {}

  bool is_brown() const { return brown_ != nullptr; }
  const BrownFit* brown() const { return brown_; }
  const CameraFit* model_fit() const { return model_; }
  std::string_view model_name() const;
  // The principal distance, mm (another model: its mean focal length in px × the pixel pitch).
  double c_mm() const;
  double rms_um() const;
  double max_um() const;
  // The correction at a measured point (image mm from the sensor centre, y up); NaN where the
  // model cannot unproject it.
  Eigen::Vector2d CorrectionMm(double x_mm, double y_mm) const;
  // The radial correction r mm from the principal point along +x (Brown: K1 r³ + K2 r⁵ + K3 r⁷).
  double RadialProfileMm(double r_mm) const;
  // Brown's decentring profile √(P1² + P2²)·r²; nullopt for a model without decentring terms.
  std::optional<double> DecentringProfileMm(double r_mm) const;
  // The fit's residual at a grid point (row-major), µm; NaN where its ray failed.
  double ResidualUm(std::size_t grid_index) const;

 private:
  const BrownFit* brown_ = nullptr;
  const CameraFit* model_ = nullptr;
  camera::Projection projection_ = camera::Projection::kRectilinear;
};

// The port with air (n = 1) outside instead of water: the in-air calibration of the camera in its
// housing.
ports::PortSystem WithAirOutside(const ports::PortSystem& sys);

// Reprojection error of a fitted model (with its fitted pose) on object points at other distances
// from the pupil: how wrong the implicit (Brown-absorbs-refraction) model is outside the range it
// was fitted over.
struct DistanceError {
  double distance_mm = 0;
  double rms_um = 0, max_um = 0;
  int num_points = 0;
};
std::vector<DistanceError> DistanceErrors(const ports::PortSystem& sys, const CameraSetup& camera,
                                          const BrownFit& fit,
                                          const std::vector<double>& distances_mm,
                                          const FitOptions& options = {});

// ---------------------------------------------------------------------------------------------
// The whole system: port, water, camera body, lens and its focus.

// The housed camera (housing/housed.h: port, water, body, lens, pupil offset) and what the
// simulation adds to it.
struct SystemSpec : housing::HousedCamera {
  // The lens is focused under water on an object this far in front of its entrance pupil (the
  // paper: autofocus at 1 m), i.e. on that object's virtual image (Eq. 2 gives the focus scale).
  double object_distance_mm = 1000;
  std::optional<double> c_mm;  // principal distance; default: thin lens focused on the image
  // The in-air calibration of the camera in its housing (c, x0, y0, K, P): the lens model, and
  // the base of the prediction. Its c overrides c_mm. For a rectilinear lens.
  std::optional<camera::BrownParams> air_calibration;
  // The in-air calibration of a fisheye lens in its housing, in a fisheye model of the camera list
  // (Kannala–Brandt, or the lens's own projection: camera::Camera, pixels; its sensor is the
  // body's): the lens model the rays leave by, and the base of the prediction; the water and air
  // fits are then of its model. Its focal length overrides c_mm.
  std::optional<camera::Camera> air_fisheye_calibration;
};

// The camera an in-air calibration must be of (camera/validate.h): the body's sensor, the lens's
// focal length and its thin-lens principal distance at the closest focus (2f, a 1:1 macro, when
// the lens's closest focus is unknown or too close for the thin lens).
camera::ExpectedCamera ExpectedCameraOf(const housing::HousedCamera& h);
// Throws InvalidInput(field, …) unless `calibration` is a valid calibration (camera::
// ValidateCalibration) of h's body and lens (camera::CheckCalibrationFits; `pitch_known`: the
// calibration states its pixel pitch). Predict runs it on the air calibrations of the spec;
// commands run it on a calibration file before converting it.
void CheckAirCalibration(const camera::Camera& calibration, bool pitch_known, const housing::HousedCamera& h,
                         const std::string& field);

// The focus under water on spec.object_distance_mm (housing::FocusOnSubject). Throws
// InvalidInput("subject_distance_mm") when the object is inside the port or the lens cannot focus
// on its virtual image.
housing::FocusSetting FocusUnderWater(const SystemSpec& spec);

struct Prediction {
  double object_distance_mm = 0;  // the focused object, from the pupil along the axis
  double wd_mm = 0;               // the same from the port's outer vertex
  housing::FocusSetting focus;    // where the lens is focused and its pupil
  FitOptions options;  // as used: reference_distance_mm = the spec's object distance
  CameraSetup camera;  // the camera the simulation used (c, lens model, pupil)
  ports::PortSystem water_system, air_system;
  BrownFit water, air;  // the fits with water and with air outside the port (rectilinear lenses)
  // A fisheye lens (its projection is not rectilinear): the Kannala–Brandt model fitted in water
  // and in air instead of Brown (water and air above are then left empty).
  std::optional<CameraFit> water_fisheye, air_fisheye;
  camera::Projection lens_projection = camera::Projection::kRectilinear;
  lens::LensSpec lens;  // the lens behind the port (sweeps refit a fisheye through its projection)
  camera::BrownParams change;  // water − air, parameter by parameter
  // The in-air calibration + change: the underwater calibration to expect (only with
  // air_calibration).
  std::optional<camera::BrownParams> predicted_water;
  // A fisheye with air_fisheye_calibration: that calibration, and it + (water − air fit),
  // parameter by parameter, the underwater calibration to expect.
  std::optional<camera::Camera> air_fisheye_calibration, predicted_water_fisheye;
  // Plausibility warnings of the inputs (housing/plausible.h: pixel pitch, focal length, the port's
  // radii or thickness), naming the library field; empty when every value is plausible.
  std::vector<std::string> warnings;

  // The water and air fits, whichever model they are (they refer to this prediction).
  FitView water_view() const { return water_fisheye ? FitView(*water_fisheye, lens_projection) : FitView(water); }
  FitView air_view() const { return air_fisheye ? FitView(*air_fisheye, lens_projection) : FitView(air); }
};

// Resolves the system (focus, pupil, c, indices), fits water and air. Throws InvalidInput: an air
// calibration that is not one of the spec's body and lens (CheckAirCalibration, field
// "air_calibration"); a fit that ends impossible (a focal length ≤ 0, a non-finite parameter or
// RMS; field "fit"), never returned as an answer.
Prediction Predict(const SystemSpec& spec, const FitOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Tolerance sweeps and maps.

struct SweepRow {
  double offset_mm = 0;  // added to the pupil along the sweep's axis
  BrownFit water, air;   // rectilinear lenses
  std::optional<CameraFit> water_fisheye, air_fisheye;  // a fisheye (as in Prediction)
  camera::Projection lens_projection = camera::Projection::kRectilinear;

  FitView water_view() const { return water_fisheye ? FitView(*water_fisheye, lens_projection) : FitView(water); }
  FitView air_view() const { return air_fisheye ? FitView(*air_fisheye, lens_projection) : FitView(air); }
};
// Moves the pupil by each offset along housing axis `axis` (0 X, 1 Y, 2 Z; +Z toward the glass)
// from its place in `prediction`, keeping c and the focus, and refits in water and in air (the
// prediction's model: Brown, or Kannala–Brandt for a fisheye).
// Fit options as in the prediction. Throws InvalidInput("axis") or when a pupil leaves the port.
std::vector<SweepRow> SweepPupilOffset(const Prediction& prediction, int axis,
                                       const std::vector<double>& offsets_mm);

// The distortion fields over the fit grid: correction vectors Δ of the water and air fits at each
// measured point (FitView::CorrectionMm), their difference (water − air), and the water fit's
// residual.
struct MapPoint {
  double x_mm = 0, y_mm = 0;  // image mm (y up)
  double u_px = 0, v_px = 0;  // pixel (v down)
  Eigen::Vector2d water_um = Eigen::Vector2d::Zero(), air_um = Eigen::Vector2d::Zero();
  Eigen::Vector2d difference_um = Eigen::Vector2d::Zero();
  double residual_um = 0;  // water fit, RMS over the distances (NaN where the ray failed)
};
// On the prediction's fit grid, row-major from the top-left corner.
std::vector<MapPoint> DistortionMap(const Prediction& prediction);

}  // namespace porthole::simulate
