// The Brown–Conrady camera model of docs/conventions.md ("The camera model"), written once as
// templates over the scalar type T so that doubles and ceres::Jet run through the same code.
//
// Frames, units and signs (see docs/camera-model.md):
//  - Image millimetres: origin at the sensor centre, x right, y UP (photogrammetric).
//  - Camera frame `cam`: origin at the perspective centre, X right, Y DOWN, Z forward (mm).
//  - Δ is a CORRECTION added to a measured (distorted) image point: with x̄ = x − x0, ȳ = y − y0,
//        x̄ + Δx(x̄, ȳ) = c·X/Z,    ȳ + Δy(x̄, ȳ) = −c·Y/Z.
//    A barrel lens therefore has K1 > 0.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/jet.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>

#include "porthole/camera/scalar.h"
#include "porthole/core/error.h"

namespace porthole::camera {

template <typename T>
using Vec2 = Eigen::Matrix<T, 2, 1>;
template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// The fixed parameter ordering used by every optimiser (a `const T* params` array of
// kBrownNumParams values is always in this order).
enum BrownIndex : int {
  kBrownC = 0,  // principal distance c, mm (> 0)
  kBrownX0,     // principal point x0, image mm (x right)
  kBrownY0,     // principal point y0, image mm (y up)
  kBrownK1,     // radial, mm^-2
  kBrownK2,     // radial, mm^-4
  kBrownK3,     // radial, mm^-6
  kBrownP1,     // decentring, mm^-1
  kBrownP2,     // decentring, mm^-1
  kBrownB1,     // affinity, dimensionless
  kBrownB2,     // shear, dimensionless
  kBrownNumParams
};

// Name, file/JSON key (the key carries the unit, as docs/conventions.md asks) and unit of each
// parameter, indexed by BrownIndex. The one list of names and units; everything else refers to it.
// (The same record describes the parameters of every model of camera/models.h.)
struct ParamInfo {
  std::string_view name;
  std::string_view json_key;
  std::string_view unit;
};
using BrownParamInfo = ParamInfo;
inline constexpr std::array<BrownParamInfo, kBrownNumParams> kBrownParamInfo = {{
    {"c", "c_mm", "mm"},
    {"x0", "x0_mm", "mm"},
    {"y0", "y0_mm", "mm"},
    {"K1", "K1", "mm^-2"},
    {"K2", "K2", "mm^-4"},
    {"K3", "K3", "mm^-6"},
    {"P1", "P1", "mm^-1"},
    {"P2", "P2", "mm^-1"},
    {"B1", "B1", "1"},
    {"B2", "B2", "1"},
}};

// Brown–Conrady parameters in the units of kBrownParamInfo.
struct BrownParams {
  double c_mm = 0, x0_mm = 0, y0_mm = 0;
  double K1 = 0, K2 = 0, K3 = 0;
  double P1 = 0, P2 = 0;
  double B1 = 0, B2 = 0;

