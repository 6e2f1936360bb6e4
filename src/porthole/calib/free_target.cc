// FreeTarget (free_target.h): the datum and the control priors of a free target behind a port or in a rig.
#include "porthole/calib/free_target.h"

#include <cmath>

#include "porthole/calib/prior_cost.h"

namespace porthole::calib {

FreeTarget FreeTargetOf(const CalibrationResult& central, const std::set<int>& observed, const TargetSpec& target,
                        std::vector<Eigen::Vector3d>* points) {
  FreeTarget t;
  t.datum = central.datum;
  t.adjusted = observed;
  const CalibrationResult::Datum& d = t.datum;
  if (d.control.empty()) {  // the minimal datum: a and b whole, one coordinate of c
    t.adjusted.erase(d.a);
    t.adjusted.erase(d.b);
    t.held[d.c] = {d.axis};
    t.n_unknowns = 3 * static_cast<int>(observed.size()) - 7;
    return t;
  }
  const std::map<int, Eigen::Vector3d> sigmas = FieldControl(target);
  const std::vector<Eigen::Vector3d> given = TargetPoints(target);
  t.n_unknowns = 3 * static_cast<int>(observed.size());
  for (int id : d.control) {
    const Eigen::Vector3d& sigma = sigmas.at(id);
    std::vector<int> held;
    for (int k = 0; k < 3; ++k) {
      if (sigma(k) > 0) {
        ++t.n_prior;
      } else {
        held.push_back(k);
      }
    }
    if (observed.count(id)) t.n_unknowns -= static_cast<int>(held.size());
    if (held.size() == 3) {
      t.adjusted.erase(id);
      (*points)[id] = given[id];
    } else {
      if (!held.empty()) t.held[id] = held;
      t.control[id] = {given[id], sigma};
    }
  }
  return t;
}

void FreeTarget::AddTo(Bundle* bundle, std::vector<Eigen::Vector3d>* points) const {
  for (const auto& [id, coords] : held) bundle->HoldPoint((*points)[id].data(), coords);
  for (const auto& [id, given_sigma] : control) {
    if (!bundle->HasBlock((*points)[id].data())) continue;
    bundle->AddCost(new ControlPrior(given_sigma.first, given_sigma.second, 1.0), {(*points)[id].data()});
  }
}

double FreeTarget::ControlSumSquares(const std::vector<Eigen::Vector3d>& points) const {
  double ss = 0;
  for (const auto& [id, given_sigma] : control) {
    const auto& [given, sigma] = given_sigma;
    for (int k = 0; k < 3; ++k) {
      if (sigma(k) > 0) ss += std::pow((points[id](k) - given(k)) / sigma(k), 2);
    }
  }
  return ss;
}

std::vector<Eigen::Vector3d> FreeTarget::Sigma(const std::vector<Eigen::Vector3d>& variance, double s0_squared,
                                               std::size_t n_points) const {
  std::vector<Eigen::Vector3d> sigma(n_points, Eigen::Vector3d::Constant(NAN));
  for (std::size_t id = 0; id < variance.size() && id < n_points; ++id) {
    if (variance[id].allFinite()) sigma[id] = (s0_squared * variance[id]).cwiseSqrt();
  }
  // The datum's points held whole: σ 0.
  for (int id : {datum.a, datum.b}) {
    if (id >= 0) sigma[id].setZero();
  }
  for (int id : datum.control) {
    if (!Adjusted(id)) sigma[id].setZero();
  }
  for (const auto& [id, coords] : held) {
    if (!sigma[id].allFinite()) sigma[id].setZero();
  }
  return sigma;
}

void AddPointCovariancePairs(const FreeTarget& t, ceres::Problem& problem, std::vector<Eigen::Vector3d>* points,
                             std::vector<std::pair<const double*, const double*>>* pairs) {
  for (int id : t.adjusted) {
    const double* p = (*points)[id].data();
    if (problem.HasParameterBlock(p)) pairs->push_back({p, p});
  }
}

bool PointVariances(const FreeTarget& t, ceres::Problem& problem, const ceres::Covariance& covariance,
                    std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* variance) {
  variance->assign(points->size(), Eigen::Vector3d::Constant(NAN));
  for (int id : t.adjusted) {
    const double* p = (*points)[id].data();
    if (!problem.HasParameterBlock(p)) continue;
    Eigen::Matrix3d c;  // ambient: a held coordinate has variance 0
    if (!covariance.GetCovarianceBlock(p, p, c.data())) return false;
    (*variance)[id] = c.diagonal();
  }
  return true;
}

}  // namespace porthole::calib
