// Planning a rig before the dive (issue 27): over the common field of view at each range, the σ a
// length will be measured with (image noise, and the rig calibration's uncertainty when the rig has a
// covariance), and the systematic length error a user makes who measures through these ports with a
// central model (pinhole + distortion, calibrated under water at one range, as most tools do).
//
// The rig: a calibrated rig file (rig_model.h), or one described by its cameras, ports, baseline and
// convergence (DescribedRig). Ranges are depths along the first camera's axis (rig frame z, mm).
//
// At each range: a fine grid over the plane z = range gives the points every camera sees (the
// exact forward projection through each port, inside every image): the common field, its width and
// height. Over a grid of positions in it, a length of options.length_mm in each of
// options.orientations directions (spread over a hemisphere) whose both ends every camera sees is
// projected exactly into every camera and triangulated (triangulate.h): its σ. The central model:
// each camera's own lens model, fitted with the rig (calib::CalibrateRig, no ports) to noise-free
// views of a chessboard through the real ports at central_fit_range_mm ± 25 %; that central rig
// triangulates the same pixels, and its length error is the systematic error.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/measure/rig_model.h"
#include "porthole/measure/triangulate.h"
#include "porthole/planning/plan.h"
#include "porthole/ports/port.h"

namespace porthole::measure {

struct RigPlanOptions {
  double sigma_px = 0.3;     // image-point σ of the measured points, px
  double length_mm = 300;    // the object (a fish)
  std::vector<double> ranges_mm = {500, 1000, 1500, 2000, 3000, 4000, 6000, 8000};
  int grid = 7;              // positions per axis over the common field at each range
  int orientations = 12;     // directions of the length
  bool calibration_sigma = true;  // add the rig calibration's σ (when the rig has a covariance)
  double central_fit_range_mm = 1500;  // where the central model is calibrated; 0: no comparison
  int num_threads = 0;
};

struct PlannedLength {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero(), direction = Eigen::Vector3d::UnitX();  // rig frame
  std::vector<Observation> end_a, end_b;  // the exact pixels of its two ends in every camera
  double sigma_mm = NAN, central_error_mm = NAN;
};

struct RigPlanRow {
  double range_mm = 0;
  std::vector<PlannedLength> lengths;  // every length placed (not in the JSON)
  double common_width_mm = 0, common_height_mm = 0;  // extent of the field every camera sees
  int n_lengths = 0;                                  // lengths placed (both ends seen by every camera)
  double sigma_median_mm = NAN, sigma_p90_mm = NAN, sigma_max_mm = NAN;
  double sigma_median_percent = NAN;
  // The central model's error (measured − true), mm: median of |error|, the largest |error|, the mean.
  double central_abs_median_mm = NAN, central_abs_max_mm = NAN, central_mean_mm = NAN;
  double central_abs_max_percent = NAN;
};

struct RigPlan {
  double sigma_px = 0, length_mm = 0;
  int orientations = 0;
  std::string calibration_sigma;  // what the σ holds ("image noise only", "image noise and the rig calibration")
  bool central = false;
  double central_fit_range_mm = 0, central_fit_rms_px = NAN;  // the central calibration's own fit
  std::vector<std::string> central_models;
  std::vector<RigPlanRow> rows;
  std::vector<std::string> notes;
};

RigPlan PlanRig(const Rig& rig, const RigPlanOptions& options);

// The central rig PlanRig compares with: each camera's own lens model without refraction,
// calibrated with the rig (calib::CalibrateRig) on noise-free views of a chessboard (13 × 10,
// squares of fit_range_mm / 25) seen through `rig` at fit_range_mm ± 25 %. *fit_rms_px: that
// calibration's RMS. Throws InvalidInput when the calibration fails.
Rig CentralRig(const Rig& rig, double fit_range_mm, double* fit_rms_px = nullptr, int num_threads = 1);
// `rig`: one line naming the rig (its file, or DescribedRig's line).
nlohmann::ordered_json RigPlanToJson(const RigPlan& plan, const std::string& rig);

// A rig of the given cameras (each behind its port, or none), the second `baseline_mm` to the right
// of the first (rig frame x) and turned `convergence_deg` towards it about the vertical axis; more
// cameras go on along x at the same spacing, each turned as the second. No covariance. Throws
// InvalidInput for counts that differ, fewer than 2 cameras, a baseline ≤ 0 or a convergence outside
// [0°, 45°).
// Two of the housed camera `setup` (as `porthole plan` describes it) `baseline_mm` apart, the second
// turned `convergence_deg` towards the first: each lens an ideal Brown camera of the thin-lens
// principal distance at the focus for a subject `focus_wd_mm` from the port (planning::MakePlan at
// f_number), behind the port placed at that focus. Throws as MakePlan and DescribedRig; InvalidInput
// ("lens") for a fisheye lens (no ideal model of it here: calibrate the rig and plan from its file).
// *what: one line naming the rig.
Rig DescribedRig(const planning::Setup& setup, double baseline_mm, double convergence_deg, double focus_wd_mm,
                 double f_number, std::string* what = nullptr);

Rig DescribedRig(const std::vector<camera::Camera>& cameras, const std::vector<std::optional<ports::PortSystem>>& ports,
                 double baseline_mm, double convergence_deg);

}  // namespace porthole::measure