  // The parameters as an array in BrownIndex order, converted to scalar type T.
  template <typename T = double>
  std::array<T, kBrownNumParams> ToArray() const {
    return {T(c_mm), T(x0_mm), T(y0_mm), T(K1), T(K2), T(K3), T(P1), T(P2), T(B1), T(B2)};
  }
  static BrownParams FromArray(const double* p) {
    return {p[kBrownC],  p[kBrownX0], p[kBrownY0], p[kBrownK1], p[kBrownK2],
            p[kBrownK3], p[kBrownP1], p[kBrownP2], p[kBrownB1], p[kBrownB2]};
  }
};

// Throws InvalidInput (field = the JSON key) unless every parameter is finite and c > 0.
inline void ValidateBrownParams(const BrownParams& p) {
  const auto a = p.ToArray();
  for (int i = 0; i < kBrownNumParams; ++i) {
    RequireFinite(std::string(kBrownParamInfo[i].json_key), a[i]);
  }
  RequirePositive(std::string(kBrownParamInfo[kBrownC].json_key), p.c_mm);
}


namespace detail {

// Δ at centred coordinates (xb, yb) = (x − x0, y − y0), and, if jac != nullptr, its Jacobian
// ∂(Δx, Δy)/∂(x̄, ȳ). Units: mm in, mm out.
template <typename T>
Vec2<T> CentredCorrection(const T* p, const T& xb, const T& yb, Eigen::Matrix<T, 2, 2>* jac) {
  const T& K1 = p[kBrownK1];
  const T& K2 = p[kBrownK2];
  const T& K3 = p[kBrownK3];
  const T& P1 = p[kBrownP1];
  const T& P2 = p[kBrownP2];
  const T& B1 = p[kBrownB1];
  const T& B2 = p[kBrownB2];
  const T r2 = xb * xb + yb * yb;
  const T radial = r2 * (K1 + r2 * (K2 + r2 * K3));  // K1 r² + K2 r⁴ + K3 r⁶
  const T xy = xb * yb;
  Vec2<T> d;
  d(0) = xb * radial + P1 * (r2 + T(2) * xb * xb) + T(2) * P2 * xy + B1 * xb + B2 * yb;
  d(1) = yb * radial + P2 * (r2 + T(2) * yb * yb) + T(2) * P1 * xy;
  if (jac != nullptr) {
    const T dradial_dr2 = K1 + r2 * (T(2) * K2 + T(3) * K3 * r2);
    const T cross = T(2) * xy * dradial_dr2 + T(2) * P1 * yb + T(2) * P2 * xb;
    (*jac)(0, 0) = radial + T(2) * xb * xb * dradial_dr2 + T(6) * P1 * xb + T(2) * P2 * yb + B1;
    (*jac)(0, 1) = cross + B2;
    (*jac)(1, 0) = cross;
    (*jac)(1, 1) = radial + T(2) * yb * yb * dradial_dr2 + T(6) * P2 * yb + T(2) * P1 * xb;
  }
  return d;
}

// One Newton step for x̄ + Δ(x̄) = target (centred mm). Updates (xb, yb); returns the step taken
// and sets *det to det(I + ∂Δ/∂x̄) at the start point.
template <typename T>
Vec2<T> NewtonStep(const T* p, const Vec2<T>& target, Vec2<T>* xb, T* det) {
  Eigen::Matrix<T, 2, 2> jac;
  const Vec2<T> d = CentredCorrection(p, (*xb)(0), (*xb)(1), &jac);
  const Vec2<T> f = *xb + d - target;
  jac(0, 0) += T(1);
  jac(1, 1) += T(1);
  *det = jac(0, 0) * jac(1, 1) - jac(0, 1) * jac(1, 0);
  Vec2<T> step;
  step(0) = (jac(1, 1) * f(0) - jac(0, 1) * f(1)) / *det;
  step(1) = (jac(0, 0) * f(1) - jac(1, 0) * f(0)) / *det;
  *xb -= step;
  return step;
}

inline constexpr int kMaxNewtonIterations = 50;
inline constexpr double kNewtonToleranceMm = 1e-12;

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Array form: params points at kBrownNumParams values in BrownIndex order.

// Δ = (Δx, Δy) in mm for a MEASURED (distorted) image point (x, y) in image mm (y up).
template <typename T>
Vec2<T> Correction(const T* params, const T& x, const T& y) {
  return detail::CentredCorrection<T>(params, x - params[kBrownX0], y - params[kBrownY0], nullptr);
}

// Measured image point → ideal image point, both in image mm with the sensor-centre origin:
// (x + Δx, y + Δy). The ideal point relative to the principal point is (c·X/Z, −c·Y/Z).
template <typename T>
Vec2<T> Undistort(const T* params, const T& x, const T& y) {
  return Vec2<T>(x, y) + Correction(params, x, y);
}

// Ideal image point → measured image point (image mm): the inverse of Undistort, by Newton
// iteration on the 2×2 system with the analytic Jacobian of Δ. The values are solved in double to
// |step| < 1e-12 mm, then one Newton step in T carries the derivatives (implicit-function
// theorem), so Jets get exact derivatives at no extra iterations. Returns nullopt if Newton does
// not converge or lands where det(I + ∂Δ/∂x̄) ≤ 0 (the fold beyond which the polynomial is no
// longer a lens).
template <typename T>
std::optional<Vec2<T>> Distort(const T* params, const T& x_ideal, const T& y_ideal) {
  const Vec2<T> target(x_ideal - params[kBrownX0], y_ideal - params[kBrownY0]);
  std::array<double, kBrownNumParams> pd;
  for (int i = 0; i < kBrownNumParams; ++i) pd[i] = ScalarValue(params[i]);
  const Vec2<double> target_d(ScalarValue(target(0)), ScalarValue(target(1)));
  Vec2<double> xb = target_d;  // start at the ideal point
  double det = 0;
  bool converged = false;
  for (int it = 0; it < detail::kMaxNewtonIterations; ++it) {
    const Vec2<double> step = detail::NewtonStep<double>(pd.data(), target_d, &xb, &det);
    if (!(det > 0) || !xb.allFinite()) return std::nullopt;
    if (step.norm() < detail::kNewtonToleranceMm) {
      converged = true;
      break;
    }
  }
  if (!converged) return std::nullopt;
  Vec2<T> xb_t(T(xb(0)), T(xb(1)));
  T det_t;
  detail::NewtonStep<T>(params, target, &xb_t, &det_t);
  if (!(ScalarValue(det_t) > 0)) return std::nullopt;
  return Vec2<T>(xb_t(0) + params[kBrownX0], xb_t(1) + params[kBrownY0]);
}

// Point in the camera frame (mm; X right, Y down, Z forward) → measured image point (image mm,
// y up). nullopt if Z ≤ 0 or Distort fails.
template <typename T>
std::optional<Vec2<T>> Project(const T* params, const Vec3<T>& point_in_cam) {
  if (!(ScalarValue(point_in_cam(2)) > 0)) return std::nullopt;
  const T& c = params[kBrownC];
  const T x_ideal = params[kBrownX0] + c * point_in_cam(0) / point_in_cam(2);
  const T y_ideal = params[kBrownY0] - c * point_in_cam(1) / point_in_cam(2);
  return Distort(params, x_ideal, y_ideal);
}

// Measured image point (image mm, y up) → unit ray direction in the camera frame (X right,
// Y down, Z forward). Closed form: no iteration.
template <typename T>
Vec3<T> Unproject(const T* params, const T& x, const T& y) {
  const Vec2<T> d = Correction(params, x, y);
  const Vec3<T> dir(x - params[kBrownX0] + d(0), -(y - params[kBrownY0] + d(1)), params[kBrownC]);
  return dir / dir.norm();
}

// ∂Δ/∂(x, y) at a MEASURED point (image mm): the 2×2 Jacobian of Correction with respect to the
// point. ∂Δ/∂(x0, y0) is its negative. I + this is the matrix A whose inverse maps an ideal-point
// change to a measured-point change (implicit-function theorem on Undistort = ideal).
template <typename T>
Eigen::Matrix<T, 2, 2> CorrectionPointJacobian(const T* params, const T& x, const T& y) {
  Eigen::Matrix<T, 2, 2> jac;
  detail::CentredCorrection<T>(params, x - params[kBrownX0], y - params[kBrownY0], &jac);
  return jac;
}

// The additional parameters K1, K2, K3, P1, P2, B1, B2 (BrownIndex kBrownK1 … kBrownB2).
inline constexpr int kBrownNumAdditional = kBrownNumParams - kBrownK1;

// ∂Δ/∂(K1, K2, K3, P1, P2, B1, B2) at a MEASURED point (image mm). Δ is linear in these seven, so
// column j is the j-th term of the correction polynomial and Correction = this · (K1 … B2).
// Units: mm per unit of each parameter (kBrownParamInfo).
template <typename T>
Eigen::Matrix<T, 2, kBrownNumAdditional> CorrectionParamJacobian(const T* params, const T& x,
                                                                  const T& y) {
  const T xb = x - params[kBrownX0], yb = y - params[kBrownY0];
  const T r2 = xb * xb + yb * yb, r4 = r2 * r2, r6 = r4 * r2;
  Eigen::Matrix<T, 2, kBrownNumAdditional> b;
  b << xb * r2, xb * r4, xb * r6, r2 + T(2) * xb * xb, T(2) * xb * yb, xb, yb,  //
      yb * r2, yb * r4, yb * r6, T(2) * xb * yb, r2 + T(2) * yb * yb, T(0), T(0);
  return b;
}

// ---------------------------------------------------------------------------------------------
// Struct form: the same functions for fixed (double) parameters and a point of scalar type T.

template <typename T>
Vec2<T> Correction(const BrownParams& params, const T& x, const T& y) {
  const auto p = params.ToArray<T>();
  return Correction<T>(p.data(), x, y);
}
template <typename T>
Vec2<T> Undistort(const BrownParams& params, const T& x, const T& y) {
  const auto p = params.ToArray<T>();
  return Undistort<T>(p.data(), x, y);
}
template <typename T>
std::optional<Vec2<T>> Distort(const BrownParams& params, const T& x_ideal, const T& y_ideal) {
  const auto p = params.ToArray<T>();
  return Distort<T>(p.data(), x_ideal, y_ideal);
}
template <typename T>
std::optional<Vec2<T>> Project(const BrownParams& params, const Vec3<T>& point_in_cam) {
  const auto p = params.ToArray<T>();
  return Project<T>(p.data(), point_in_cam);
}
template <typename T>
Vec3<T> Unproject(const BrownParams& params, const T& x, const T& y) {
  const auto p = params.ToArray<T>();
  return Unproject<T>(p.data(), x, y);
}

// ---------------------------------------------------------------------------------------------
// Ceres residuals. The residual lives in the image: projected minus observed measured point, in
// image mm divided by sigma_mm (so with sigma_mm = the measurement σ it is dimensionless).
// Evaluation fails (returns false) where Project fails.

// Parameter blocks: camera [kBrownNumParams] (BrownIndex order), point_in_cam [3] (mm).
struct BrownReprojectionResidual {
  BrownReprojectionResidual(double x_obs_mm, double y_obs_mm, double sigma_mm = 1.0)
      : x_obs_mm(x_obs_mm), y_obs_mm(y_obs_mm), sigma_mm(sigma_mm) {}

