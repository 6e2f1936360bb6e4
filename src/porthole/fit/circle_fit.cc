#include <ceres/ceres.h>
#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "porthole/core/error.h"
#include "porthole/fit/plane_fit.h"
#include "porthole/fit/robust.h"

namespace porthole::fit {
namespace {

constexpr int kChunk = 512;

// In-plane radial residuals |q − c| − R of k 2D points (2×k column-major), x = (cx, cy, R).
struct CircleChunk {
  const double* xy;
  int k;
  template <typename T>
  bool operator()(const T* const x, T* residuals) const {
    using std::sqrt;
    for (int i = 0; i < k; ++i) {
      const T dx = T(xy[2 * i]) - x[0];
      const T dy = T(xy[2 * i + 1]) - x[1];
      residuals[i] = sqrt(dx * dx + dy * dy) - x[2];
    }
    return true;
  }
};

}  // namespace

CircleFitSummary FitCircle3d(const Eigen::Matrix3Xd& p, const CircleFitOptions& o) {
  if (p.cols() < 3)
    throw InvalidInput("points", fmt::format("a circle needs at least 3 points, got {}", p.cols()));
  if (o.max_solver_iterations < 1) throw InvalidInput("max_solver_iterations", "must be >= 1");
  CircleFitSummary out;
  out.n_points = p.cols();
  out.plane = FitPlane(p, {.normal_hint = o.normal_hint});  // throws on equal/collinear points
  const Eigen::Vector3d normal = out.plane.plane.normal;
  const Eigen::Vector3d m = out.plane.centroid_mm;
  Eigen::Matrix<double, 3, 2> e;  // in-plane orthonormal basis
  e.col(0) = normal.unitOrthogonal();
  e.col(1) = normal.cross(e.col(0));
  const Eigen::Matrix2Xd q = e.transpose() * (p.colwise() - m);  // 2×N, mm

  // Algebraic start on scaled coordinates: |u|² = 2 a·u + c, u = q/s.
  const auto n = static_cast<double>(p.cols());
  const double s = std::sqrt(q.squaredNorm() / n);
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    const Eigen::Vector2d u = q.col(i) / s;
    const Eigen::Vector3d row(2 * u.x(), 2 * u.y(), 1.0);
    ata += row * row.transpose();
    atb += row * u.squaredNorm();
  }
  const Eigen::Vector3d sol = ata.ldlt().solve(atb);
  if (!sol.allFinite())
    throw InvalidInput("points", "a circle is not determined (singular system)");
  double x[3] = {s * sol[0], s * sol[1],
                 s * std::sqrt(std::max(0.0, sol[2] + sol.head<2>().squaredNorm()))};

  // Geometric refinement.
  ceres::Problem problem;
  const auto np = static_cast<int>(q.cols());
  for (int b = 0; b < np; b += kChunk) {
    const int k = std::min(kChunk, np - b);
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CircleChunk, ceres::DYNAMIC, 3>(
                                 new CircleChunk{q.data() + 2 * static_cast<ptrdiff_t>(b), k}, k),
                             nullptr, x);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(internal::GeometricSolverOptions(o.max_solver_iterations, 1), &problem, &summary);
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  const Eigen::Vector2d c2(x[0], x[1]);
  out.circle.radius_mm = std::abs(x[2]);
  out.circle.center_mm = m + e * c2;
  out.circle.normal = normal;
  out.residuals_mm =
      ((q.colwise() - c2).colwise().norm().array() - out.circle.radius_mm).transpose();
  out.rms_mm = std::sqrt(out.residuals_mm.squaredNorm() / n);
  out.max_abs_residual_mm = out.residuals_mm.cwiseAbs().maxCoeff();
  out.sigma_normal_rad = out.plane.sigma_tilt_rad;

  if (p.cols() > 3) {
    const double s2 = out.residuals_mm.squaredNorm() / (n - 3);
    out.sigma0_mm = std::sqrt(s2);
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      const Eigen::Vector2d u = (q.col(i) - c2).normalized();
      const Eigen::Vector3d j(-u.x(), -u.y(), -1.0);
      jtj += j * j.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(jtj);
    if (es.eigenvalues()[0] > 1e-12 * es.eigenvalues()[2]) {
      const Eigen::Matrix3d cov = s2 * jtj.inverse();  // of (cx, cy, R) in the plane
      out.sigma_radius_mm = std::sqrt(cov(2, 2));
      // In-plane part, plus the plane's uncertainty along the normal at the centre: the
      // centroid's offset error and the tilt acting over the lever arm centre − centroid.
      const Eigen::Vector3d lever = out.circle.center_mm - m;
      const double var_normal = out.plane.sigma0_mm * out.plane.sigma0_mm / n +
                                lever.dot(out.plane.normal_covariance * lever);
      out.center_covariance =
          e * cov.topLeftCorner<2, 2>() * e.transpose() + var_normal * normal * normal.transpose();
      out.sigma_center_mm = out.center_covariance.diagonal().cwiseSqrt();
    }
  }
  if (!out.converged) {
    out.message = "the solver did not converge";
  } else if (p.cols() <= 3) {
    out.message = "exact fit through 3 points: no redundancy, no σ";
  } else if (!std::isfinite(out.sigma_radius_mm)) {
    out.message = "covariance is singular: the circle is not determined";
  } else if (out.sigma_radius_mm > 0.1 * out.circle.radius_mm) {
    out.message = "radius not determined (σ_R > R/10): the points are nearly collinear";
  } else {
    out.message = "ok";
  }
  return out;
}

bool CircleFitSummary::IsUsable() const {
  return message == "ok" && circle.center_mm.allFinite() && std::isfinite(circle.radius_mm);
}

std::string CircleFitSummary::BriefReport() const {
  return fmt::format(
      "circle: centre ({:.4f}, {:.4f}, {:.4f}) ± ({:.4f}, {:.4f}, {:.4f}) mm, R {:.4f} ± {:.4f} "
      "mm, "
      "normal ({:.6f}, {:.6f}, {:.6f}) ± {:.2e} rad, rms {:.4f} mm, {} points: {}",
      circle.center_mm.x(), circle.center_mm.y(), circle.center_mm.z(), sigma_center_mm.x(),
      sigma_center_mm.y(), sigma_center_mm.z(), circle.radius_mm, sigma_radius_mm,
      circle.normal.x(), circle.normal.y(), circle.normal.z(), sigma_normal_rad, rms_mm, n_points,
      IsUsable() ? "usable" : message);
}

}  // namespace porthole::fit
