// A calibration made in air with the housing on (the paper's protocol: calibrated "without
// removing the camera from the pressure housing") as a prior on the lens AND the port of the
// refractive calibration (refractive.h, RefractiveOptions::AirCalibrationOf::kThroughPort;
// issue 26). Used by refractive.cc only.
//
// Such a calibration is a central camera C_h: a model of the camera list, its parameters θ_h and
// their covariance Σ_h over the ones it adjusted. It is not the lens: it is the central camera that
// best fits the rays of the lens behind the port with air outside (a thick or decentred dome is a
// weak meniscus lens in air). The prior is therefore on that fit:
//   r = W·(H(lens, port) − θ_h)  over the parameters C_h adjusted,  W = L⁻¹,  Σ_h = L·Lᵀ,
// H(lens, port) = the parameters of C_h's model (those it did not adjust held at its values) fitted,
// with a free pose per view, by least squares to the pixels y_j(lens, port) of fixed object points
// X_j seen through the port in air: a calibration of a network of views. The air calibration's own
// network is not known, so the caller gives one like it: the target at the water images' poses
// (refractive.cc). The network matters: the bundle through a decentred dome is not central, and
// what a central camera absorbs of it (a principal-point shift against a tilt of each view)
// depends on the views, so a single rigid bundle gives another answer than a calibration does.
// What no central camera holds stays in the fit's residual (`fit_rms_px`).
// H is linearised at a point (lens0, port0): H ≈ H0 + G·(y(lens, port) − y0), G the intrinsic rows
// of the fit's (JᵀJ)⁻¹Jᵀ at H0 (the Gauss–Newton step), and re-linearised after each adjustment
// until y0 settles (refractive.cc): at convergence H0 is the fit at the estimate and G its
// derivative, up to the second-order term of the fit's own residual.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "porthole/calib/prior_cost.h"
#include "porthole/calib/result_json.h"
#include "porthole/camera/sensor.h"
#include "porthole/core/error.h"
#include "porthole/refraction/refraction.h"