  template <typename T>
  bool operator()(const T* camera, const T* point_in_cam, T* residual) const {
    const auto xy = Project<T>(camera, Vec3<T>(point_in_cam[0], point_in_cam[1], point_in_cam[2]));
    if (!xy) return false;
    residual[0] = ((*xy)(0) - T(x_obs_mm)) / T(sigma_mm);
    residual[1] = ((*xy)(1) - T(y_obs_mm)) / T(sigma_mm);
    return true;
  }

  static ceres::CostFunction* Create(double x_obs_mm, double y_obs_mm, double sigma_mm = 1.0) {
    return new ceres::AutoDiffCostFunction<BrownReprojectionResidual, 2, kBrownNumParams, 3>(
        new BrownReprojectionResidual(x_obs_mm, y_obs_mm, sigma_mm));
  }

  double x_obs_mm, y_obs_mm, sigma_mm;
};

// Bundle-adjustment form. Parameter blocks: camera [kBrownNumParams], cam_from_world rotation as
// an angle-axis vector [3] (rad), cam_from_world translation [3] (mm), point_in_world [3] (mm):
// point_in_cam = R·point_in_world + t.
struct BrownBundleResidual {
  BrownBundleResidual(double x_obs_mm, double y_obs_mm, double sigma_mm = 1.0)
      : x_obs_mm(x_obs_mm), y_obs_mm(y_obs_mm), sigma_mm(sigma_mm) {}

  template <typename T>
  bool operator()(const T* camera, const T* rotation, const T* translation, const T* point_in_world,
                  T* residual) const {
    T rotated[3];
    ceres::AngleAxisRotatePoint(rotation, point_in_world, rotated);
    const Vec3<T> point_in_cam(rotated[0] + translation[0], rotated[1] + translation[1],
                               rotated[2] + translation[2]);
    return BrownReprojectionResidual(x_obs_mm, y_obs_mm, sigma_mm)(camera, point_in_cam.data(),
                                                                   residual);
  }

  static ceres::CostFunction* Create(double x_obs_mm, double y_obs_mm, double sigma_mm = 1.0) {
    return new ceres::AutoDiffCostFunction<BrownBundleResidual, 2, kBrownNumParams, 3, 3, 3>(
        new BrownBundleResidual(x_obs_mm, y_obs_mm, sigma_mm));
  }

  double x_obs_mm, y_obs_mm, sigma_mm;
};

}  // namespace porthole::camera
