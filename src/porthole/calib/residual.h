// The residuals of the calibration adjustment (calibrate.cc), in the two forms of the one camera
// model of camera/brown.h, with analytic Jacobians, and the automatic-differentiation reference
// they are tested against (residual_test.cc).
//
// Contract:
//  - Unknowns: the camera as SCALED parameters, camera[i] = scale[i]·scaled[i] (BrownIndex order;
//    the scales make every column of the Jacobian comparable, see ParameterScales in
//    calibrate.cc), the cam_from_target rotation as an angle-axis vector (rad), the translation
//    (mm), and the target point (mm, target frame): point_in_cam = R(ω)·X + t (camera frame of
//    docs/conventions.md: X right, Y down, Z forward).
//  - Form::kProject, the image residual: (projected − observed measured point)/pitch, in px. The
//    projection inverts the correction polynomial (camera::Project, Newton); the statistics and
//    the RMS are defined on this residual, as OpenCV's and mrcal's are.
//  - Form::kCorrect, the photogrammetric collinearity form (Fraser 1997): corrected observation −
//    collinearity, (x̄ + Δx(x̄) − c·X/Z, ȳ + Δy(x̄) + c·Y/Z)/pitch with x̄ = x_obs − x0 (px, y up).
//    No inversion. Near the optimum r_correct ≈ −A·r_project with A = I + ∂Δ/∂x̄, so the two
//    minima differ at the order of |∂Δ/∂x̄| (docs/calibration.md gives the measured difference).
//  - Jacobians (analytic): with u = c·(X/Z, −Y/Z) the ideal point relative to the principal point
//    and x̄_m the projected measured point relative to it (x̄_m + Δ(x̄_m) = u):
//      kProject: ∂x_m/∂(x0, y0) = I, ∂x_m/∂q = A(x̄_m)⁻¹·(∂u/∂q − ∂Δ/∂q) for every other unknown q;
//      kCorrect: ∂r/∂(x0, y0) = −A(x̄_obs), ∂r/∂q = ∂Δ/∂q − ∂u/∂q.
//    The rotation derivative is ∂(R(ω)X)/∂ω = −R·[X]×·J_r(ω) with J_r the right Jacobian of SO(3)
//    (Solà, Deray & Atchuthan 2018, "A micro Lie theory for state estimation in robotics").
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cmath>

#include "porthole/camera/brown.h"