namespace porthole::calib {

struct HousedPrior {
  std::vector<int> idx;              // the parameters C_h adjusted (model order)
  Eigen::VectorXd mean;              // θ_h over idx
  Eigen::MatrixXd whiten;            // W = L⁻¹ over idx
  std::vector<double> held;          // C_h's parameters: the fit holds those not in idx here
  // X_j, camera frame (pupil at the origin), mm, and the view each belongs to.
  std::vector<Eigen::Vector3d> points;
  std::vector<int> view;
  // The linearisation: the pixels at (lens0, port0) (2 per point), the fit H0 over idx and its
  // poses (one per view: angle-axis rad, translation mm, applied to X_j), the gain G
  // (idx × 2·points), the fit's RMS (px, 2-D).
  Eigen::VectorXd y0, h0;
  std::vector<std::array<double, 6>> pose;
  Eigen::MatrixXd gain;
  double fit_rms_px = NAN;
  int linearisations = 0;
};

namespace housed_detail {

// The central fit's residual of one object point: M::Project(R·X + t) − y, px.
template <typename M>
struct CentralFitCost {
  camera::Sensor sensor;
  Eigen::Vector3d x;
  Eigen::Vector2d y;
  template <typename T>
  bool operator()(const T* cam, const T* pose, T* r) const {
    const T p[3] = {T(x.x()), T(x.y()), T(x.z())};
    T q[3];
    ceres::AngleAxisRotatePoint(pose, p, q);
    const Eigen::Matrix<T, 3, 1> pc(q[0] + pose[3], q[1] + pose[4], q[2] + pose[5]);
    const auto uv = M::template Project<T>(sensor, cam, pc);
    if (!uv) return false;
    r[0] = (*uv)(0) - T(y.x());
    r[1] = (*uv)(1) - T(y.y());
    return true;
  }
};

}  // namespace housed_detail

// The prior's fixed parts: idx, θ_h, W and the network: `views`, each the object points of one
// view in the camera frame (mm); the points C_h does not see inside its frame are left out, and of
// the others at most kPointsPerView are kept, evenly through the list.
// Throws InvalidInput("air_calibration") for a calibration that adjusted nothing, a covariance that
// is not positive definite, or a network it does not see.
inline constexpr std::size_t kPointsPerView = 24;

template <typename M>
HousedPrior MakeHousedPrior(const CalibrationRecord& air, const std::vector<std::vector<Eigen::Vector3d>>& views) {
  constexpr int N = M::kNumParams;
  HousedPrior h;
  for (int i = 0; i < N; ++i) {
    if (air.free[i]) h.idx.push_back(i);
  }
  if (h.idx.empty()) throw InvalidInput("air_calibration", "adjusted no parameter: it cannot be a prior");
  const WhitenedPrior w = WhitenedPriorOf(air, h.idx, "air_calibration");
  h.mean = w.mean;
  h.whiten = w.whiten;
  h.held = air.camera.params;
  const camera::Sensor& s = air.camera.sensor;
  for (const auto& v : views) {
    std::vector<Eigen::Vector3d> seen;
    for (const auto& x : v) {
      const auto uv = M::template Project<double>(s, air.camera.params.data(), x);
      if (uv && uv->x() >= 0 && uv->y() >= 0 && uv->x() <= s.width_px - 1 && uv->y() <= s.height_px - 1) {
        seen.push_back(x);
      }
    }
    if (seen.size() < 4) continue;  // as Calibrate: a view needs 4 points
    // At most kPointsPerView, evenly through the view's points (the cost is per point; the
    // network's shape is in its views).
    if (seen.size() > kPointsPerView) {
      std::vector<Eigen::Vector3d> kept;
      for (std::size_t a = 0; a < kPointsPerView; ++a) kept.push_back(seen[a * (seen.size() - 1) / (kPointsPerView - 1)]);
      seen = kept;
    }
    const int k = static_cast<int>(h.pose.size());
    for (const auto& x : seen) h.points.push_back(x), h.view.push_back(k);
    h.pose.push_back({});
  }
  if (h.pose.size() < 3) {
    throw InvalidInput("air_calibration", "sees fewer than 3 of the images' views of the target: not a camera of these images");
  }
  return h;
}

// (Re-)linearises H at (lens, port) in air (`air_shell`, `shell_values` with the water factor 1 or
// nullptr): projects the points (dropping those that cannot be seen through the port), fits C_h's
// model and a pose to them, and sets y0, h0, the pose, G and the fit's RMS. Returns the largest
// move of a pixel since the previous linearisation (infinity for the first). Throws
// InvalidInput("air_calibration") when fewer than half the points are seen.
template <typename M>
double LineariseHousedPrior(HousedPrior* h, const camera::Sensor& sensor, const refraction::Shell& air_shell,
                            const double* lens, const double* port, const double* shell_values) {
  constexpr int N = M::kNumParams;
  const int m = static_cast<int>(h->idx.size());
  std::vector<Eigen::Vector3d> seen;
  std::vector<int> seen_view;
  std::vector<Eigen::Vector2d> y;
  for (std::size_t j = 0; j < h->points.size(); ++j) {
    const auto uv = refraction::Project<M, double>(sensor, lens, air_shell, port, h->points[j], shell_values);
    if (uv) seen.push_back(h->points[j]), seen_view.push_back(h->view[j]), y.push_back(*uv);
  }
  const bool same = seen.size() == h->points.size();
  if (2 * seen.size() < h->points.size() || seen.size() < 10) {
    throw InvalidInput("air_calibration", "the lens behind the port in air sees less than half of the "
                                          "calibration's frame: not this camera in this housing");
  }
  double moved = std::numeric_limits<double>::infinity();
  if (same && h->y0.size() == 2 * static_cast<Eigen::Index>(y.size())) {
    moved = 0;
    for (std::size_t j = 0; j < y.size(); ++j) {
      moved = std::max(moved, (y[j] - Eigen::Vector2d(h->y0(2 * j), h->y0(2 * j + 1))).norm());
    }
  }
  h->points = seen;
  h->view = seen_view;
  const int J = static_cast<int>(seen.size());
  const int V = static_cast<int>(h->pose.size());
  // The central fit, from the previous one (or C_h, each view where it was given).
  std::vector<double> cam = h->held;
  for (int a = 0; a < m; ++a) cam[h->idx[a]] = h->h0.size() == m ? h->h0(a) : h->mean(a);
  std::vector<std::array<double, 6>> pose = h->pose;
  using Cost = housed_detail::CentralFitCost<M>;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    for (int j = 0; j < J; ++j) {
      costs.emplace_back(new ceres::AutoDiffCostFunction<Cost, 2, N, 6>(new Cost{sensor, seen[j], y[j]}));
      problem.AddResidualBlock(costs.back().get(), nullptr, cam.data(), pose[seen_view[j]].data());
    }
    std::vector<int> fixed;
    for (int i = 0; i < N; ++i) {
      if (std::find(h->idx.begin(), h->idx.end(), i) == h->idx.end()) fixed.push_back(i);
    }
    if (!fixed.empty()) problem.SetManifold(cam.data(), new ceres::SubsetManifold(N, fixed));
    ceres::Solver::Options so;
    so.logging_type = ceres::SILENT;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.max_num_iterations = 200;
    so.function_tolerance = 1e-14;
    so.parameter_tolerance = 1e-14;
    so.gradient_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (!summary.IsSolutionUsable()) {
      throw InvalidInput("air_calibration", "no central camera of its model fits the lens behind the port in air");
    }
  }
  // J = ∂r/∂(θ over idx, poses), columns scaled to unit norm; G = rows of (JᵀJ)⁻¹Jᵀ.
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(2 * J, m + 6 * V);
  Eigen::VectorXd res(2 * J);
  for (int j = 0; j < J; ++j) {
    double r[2];
    Eigen::Matrix<double, 2, N, Eigen::RowMajor> jc;
    Eigen::Matrix<double, 2, 6, Eigen::RowMajor> jp;
    const double* params[2] = {cam.data(), pose[seen_view[j]].data()};
    double* jacobians[2] = {jc.data(), jp.data()};
    if (!costs[j]->Evaluate(params, r, jacobians)) {
      throw InvalidInput("air_calibration", "the central fit of the lens behind the port in air fails at a grid point");
    }
    res(2 * j) = r[0], res(2 * j + 1) = r[1];
    for (int a = 0; a < m; ++a) jac.block(2 * j, a, 2, 1) = jc.col(h->idx[a]);
    jac.block(2 * j, m + 6 * seen_view[j], 2, 6) = jp;
  }
  const Eigen::VectorXd norms = jac.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd a = jac * norms.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd full = norms.cwiseInverse().asDiagonal() * (a.transpose() * a).ldlt().solve(a.transpose());
  h->gain = full.topRows(m);
  h->y0.resize(2 * J);
  for (int j = 0; j < J; ++j) h->y0(2 * j) = y[j].x(), h->y0(2 * j + 1) = y[j].y();
  h->h0.resize(m);
  for (int a = 0; a < m; ++a) h->h0(a) = cam[h->idx[a]];
  h->pose = pose;
  h->fit_rms_px = std::sqrt(res.squaredNorm() / J);
  ++h->linearisations;
  return moved;
}

