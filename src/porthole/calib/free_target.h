// A free target in an adjustment on Bundle (bundle.h) that starts from a central calibration's
// (issue 26): the refractive calibration and the rig adjust the target's points with everything
// else, the datum the one the central calibration of the start chose (CalibrationResult::datum):
// the minimal 7 coordinates held at their values, or the field's control points — coordinates of
// σ 0 held, the others a prior of their σ (ControlPrior, weight 1: the images are weighted by
// 1/σ0 as with the adjustment's other priors).
#pragma once

#include <Eigen/Core>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "porthole/calib/bundle.h"
#include "porthole/calib/calibrate.h"
#include "porthole/calib/target.h"

namespace porthole::calib {

struct FreeTarget {
  CalibrationResult::Datum datum;
  std::set<int> adjusted;                  // the points that are blocks (observed, not held whole)
  std::map<int, std::vector<int>> held;    // id → coordinates held of an adjusted point
  std::map<int, std::pair<Eigen::Vector3d, Eigen::Vector3d>> control;  // id → (given, σ) priors, mm
  int n_unknowns = 0;  // 3 per observed point, less the held coordinates
  int n_prior = 0;     // control coordinates with a σ > 0 (one observation each)

  // Whether point `id` is a block of the adjustment.
  bool Adjusted(int id) const { return adjusted.count(id) > 0; }
  // Holds the datum and adds the control priors to `bundle` (`points`: the adjusted points, by id).
  void AddTo(Bundle* bundle, std::vector<Eigen::Vector3d>* points) const;
  // Σ of the control priors' squared residuals at `points`.
  double ControlSumSquares(const std::vector<Eigen::Vector3d>& points) const;
  // Each point's σ (mm) from the diagonal of its covariance block (`variance`, σ0²-free, NaN where
  // not adjusted) times s0²: held coordinates and points 0, points not observed NaN.
  std::vector<Eigen::Vector3d> Sigma(const std::vector<Eigen::Vector3d>& variance, double s0_squared,
                                     std::size_t n_points) const;
};

// The free target of an adjustment of the points `observed`, with the datum of `central` (a central
// calibration with target_free) and the field's control σ (FieldControl). Sets the held control
// points of *points to their given values.
FreeTarget FreeTargetOf(const CalibrationResult& central, const std::set<int>& observed, const TargetSpec& target,
                        std::vector<Eigen::Vector3d>* points);

// The diagonal of each adjusted point's covariance block (σ0²-free, ambient: a held coordinate 0)
// from a computed ceres::Covariance; NaN for points not adjusted: AddPointCovariancePairs before
// ceres::Covariance::Compute, PointVariances after.
void AddPointCovariancePairs(const FreeTarget& t, ceres::Problem& problem, std::vector<Eigen::Vector3d>* points,
                             std::vector<std::pair<const double*, const double*>>* pairs);
bool PointVariances(const FreeTarget& t, ceres::Problem& problem, const ceres::Covariance& covariance,
                    std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* variance);

}  // namespace porthole::calib