namespace porthole::calib {

enum class Form { kCorrect, kProject };

using CameraScales = std::array<double, camera::kBrownNumParams>;
using RowJacobianCamera = Eigen::Matrix<double, 2, camera::kBrownNumParams, Eigen::RowMajor>;
using RowJacobian3 = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;

// ∂(R(ω)·X)/∂ω for the angle-axis ω (rad), X in mm; the small-angle series below 1e-4 rad.
inline Eigen::Matrix3d RotatedPointJacobian(const double* omega, const Eigen::Matrix3d& r,
                                            const Eigen::Vector3d& x) {
  const Eigen::Vector3d w(omega[0], omega[1], omega[2]);
  const double t2 = w.squaredNorm();
  double a, b;  // (1 − cos θ)/θ², (θ − sin θ)/θ³
  if (t2 < 1e-8) {
    a = 0.5 - t2 / 24.0;
    b = 1.0 / 6.0 - t2 / 120.0;
  } else {
    const double t = std::sqrt(t2);
    a = (1.0 - std::cos(t)) / t2;
    b = (t - std::sin(t)) / (t2 * t);
  }
  Eigen::Matrix3d wx, px;
  wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  px << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
  const Eigen::Matrix3d jr = Eigen::Matrix3d::Identity() - a * wx + b * wx * wx;
  return -r * px * jr;
}

// The residual of one observation (x_mm, y_mm: measured image point, y up) and, for each non-null
// pointer, its analytic Jacobian (row-major 2×n, per unit of the SCALED camera parameters, of ω,
// t and X). Returns false where the residual is undefined (point behind the camera, or the
// projection leaves the domain of the correction polynomial).
template <Form kForm>
bool EvaluateResidual(const double* scaled, const CameraScales& scale, const double* rotation,
                      const double* translation, const double* point, double x_mm, double y_mm,
                      double pitch_mm, double* residual, RowJacobianCamera* j_camera,
                      RowJacobian3* j_rotation, RowJacobian3* j_translation, RowJacobian3* j_point) {
  using camera::kBrownC;
  using camera::kBrownK1;
  using camera::kBrownNumAdditional;
  using camera::kBrownNumParams;
  using camera::kBrownX0;
  using camera::kBrownY0;
  double cam[kBrownNumParams];
  for (int i = 0; i < kBrownNumParams; ++i) cam[i] = scaled[i] * scale[i];
  Eigen::Matrix3d r;
  ceres::AngleAxisToRotationMatrix(rotation, r.data());  // column-major, as Eigen
  const Eigen::Vector3d x(point[0], point[1], point[2]);
  const Eigen::Vector3d p = r * x + Eigen::Vector3d(translation[0], translation[1], translation[2]);
  if (!(p.z() > 0)) return false;
  const double c = cam[kBrownC];
  const Eigen::Vector2d n(p.x() / p.z(), -p.y() / p.z());  // u / c
  Eigen::Vector2d at;  // the measured point where Δ and its derivatives are evaluated
  if constexpr (kForm == Form::kProject) {
    const auto xm = camera::Distort<double>(cam, cam[kBrownX0] + c * n.x(),
                                            cam[kBrownY0] + c * n.y());
    if (!xm) return false;
    at = *xm;
    residual[0] = (at.x() - x_mm) / pitch_mm;
    residual[1] = (at.y() - y_mm) / pitch_mm;
  } else {
    at = Eigen::Vector2d(x_mm, y_mm);
    const camera::Vec2<double> d = camera::Correction<double>(cam, x_mm, y_mm);
    residual[0] = (x_mm - cam[kBrownX0] + d.x() - c * n.x()) / pitch_mm;
    residual[1] = (y_mm - cam[kBrownY0] + d.y() - c * n.y()) / pitch_mm;
  }
  if (j_camera == nullptr && j_rotation == nullptr && j_translation == nullptr &&
      j_point == nullptr) {
    return true;
  }
  Eigen::Matrix2d a = camera::CorrectionPointJacobian<double>(cam, at.x(), at.y());
  a.diagonal().array() += 1.0;
  // g·(∂u/∂q − ∂Δ/∂q) is the residual's derivative for every q but x0, y0 (see the contract).
  Eigen::Matrix2d g;
  if constexpr (kForm == Form::kProject) {
    const double det = a.determinant();
    if (!(det > 0)) return false;
    g = a.inverse() / pitch_mm;
  } else {
    g = -Eigen::Matrix2d::Identity() / pitch_mm;
  }
  if (j_camera != nullptr) {
    const auto basis = camera::CorrectionParamJacobian<double>(cam, at.x(), at.y());
    RowJacobianCamera& j = *j_camera;
    j.col(kBrownC) = g * n;
    if constexpr (kForm == Form::kProject) {
      j.col(kBrownX0) = Eigen::Vector2d(1, 0) / pitch_mm;
      j.col(kBrownY0) = Eigen::Vector2d(0, 1) / pitch_mm;
    } else {
      j.col(kBrownX0) = -a.col(0) / pitch_mm;
      j.col(kBrownY0) = -a.col(1) / pitch_mm;
    }
    j.template rightCols<kBrownNumAdditional>() = -g * basis;
    for (int i = 0; i < kBrownNumParams; ++i) j.col(i) *= scale[i];
  }
  // ∂u/∂p for the camera-frame point p, then through g.
  Eigen::Matrix<double, 2, 3> du;
  du << c / p.z(), 0, -c * p.x() / (p.z() * p.z()),  //
      0, -c / p.z(), c * p.y() / (p.z() * p.z());
  const Eigen::Matrix<double, 2, 3> gp = g * du;
  if (j_translation != nullptr) *j_translation = gp;
  if (j_rotation != nullptr) *j_rotation = gp * RotatedPointJacobian(rotation, r, x);
  if (j_point != nullptr) *j_point = gp * r;
  return true;
}

// The same residual by automatic differentiation of camera/brown.h (Jets through Project or
// Undistort): the reference the analytic Jacobians are tested against. Blocks: scaled camera [10],
// rotation [3], translation [3], point [3].
template <Form kForm>
struct AutoDiffResidual {
  double x_mm, y_mm, pitch_mm;
  CameraScales scale;

