// Plane and 3D circle fits to photogrammetric targets (camera and housing flanges, paper Sec. 3).
//
// Contract: points 3×N in mm; results in the same frame. Plane: total least squares (the normal is
// the eigenvector of the scatter matrix with the smallest eigenvalue), plane {x : n·x = d}, signed
// residual r = n·p − d. Circle: that plane, then a 2D circle in it (algebraic start, then geometric
// least squares with Ceres on the in-plane radial residual r = |q − c| − R).
// σ̂² = Σr²/(n − k) with k = 3 parameters for both fits; statistics need n > k (otherwise they are
// NaN and IsUsable() is false: an exact fit has no redundancy). Degenerate input (too few points,
// all equal, collinear) throws InvalidInput("points", ...).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

namespace porthole::fit {

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit
  double offset_mm = 0;                               // n·x = offset for points x on the plane
};

struct PlaneFitOptions {
  // Orientation of the normal: when non-zero, the normal is flipped to have n·hint > 0; when zero,
  // its largest-magnitude component is made positive (a deterministic choice).
  Eigen::Vector3d normal_hint = Eigen::Vector3d::Zero();
};

struct PlaneFitSummary {
  Plane plane;
  Eigen::Vector3d centroid_mm = Eigen::Vector3d::Zero();               // lies on the plane
  Eigen::Matrix3d normal_covariance = Eigen::Matrix3d::Constant(NAN);  // of the unit normal
  Eigen::Vector3d sigma_normal = Eigen::Vector3d::Constant(NAN);       // √diag, dimensionless
  double sigma_tilt_rad = NAN;   // 1σ of the normal's direction (√trace of its covariance)
  double sigma_offset_mm = NAN;  // 1σ of offset_mm
  double sigma0_mm = NAN;        // √(Σr²/(n − 3))
  double rms_mm = NAN;
  double max_abs_residual_mm = NAN;
  int64_t n_points = 0;
  Eigen::VectorXd residuals_mm;  // signed n·p_i − d (N)

  bool IsUsable() const;  // finite plane and n > 3
  std::string BriefReport() const;
};

PlaneFitSummary FitPlane(const Eigen::Matrix3Xd& points_mm, const PlaneFitOptions& options = {});

struct Circle3d {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit normal of the circle's plane
  double radius_mm = 0;
};

struct CircleFitOptions {
  Eigen::Vector3d normal_hint = Eigen::Vector3d::Zero();  // as PlaneFitOptions::normal_hint
  int max_solver_iterations = 100;  // Ceres cap; from the algebraic start a few steps suffice
};

struct CircleFitSummary {
  Circle3d circle;
  PlaneFitSummary plane;  // the plane fit the circle lies in
  Eigen::Matrix3d center_covariance = Eigen::Matrix3d::Constant(NAN);  // mm², in the input frame
  Eigen::Vector3d sigma_center_mm = Eigen::Vector3d::Constant(NAN);
  double sigma_radius_mm = NAN;
  double sigma_normal_rad = NAN;     // = plane.sigma_tilt_rad
  double sigma0_mm = NAN;            // in-plane radial: √(Σr²/(n − 3))
  double rms_mm = NAN;               // in-plane radial residual RMS
  double max_abs_residual_mm = NAN;  // in-plane radial
  int64_t n_points = 0;
  bool converged = false;
  std::string message;           // "ok" or why not usable
  Eigen::VectorXd residuals_mm;  // in-plane radial residual per point (N)

  bool IsUsable() const;
  std::string BriefReport() const;
};

CircleFitSummary FitCircle3d(const Eigen::Matrix3Xd& points_mm,
                             const CircleFitOptions& options = {});

}  // namespace porthole::fit