// The prior's residual W·(H0 + G·(y(lens, port) − y0) − θ_h), padded with zeros to N rows (the
// lens's size: Ceres's residual count is fixed). Blocks: scaled lens [N], port, and the shell's
// values when some are adjusted (the water factor replaced by 1: air outside).
template <typename M>
struct HousedPriorCost {
  static constexpr int N = M::kNumParams;
  const HousedPrior* prior;
  camera::Sensor sensor;
  std::array<double, N> scale;
  refraction::Shell air_shell;

  template <typename T>
  bool Residual(const T* scaled, const T* port, const T* shell_values, T* r) const {
    T cam[N];
    for (int i = 0; i < N; ++i) cam[i] = scaled[i] * T(scale[i]);
    T air_values[refraction::kShellNumParams];
    if (shell_values != nullptr) {
      std::copy(shell_values, shell_values + refraction::kShellNumParams, air_values);
      air_values[0] = T(1);
    }
    const HousedPrior& h = *prior;
    const int m = static_cast<int>(h.idx.size());
    Eigen::Matrix<T, Eigen::Dynamic, 1> e(m);
    for (int a = 0; a < m; ++a) e(a) = T(h.h0(a) - h.mean(a));
    for (std::size_t j = 0; j < h.points.size(); ++j) {
      const Eigen::Vector3d& x = h.points[j];
      const refraction::Vec3T<T> p(T(x.x()), T(x.y()), T(x.z()));
      const auto uv = refraction::Project<M, T>(sensor, cam, air_shell, port, p,
                                                shell_values != nullptr ? air_values : nullptr);
      if (!uv) return false;
      const T du = (*uv)(0) - T(h.y0(2 * j)), dv = (*uv)(1) - T(h.y0(2 * j + 1));
      for (int a = 0; a < m; ++a) e(a) += T(h.gain(a, 2 * j)) * du + T(h.gain(a, 2 * j + 1)) * dv;
    }
    for (int a = 0; a < N; ++a) r[a] = T(0);
    for (int a = 0; a < m; ++a) {
      for (int b = 0; b <= a; ++b) r[a] += T(h.whiten(a, b)) * e(b);  // W is lower triangular
    }
    return true;
  }
  template <typename T>
  bool operator()(const T* scaled, const T* port, T* r) const {
    return Residual<T>(scaled, port, nullptr, r);
  }
};

template <typename M>
struct HousedPriorShellCost : HousedPriorCost<M> {
  template <typename T>
  bool operator()(const T* scaled, const T* port, const T* shell_values, T* r) const {
    return this->template Residual<T>(scaled, port, shell_values, r);
  }
};

}  // namespace porthole::calib