  template <typename T>
  bool operator()(const T* scaled, const T* rotation, const T* translation, const T* point,
                  T* r) const {
    T cam[camera::kBrownNumParams];
    for (int i = 0; i < camera::kBrownNumParams; ++i) cam[i] = scaled[i] * T(scale[i]);
    if constexpr (kForm == Form::kProject) {
      return camera::BrownBundleResidual(x_mm, y_mm, pitch_mm)(cam, rotation, translation, point,
                                                               r);
    } else {
      T p[3];
      ceres::AngleAxisRotatePoint(rotation, point, p);
      for (int k = 0; k < 3; ++k) p[k] += translation[k];
      if (!(camera::ScalarValue(p[2]) > 0)) return false;
      const camera::Vec2<T> u = camera::Undistort<T>(cam, T(x_mm), T(y_mm));
      r[0] = (u(0) - cam[camera::kBrownX0] - cam[camera::kBrownC] * p[0] / p[2]) / T(pitch_mm);
      r[1] = (u(1) - cam[camera::kBrownY0] + cam[camera::kBrownC] * p[1] / p[2]) / T(pitch_mm);
      return true;
    }
  }
};

// Ceres cost with the analytic Jacobian. kPointFree: blocks camera [10], rotation [3],
// translation [3], point [3]; otherwise the point is a constant and the last block is absent.
template <Form kForm, bool kPointFree>
class AnalyticResidual final : public ceres::CostFunction {
 public:
  AnalyticResidual(double x_mm, double y_mm, double pitch_mm, const CameraScales& scale,
                   const Eigen::Vector3d& point)
      : x_mm_(x_mm), y_mm_(y_mm), pitch_mm_(pitch_mm), scale_(scale), point_(point) {
    set_num_residuals(2);
    auto* sizes = mutable_parameter_block_sizes();
    *sizes = {camera::kBrownNumParams, 3, 3};
    if (kPointFree) sizes->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* point = kPointFree ? parameters[3] : point_.data();
    if (jacobians == nullptr) {
      return EvaluateResidual<kForm>(parameters[0], scale_, parameters[1], parameters[2], point,
                                     x_mm_, y_mm_, pitch_mm_, residuals, nullptr, nullptr, nullptr,
                                     nullptr);
    }
    RowJacobianCamera jc;
    RowJacobian3 jr, jt, jp;
    const bool want_point = kPointFree && jacobians[3] != nullptr;
    if (!EvaluateResidual<kForm>(parameters[0], scale_, parameters[1], parameters[2], point, x_mm_,
                                 y_mm_, pitch_mm_, residuals, &jc, &jr, &jt,
                                 want_point ? &jp : nullptr)) {
      return false;
    }
    if (jacobians[0] != nullptr) Eigen::Map<RowJacobianCamera>{jacobians[0]} = jc;
    if (jacobians[1] != nullptr) Eigen::Map<RowJacobian3>{jacobians[1]} = jr;
    if (jacobians[2] != nullptr) Eigen::Map<RowJacobian3>{jacobians[2]} = jt;
    if (want_point) Eigen::Map<RowJacobian3>{jacobians[3]} = jp;
    return true;
  }

 private:
  double x_mm_, y_mm_, pitch_mm_;
  CameraScales scale_;
  Eigen::Vector3d point_;
};

}  // namespace porthole::calib
