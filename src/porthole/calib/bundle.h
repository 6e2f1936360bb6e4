// The one bundle adjustment of porthole's calibrations (issue 26): the central calibration
// (calibrate.cc), the refractive one behind a port (refractive.cc) and the rig (rig.cc) describe
// their problem to a Bundle — cameras, each a model of the camera list and optionally behind a
// port of the port list; observations, each of a camera in a medium (water, or air through the same
// port) at a pose (cam_from_target, or rig_from_target with the camera's cam_from_rig), of a target
// point held or adjusted; priors as Ceres costs — and the Bundle builds the Ceres problem, holds
// what is not adjusted, orders the Schur elimination and solves. As COLMAP's BundleAdjustmentConfig
// and Ceres's Problem: the parameter blocks are the caller's (pointers into its state, updated in
// place), the Bundle owns the costs.
//
// One residual for every case (BundleResidual, bundle.cc): the point X through the pose (and the
// rig's offset) into the camera frame, then the lens alone (central) or the exact forward
// projection through the port (refraction::Project) with the port's three parameters and, when
// some are adjusted, the shell's values; minus the observed pixel, times the observation's weight.
// The Brown model without a port keeps its analytic Jacobian (residual.h, in the image or the
// correction form); every other case is differentiated automatically.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <array>
#include <memory>
#include <optional>
#include <unordered_set>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/residual.h"
#include "porthole/camera/models.h"
#include "porthole/refraction/refraction.h"

namespace porthole::calib {

enum class Medium { kWater, kAir };

// A camera: its lens as a block of scaled parameters (the value / `scale`, ModelScales: every
// parameter of order 1), the ones adjusted, and behind a port its shells and the port's blocks.
struct BundleCamera {
  camera::CameraModelId model = camera::CameraModelId::kBrown;
  camera::Sensor sensor;
  double* scaled = nullptr;   // kNumParams values
  std::vector<double> scale;  // kNumParams
  FreeMask free;              // kNumParams; false: held
  // Behind a port (null: a central camera): the shell with water outside and with air outside
  // (refraction::Shell, n_water 1), the port's parameters [kPortNumParams] and which are adjusted.
  const refraction::Shell* water_shell = nullptr;
  const refraction::Shell* air_shell = nullptr;
  double* port = nullptr;
  std::array<bool, refraction::kPortNumParams> port_free{true, true, true};
  // The shell's values as a block [kShellNumParams] (refraction::ShellParams) when some are
  // adjusted (null: the shells' own). In air the water index factor (value 0) does not apply.
  double* shell_values = nullptr;
  std::array<bool, refraction::kShellNumParams> shell_free{};
};

// One observed point: camera `camera` sees target point X at the pixel (u_px, v_px).
struct BundleObservation {
  int camera = 0;
  double* pose = nullptr;          // [6] angle-axis (rad), translation (mm): cam_from_target, or
                                   // rig_from_target when cam_from_rig is given
  double* cam_from_rig = nullptr;  // [6] the camera's offset in a rig, or null (identity)
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // X, target frame, mm (held) …
  double* point_block = nullptr;                    // … or X adjusted [3] (a free target)
  double u_px = 0, v_px = 0;
  double weight = 1;  // the residual's factor (1/σ px when priors are weighed against it)
  Medium medium = Medium::kWater;
  // A set taken at another focus (the lens refocused between sets): [1] a factor on the camera's
  // focal length(s) (its first kNumFocal parameters) for this observation, or null (the camera's).
  double* focal_scale = nullptr;
};

struct BundleSolveOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-8, parameter_tolerance = 1e-8, gradient_tolerance = 1e-12;
  // The start is near the optimum: a large region lets Levenberg–Marquardt take the Gauss–Newton
  // step at once.
  double initial_trust_region_radius = 1e8;
  int num_threads = 1;
  // Sparse Schur (large free targets) instead of the dense one.
  bool sparse = false;
};

// The cost of one observation of camera c; its blocks in this order: c.scaled, ob.focal_scale
// (when given), c.port (behind a port), c.shell_values (when given), ob.cam_from_rig (when given),
// ob.pose, ob.point_block (when given). Residual in px times ob.weight. `form`: as Bundle's.
ceres::CostFunction* NewObservationCost(const BundleCamera& c, const BundleObservation& ob,
                                        Form form = Form::kProject);

// The residual (px, times ob.weight) of one observation at the blocks' current values; nullopt
// where it cannot be projected.
std::optional<Eigen::Vector2d> ObservationResidual(const BundleCamera& c, const BundleObservation& ob);

class Bundle {
 public:
  // `loss`: the robust loss of the image residuals (scale in px); `form`: the residual form of
  // the Brown model without a port (the correction form only starts the image form; residual.h).
  explicit Bundle(LossKind loss = LossKind::kNone, double loss_scale_px = 1.0, Form form = Form::kProject);
  ~Bundle();
  Bundle(const Bundle&) = delete;
  Bundle& operator=(const Bundle&) = delete;

  // Returns the camera's index.
  int AddCamera(const BundleCamera& camera);
  const BundleCamera& camera(int k) const { return cameras_[k]; }
  void AddObservation(const BundleObservation& ob);
  // A prior or any other cost on the caller's blocks (owned by the Bundle).
  void AddCost(ceres::CostFunction* cost, const std::vector<double*>& blocks);
  // Whether some cost has this block.
  bool HasBlock(double* block) const { return problem_->HasParameterBlock(block); }
  // Holds the coordinates `held` (0–2) of a free point, or all of it (empty `held`: constant).
  void HoldPoint(double* point_block, const std::vector<int>& held = {});

  // Adjusts (the blocks are updated in place) and returns Ceres's summary.
  ceres::Solver::Summary Solve(const BundleSolveOptions& options);
  // The problem with the held parameters set: for ceres::Covariance and for queries.
  ceres::Problem& problem();

 private:
  void Seal();

  LossKind loss_;
  double loss_scale_px_;
  Form form_;
  std::vector<BundleCamera> cameras_;
  std::unordered_set<double*> poses_, points_;  // the blocks the Schur solver eliminates
  std::unique_ptr<ceres::Problem> problem_;
  bool sealed_ = false;
};

}  // namespace porthole::calib
