// Dense refits between camera models and the covariance carried through a conversion
// (docs/interop.md, "What is exact and what is refit"); refit.cc builds interop.h's
// ConvertCalibration on them, internal.h the formats' ConvertTo and CarrySigma. A projector is any type with
//   static constexpr int kNumParams;
//   template <typename T> std::optional<camera::Vec2<T>> operator()(const T* params, const camera::Vec3<T>& ray) const;
// returning porthole pixels ((0, 0) the centre of the top-left pixel). Models of the camera list
// are projectors through ListProjector; formats with a model of their own (Metashape) write one.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "porthole/camera/camera.h"
#include "porthole/camera/opencv_model.h"
#include "porthole/core/error.h"

namespace porthole::interop::refit {

template <typename M>
struct ListProjector {
  static constexpr int kNumParams = M::kNumParams;
  camera::Sensor sensor;
  template <typename T>
  std::optional<camera::Vec2<T>> operator()(const T* p, const camera::Vec3<T>& ray) const {
    return M::template Project<T>(sensor, p, ray);
  }
};

// Rays through a grid of `cols` × `rows` pixel centres spanning the frame, by `unproject` (any
// callable Vector2d → optional<Vector3d>); pixels it cannot unproject are left out.
template <typename Unproject>
std::vector<Eigen::Vector3d> GridRays(const camera::Sensor& s, const Unproject& unproject,
                                      int cols = 40, int rows = 30) {
  std::vector<Eigen::Vector3d> rays;
  for (const Eigen::Vector2d& uv : camera::FramePixels(s, cols, rows)) {
    if (const auto ray = unproject(uv)) rays.push_back(*ray);
  }
  return rays;
}

// The rays `proj` (parameters p) can project and their pixels: the data a refit fits to.
struct ProjectedRays {
  std::vector<Eigen::Vector3d> rays;
  std::vector<Eigen::Vector2d> px;
};
template <typename Proj>
ProjectedRays ProjectRays(const Proj& proj, const std::vector<double>& p, const std::vector<Eigen::Vector3d>& rays) {
  ProjectedRays out;
  for (const Eigen::Vector3d& r : rays) {
    if (const auto uv = proj(p.data(), camera::Vec3<double>(r))) {
      out.rays.push_back(r);
      out.px.push_back(*uv);
    }
  }
  return out;
}

// d pixel / d params, two rows a ray (u then v), by forward-mode automatic differentiation; a ray
// the projector cannot project gives zero rows.
template <typename Proj>
Eigen::MatrixXd PixelJacobian(const Proj& proj, const std::vector<double>& p,
                              const std::vector<Eigen::Vector3d>& rays) {
  constexpr int N = Proj::kNumParams;
  using J = ceres::Jet<double, N>;
  std::array<J, N> pj;
  for (int i = 0; i < N; ++i) pj[i] = J(p[i], i);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(2 * static_cast<int>(rays.size()), N);
  for (std::size_t k = 0; k < rays.size(); ++k) {
    const auto uv = proj(pj.data(), camera::Vec3<J>(J(rays[k](0)), J(rays[k](1)), J(rays[k](2))));
    if (!uv) continue;
    out.row(2 * k) = (*uv)(0).v.transpose();
    out.row(2 * k + 1) = (*uv)(1).v.transpose();
  }
  return out;
}

// Residual (px) of one ray: the projector's pixel minus the target pixel.
template <typename Proj>
struct FitResidual {
  const Proj* proj;
  Eigen::Vector3d ray;
  Eigen::Vector2d px;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    const auto uv = (*proj)(p, camera::Vec3<T>(T(ray(0)), T(ray(1)), T(ray(2))));
    if (!uv) return false;
    r[0] = (*uv)(0) - T(px(0));
    r[1] = (*uv)(1) - T(px(1));
    return true;
  }
};

