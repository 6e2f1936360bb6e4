// Sphere fitting to scans of dome ports (paper Section 3, Table 3).
//
// Contract: points are a 3×N matrix in mm (any frame; results are in the same frame). The fit
// minimises geometric (orthogonal) distances r_i = |p_i − c| − R:
//  1. start: algebraic closed form (linear least squares on |p|² = 2c·p + (R² − |c|²)), or in
//     robust mode MSAC on minimal 4-point samples (fixed seed) plus an algebraic fit to the best
//     sample's inliers;
//  2. geometric least squares with Ceres (automatic differentiation), plain squared loss, or in
//     robust mode a Huber or Cauchy loss whose scale is the MSAC inlier threshold;
//  3. robust mode only: points with |r| ≤ threshold are the inliers, and (by default) a final
//     squared-loss refit on them removes the residual pull of the outliers.
// Statistics use the points that count (all, or the inliers): σ̂² = Σr²/(n − 4) and the covariance
// σ̂²(JᵀJ)⁻¹ of (cx, cy, cz, R) with J the Jacobian of the geometric residuals.
// Degenerate input (fewer than 4 points, all points equal, collinear or coplanar points) throws
// InvalidInput("points", ...). A fit that runs but does not determine a sphere (nearly planar
// data, no convergence) is returned with IsUsable() == false and a message saying why.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace porthole::fit {

struct Sphere {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 0;
};

enum class RobustLoss {
  kHuber,   // quadratic within the threshold, linear beyond: outliers keep a bounded pull
  kCauchy,  // log(1 + r²/s²): the pull of far outliers fades, better for gross outliers
};

struct SphereFitOptions {
  // Robust mode: MSAC start and a robust loss. Needed when the scan holds gross outliers (spray,
  // fixtures, the flange); costs ~10× the plain fit.
  bool robust = false;
  // Robust loss of the geometric refinement (robust mode only).
  RobustLoss loss = RobustLoss::kCauchy;
  // MSAC inlier threshold on |r| in mm; also the scale of the robust loss. 0.25 mm ≈ 5σ of the
  // paper's scanner noise (~0.05 mm): set it to 3–5× your scanner's σ.
  double inlier_threshold_mm = 0.25;
  // MSAC iteration cap; the adaptive stop (confidence below) usually ends far earlier.
  int max_ransac_iterations = 2000;
  // MSAC stops once an all-inlier sample has been drawn with this probability.
  double ransac_confidence = 0.9999;
  // Hypotheses are scored on a fixed random subset of this many points (all if fewer): scoring
  // cost stops growing with the scan size while the ranking is unchanged.
  int ransac_score_points = 4000;
  // Seed of the MSAC sampler (std::mt19937_64): the same input gives the same fit.
  uint64_t seed = 12345;
  // Robust mode: refit the inliers with the squared loss, so Huber/Cauchy's leftover outlier pull
  // does not bias the result and the statistics are those of an ordinary least-squares fit.
  bool refit_inliers = true;
  // Ceres iteration cap; from the closed-form start a few Gauss–Newton steps suffice.
  int max_solver_iterations = 100;
  // Threads for the Ceres residual evaluation (the machine is shared: default 1).
  int num_threads = 1;
};

struct SphereFitSummary {
  Sphere sphere;
  Eigen::Vector3d sigma_center_mm = Eigen::Vector3d::Constant(NAN);  // 1σ per axis
  double sigma_radius_mm = NAN;                                      // 1σ
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Constant(NAN);       // of (cx, cy, cz, R), mm²
  double sigma0_mm = NAN;  // residual standard deviation √(Σr²/(n − 4)) over the inliers
  double rms_mm = NAN;     // residual RMS over the inliers
  double max_abs_residual_mm = NAN;  // largest |r| over the inliers
  int64_t n_points = 0;              // points given
  int64_t n_inliers = 0;             // points that count (all, unless robust)
  int ransac_iterations = 0;         // MSAC hypotheses drawn (robust mode)
  int solver_iterations = 0;         // Ceres iterations, summed over the solves
  bool converged = false;            // Ceres reported convergence
  std::string message;               // why the fit is not usable, or "ok"
  Eigen::VectorXd residuals_mm;      // signed r_i = |p_i − c| − R for every point (N)
  std::vector<bool> is_inlier;       // N flags (all true unless robust)

  // Converged, finite, enough inliers (≥ 5, so σ̂ is defined) and a determined sphere.
  bool IsUsable() const;
  // One line: centre, radius, σ, RMS, inliers, status.
  std::string BriefReport() const;
};

// Algebraic closed form: linear least squares on the centred, scaled points. Throws on degenerate
// input like FitSphere. Biased on partial caps with noise; use it as a start.
Sphere FitSphereAlgebraic(const Eigen::Matrix3Xd& points_mm);

// Sphere through 4 points; false when they are (nearly) coplanar.
bool SphereFrom4Points(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d, Sphere* sphere);

// The full fit described at the top of this file.
SphereFitSummary FitSphere(const Eigen::Matrix3Xd& points_mm, const SphereFitOptions& options = {});

// Throws InvalidInput("points", ...) unless the points can determine a sphere: at least 4 finite
// points, not all equal, not collinear, not coplanar (relative tolerance 1e-9 of the spread).
void CheckSpherePoints(const Eigen::Matrix3Xd& points_mm);

}  // namespace porthole::fit
