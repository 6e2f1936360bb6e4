// Priors as Ceres costs. A Gaussian prior on one parameter block, whitened: r = A·x − b (A = W·E·S and
// b = W·μ for a prior N(μ, Σ = L·Lᵀ) on the scaled parameters x, W = L⁻¹); a control point's.
// Shared by the central calibration (calibrate.cc: control points), the refractive one
// (refractive.cc) and the rig (rig.cc).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/core/error.h"

namespace porthole::calib {

// A calibration's parameters `idx` (model order) as a Gaussian prior N(μ, Σ), whitened: μ and
// W = L⁻¹ with Σ = L·Lᵀ (the record's covariance over idx). Throws InvalidInput(field, `who` +
// …) when Σ is not positive definite. Shared by the lens priors of refractive.cc and rig.cc and
// the housed prior (housed_prior.h).
struct WhitenedPrior {
  Eigen::VectorXd mean;
  Eigen::MatrixXd whiten;
};
inline WhitenedPrior WhitenedPriorOf(const CalibrationRecord& rec, const std::vector<int>& idx,
                                     const std::string& field, const std::string& who = "") {
  const int m = static_cast<int>(idx.size());
  WhitenedPrior p;
  p.mean.resize(m);
  Eigen::MatrixXd cov(m, m);
  for (int a = 0; a < m; ++a) {
    p.mean(a) = rec.camera.params[idx[a]];
    for (int b = 0; b < m; ++b) cov(a, b) = rec.covariance(idx[a], idx[b]);
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  if (llt.info() != Eigen::Success) throw InvalidInput(field, who + "its covariance is not positive definite");
  p.whiten = llt.matrixL().solve(Eigen::MatrixXd::Identity(m, m));
  return p;
}

class LinearPriorCost final : public ceres::CostFunction {
 public:
  LinearPriorCost(Eigen::MatrixXd a, Eigen::VectorXd b) : a_(std::move(a)), b_(std::move(b)) {
    set_num_residuals(static_cast<int>(a_.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(a_.cols()));
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> x(params[0], a_.cols());
    Eigen::Map<Eigen::VectorXd>(residuals, a_.rows()) = a_ * x - b_;
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[0], a_.rows(),
                                                                                         a_.cols()) = a_;
    }
    return true;
  }

 private:
  Eigen::MatrixXd a_;
  Eigen::VectorXd b_;
};

// A control point's prior (CalibrationOptions::datum kControl): (p − given) / σ · weight per
// coordinate of σ > 0 (0 for the others, which are held). The central calibration weighs it with
// σ0 (px): the prior as an image observation of that σ; the refractive one with 1, its image
// residuals weighted by 1/σ0 instead.
class ControlPrior final : public ceres::SizedCostFunction<3, 3> {
 public:
  ControlPrior(const Eigen::Vector3d& given_mm, const Eigen::Vector3d& sigma_mm, double weight)
      : given_(given_mm), sigma_(sigma_mm), weight_(weight) {}
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    for (int k = 0; k < 3; ++k) {
      const double w = sigma_(k) > 0 ? weight_ / sigma_(k) : 0.0;
      r[k] = w * (p[0][k] - given_(k));
      if (jac != nullptr && jac[0] != nullptr) {
        for (int m = 0; m < 3; ++m) jac[0][3 * k + m] = m == k ? w : 0.0;
      }
    }
    return true;
  }

 private:
  Eigen::Vector3d given_, sigma_;
  double weight_;
};

}  // namespace porthole::calib
