#include "porthole/fit/plane_fit.h"

#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "porthole/core/error.h"

namespace porthole::fit {

PlaneFitSummary FitPlane(const Eigen::Matrix3Xd& p, const PlaneFitOptions& o) {
  if (p.cols() < 3)
    throw InvalidInput("points", fmt::format("a plane needs at least 3 points, got {}", p.cols()));
  if (!p.allFinite()) throw InvalidInput("points", "contain a non-finite coordinate");
  if (!o.normal_hint.allFinite()) throw InvalidInput("normal_hint", "must be finite");
  const auto n = static_cast<double>(p.cols());
  PlaneFitSummary out;
  out.n_points = p.cols();
  out.centroid_mm = p.rowwise().mean();
  const Eigen::Matrix3Xd d = p.colwise() - out.centroid_mm;
  const Eigen::Matrix3d scatter = d * d.transpose();  // Σ (p − m)(p − m)ᵀ, mm²
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(scatter);
  const Eigen::Vector3d lam = es.eigenvalues().cwiseMax(0.0);  // ascending
  const double scale = std::max(1.0, out.centroid_mm.norm());
  if (!(lam[2] > 1e-24 * scale * scale * n)) throw InvalidInput("points", "all points are equal");
  if (lam[1] <= 1e-12 * lam[2]) throw InvalidInput("points", "points are collinear: no plane");

  Eigen::Vector3d normal = es.eigenvectors().col(0).normalized();
  const Eigen::Vector3d hint = o.normal_hint;
  if (hint.squaredNorm() > 0) {
    if (normal.dot(hint) < 0) normal = -normal;
  } else {
    Eigen::Index k;
    normal.cwiseAbs().maxCoeff(&k);
    if (normal[k] < 0) normal = -normal;
  }
  out.plane.normal = normal;
  out.plane.offset_mm = normal.dot(out.centroid_mm);
  out.residuals_mm = (normal.transpose() * d).transpose();
  out.rms_mm = std::sqrt(out.residuals_mm.squaredNorm() / n);
  out.max_abs_residual_mm = out.residuals_mm.cwiseAbs().maxCoeff();
  if (p.cols() > 3) {
    const double s2 = out.residuals_mm.squaredNorm() / (n - 3);
    out.sigma0_mm = std::sqrt(s2);
    // First-order perturbation of the smallest eigenvector: along e_k (k = 1, 2) the normal's
    // variance is σ² λ_k / (λ_k − λ_0)².
    out.normal_covariance.setZero();
    for (int k = 1; k <= 2; ++k) {
      const Eigen::Vector3d e = es.eigenvectors().col(k);
      out.normal_covariance +=
          s2 * lam[k] / ((lam[k] - lam[0]) * (lam[k] - lam[0])) * e * e.transpose();
    }
    out.sigma_normal = out.normal_covariance.diagonal().cwiseSqrt();
    out.sigma_tilt_rad = std::sqrt(out.normal_covariance.trace());
    // d = n·m: the centroid's error along n (σ²/N) plus the tilt seen from the origin.
    out.sigma_offset_mm =
        std::sqrt(s2 / n + out.centroid_mm.dot(out.normal_covariance * out.centroid_mm));
  }
  return out;
}

bool PlaneFitSummary::IsUsable() const {
  return n_points > 3 && plane.normal.allFinite() && std::isfinite(plane.offset_mm) &&
         std::isfinite(sigma_offset_mm);
}

std::string PlaneFitSummary::BriefReport() const {
  return fmt::format(
      "plane: normal ({:.6f}, {:.6f}, {:.6f}) ± {:.2e} rad, offset {:.4f} ± {:.4f} mm, "
      "rms {:.4f} mm, max |r| {:.4f} mm, {} points: {}",
      plane.normal.x(), plane.normal.y(), plane.normal.z(), sigma_tilt_rad, plane.offset_mm,
      sigma_offset_mm, rms_mm, max_abs_residual_mm, n_points,
      IsUsable() ? "usable" : "no redundancy (3 points): no σ");
}

}  // namespace porthole::fit
