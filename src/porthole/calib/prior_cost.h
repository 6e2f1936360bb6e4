// A Gaussian prior on one parameter block as a Ceres cost, whitened: r = A·x − b (A = W·E·S and
// b = W·μ for a prior N(μ, Σ = L·Lᵀ) on the scaled parameters x, W = L⁻¹). Shared by the
// refractive calibration (refractive.cc) and the rig (rig.cc).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <utility>

namespace porthole::calib {

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

}  // namespace porthole::calib
