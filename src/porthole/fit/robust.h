// Internal helpers shared by the fits: robust residual transform and Ceres defaults.
#pragma once

#include <ceres/ceres.h>

#include <cmath>

#include "porthole/fit/sphere_fit.h"

namespace porthole::fit::internal {

// Maps a residual r to r̃ = sign(r)·b·√ρ(r²/b²) so that Σ r̃² = Σ b²ρ(r_i²/b²): the objective of
// ceres::HuberLoss(b) / ceres::CauchyLoss(b) on one-point residual blocks, evaluated inside a
// chunked cost function (a Ceres loss acts on the squared norm of a whole block, not per entry).
// Huber: ρ(s) = s (s ≤ 1), 2√s − 1 (s > 1). Cauchy: ρ(s) = log(1 + s). Gauss–Newton on r̃ has the
// same stationary points as the robust objective.
template <typename T>
T RobustResidual(const T& r, RobustLoss loss, double b) {
  using std::abs;
  using std::log;
  using std::sqrt;
  const T ar = abs(r);
  if (loss == RobustLoss::kHuber) {
    if (ar <= T(b)) return r;
    const T rt = sqrt(T(2.0 * b) * ar - T(b * b));
    return r < T(0) ? -rt : rt;
  }
  if (ar < T(1e-6 * b)) return r;  // ρ(s) = s + O(s²); avoids √ at 0 in the derivative
  const T rt = T(b) * sqrt(log(T(1) + r * r / T(b * b)));
  return r < T(0) ? -rt : rt;
}

// Σ (p − mean)(p − mean)ᵀ over the columns of p (3×N), in one pass without temporaries.
inline Eigen::Matrix3d Scatter(const Eigen::Matrix3Xd& p, const Eigen::Vector3d& mean) {
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double x = p(0, i) - mean.x(), y = p(1, i) - mean.y(), z = p(2, i) - mean.z();
    xx += x * x;
    xy += x * y;
    xz += x * z;
    yy += y * y;
    yz += y * z;
    zz += z * z;
  }
  Eigen::Matrix3d s;
  s << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  return s;
}

// Solver settings shared by the geometric fits: dense normal equations (few parameters, many
// residuals), tight tolerances (the start is already close; we want the last micrometre).
inline ceres::Solver::Options GeometricSolverOptions(int max_iterations, int num_threads) {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  o.max_num_iterations = max_iterations;
  o.function_tolerance = 1e-14;
  o.gradient_tolerance = 1e-14;
  o.parameter_tolerance = 1e-12;
  o.num_threads = num_threads;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  return o;
}

}  // namespace porthole::fit::internal