// The target's parameters q fitted so that target(q, ray) = source pixel of each ray, by Ceres
// from q (in: the start, out: the fit); parameters with free[i] false stay as given. Returns the
// misfit over the rays the target can project.
template <typename Proj>
camera::ConversionFit Fit(const Proj& target, std::vector<double>* q, const std::vector<bool>& free,
                          const std::vector<Eigen::Vector3d>& rays,
                          const std::vector<Eigen::Vector2d>& pixels) {
  constexpr int N = Proj::kNumParams;
  using Residual = FitResidual<Proj>;
  // Too few rays to fit (a source that projects hardly any of its own image's rays, e.g. a
  // principal point far outside the frame): no fit, and Ceres must not see a block with no residual.
  if (static_cast<int>(rays.size()) < N) {
    throw InvalidInput("refit", "the source calibration maps only " + std::to_string(rays.size()) +
                                    " of its image's grid rays: too few to refit it (is the principal point "
                                    "inside the image?)");
  }
  ceres::Problem problem;
  for (std::size_t k = 0; k < rays.size(); ++k) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Residual, 2, N>(
                                 new Residual{&target, rays[k], pixels[k]}),
                             nullptr, q->data());
  }
  std::vector<int> fixed;
  for (int i = 0; i < N; ++i) {
    if (!free[i]) fixed.push_back(i);
  }
  if (static_cast<int>(fixed.size()) == N) {
    problem.SetParameterBlockConstant(q->data());
  } else if (!fixed.empty()) {
    problem.SetManifold(q->data(), new ceres::SubsetManifold(N, fixed));
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 200;
  so.function_tolerance = 1e-15;
  so.parameter_tolerance = 1e-15;
  so.gradient_tolerance = 1e-20;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  camera::ConversionFit fit;
  double sum = 0;
  for (std::size_t k = 0; k < rays.size(); ++k) {
    const auto uv = target(q->data(), camera::Vec3<double>(rays[k]));
    if (!uv) {
      ++fit.num_not_projected;
      continue;
    }
    const double d = (*uv - pixels[k]).norm();
    sum += d * d;
    fit.max_px = std::max(fit.max_px, d);
    ++fit.num_points;
  }
  fit.rms_px = fit.num_points > 0 ? std::sqrt(sum / fit.num_points) : NAN;
  return fit;
}

// The covariance of a conversion's result q from that of its input p: Σq = G Σp Gᵀ with
// G = ∂q/∂p = (Jqᵀ Jq)⁻¹ Jqᵀ Jp over the free columns of q (the least-squares refit's sensitivity
// to the source's pixels; for an exact conversion the Jacobian of the mapping itself). Rows and
// columns of parameters q holds fixed are 0. NaN entries of Σp (unknown) make what they touch NaN.
struct Propagated {
  Eigen::MatrixXd g;           // ∂q/∂p (rows of fixed q are 0)
  Eigen::MatrixXd covariance;  // Σq
};
inline Propagated PropagateCovariance(const Eigen::MatrixXd& jq, const std::vector<bool>& free_q,
                                      const Eigen::MatrixXd& jp, const Eigen::MatrixXd& sigma_p) {
  std::vector<int> cols;
  for (int i = 0; i < static_cast<int>(free_q.size()); ++i) {
    if (free_q[i]) cols.push_back(i);
  }
  Eigen::MatrixXd jf(jq.rows(), static_cast<int>(cols.size()));
  for (int c = 0; c < static_cast<int>(cols.size()); ++c) jf.col(c) = jq.col(cols[c]);
  // Column scaling: the parameters span many orders of magnitude (f ~ 1e3, k3 ~ 1e-2).
  const Eigen::VectorXd scale = jf.colwise().norm().cwiseMax(1e-300).cwiseInverse();
  const Eigen::MatrixXd js = jf * scale.asDiagonal();
  const Eigen::MatrixXd g_scaled = js.colPivHouseholderQr().solve(jp);
  const Eigen::MatrixXd g_free = scale.asDiagonal() * g_scaled;
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(jq.cols(), jp.cols());
  for (int c = 0; c < static_cast<int>(cols.size()); ++c) g.row(cols[c]) = g_free.row(c);
  // Σq = G Σp Gᵀ, with the unknown entries of Σp spreading NaN only where G uses them.
  Eigen::MatrixXd known = sigma_p;
  for (int i = 0; i < known.rows(); ++i) {
    for (int j = 0; j < known.cols(); ++j) {
      if (!std::isfinite(known(i, j))) known(i, j) = 0;
    }
  }
  Eigen::MatrixXd out = g * known * g.transpose();
  for (int i = 0; i < sigma_p.rows(); ++i) {
    for (int j = 0; j < sigma_p.cols(); ++j) {
      if (std::isfinite(sigma_p(i, j))) continue;
      for (int a = 0; a < out.rows(); ++a) {
        if (g(a, i) == 0 && g(a, j) == 0) continue;
        out.row(a).setConstant(NAN);
        out.col(a).setConstant(NAN);
      }
    }
  }
  return {g, out};
}

}  // namespace porthole::interop::refit
