#include "porthole/fit/sphere_fit.h"

#include <ceres/ceres.h>
#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <random>

#include "porthole/core/error.h"
#include "porthole/fit/robust.h"

namespace porthole::fit {
namespace {

constexpr int kChunk = 512;  // points per Ceres residual block

// Residuals |p − c| − R of a run of points (3×k, column-major) for x = (cx, cy, cz, R).
struct SphereChunk {
  const double* xyz;
  int k;
  bool robust;
  RobustLoss loss;
  double scale;

  template <typename T>
  bool operator()(const T* const x, T* residuals) const {
    using std::sqrt;
    for (int i = 0; i < k; ++i) {
      const T dx = T(xyz[3 * i]) - x[0];
      const T dy = T(xyz[3 * i + 1]) - x[1];
      const T dz = T(xyz[3 * i + 2]) - x[2];
      const T r = sqrt(dx * dx + dy * dy + dz * dz) - x[3];
      residuals[i] = robust ? internal::RobustResidual(r, loss, scale) : r;
    }
    return true;
  }
};

struct SolveResult {
  Sphere sphere;
  bool converged = false;
  int iterations = 0;
};

// Geometric least squares from `start` on the contiguous 3×N points.
SolveResult SolveGeometric(const Eigen::Matrix3Xd& pts, const Sphere& start, bool robust,
                           RobustLoss loss, double scale, const SphereFitOptions& o) {
  double x[4] = {start.center_mm.x(), start.center_mm.y(), start.center_mm.z(), start.radius_mm};
  ceres::Problem problem;
  const auto n = static_cast<int>(pts.cols());
  for (int b = 0; b < n; b += kChunk) {
    const int k = std::min(kChunk, n - b);
    auto* cost = new ceres::AutoDiffCostFunction<SphereChunk, ceres::DYNAMIC, 4>(
        new SphereChunk{pts.data() + 3 * static_cast<ptrdiff_t>(b), k, robust, loss, scale}, k);
    problem.AddResidualBlock(cost, nullptr, x);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(internal::GeometricSolverOptions(o.max_solver_iterations, o.num_threads), &problem,
               &summary);
  SolveResult out;
  out.sphere.center_mm = Eigen::Vector3d(x[0], x[1], x[2]);
  out.sphere.radius_mm = std::abs(x[3]);
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  out.iterations = static_cast<int>(summary.iterations.size());
  return out;
}

Eigen::VectorXd Residuals(const Eigen::Matrix3Xd& pts, const Sphere& s) {
  return ((pts.colwise() - s.center_mm).colwise().norm().array() - s.radius_mm)
      .matrix()
      .transpose();
}

Eigen::Matrix3Xd Select(const Eigen::Matrix3Xd& pts, const std::vector<bool>& keep, int64_t count) {
  Eigen::Matrix3Xd out(3, count);
  Eigen::Index j = 0;
  for (Eigen::Index i = 0; i < pts.cols(); ++i)
    if (keep[static_cast<size_t>(i)]) out.col(j++) = pts.col(i);
  return out;
}

// Algebraic fit without the degeneracy checks: |q|² = 2a·q + d with q = (p − mean)/s, normal
// equations accumulated in one pass (upper triangle in scalars).
Sphere AlgebraicUnchecked(const Eigen::Matrix3Xd& p) {
  const Eigen::Vector3d mean = p.rowwise().mean();
  const double s = std::sqrt((p.colwise() - mean).squaredNorm() / static_cast<double>(p.cols()));
  const double inv_s = 1.0 / s;
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0, x1 = 0, y1 = 0, z1 = 0;
  double bx = 0, by = 0, bz = 0, b1 = 0;
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double x = (p(0, i) - mean.x()) * inv_s, y = (p(1, i) - mean.y()) * inv_s,
                 z = (p(2, i) - mean.z()) * inv_s;
    const double q2 = x * x + y * y + z * z;
    xx += x * x;
    xy += x * y;
    xz += x * z;
    yy += y * y;
    yz += y * z;
    zz += z * z;
    x1 += x;
    y1 += y;
    z1 += z;
    bx += x * q2;
    by += y * q2;
    bz += z * q2;
    b1 += q2;
  }
  // Unknowns (a, d) with rows (2x, 2y, 2z, 1).
  Eigen::Matrix4d ata;
  ata << 4 * xx, 4 * xy, 4 * xz, 2 * x1,  //
      4 * xy, 4 * yy, 4 * yz, 2 * y1,     //
      4 * xz, 4 * yz, 4 * zz, 2 * z1,     //
      2 * x1, 2 * y1, 2 * z1, static_cast<double>(p.cols());
  const Eigen::Vector4d atb(2 * bx, 2 * by, 2 * bz, b1);
  const Eigen::Vector4d sol = ata.ldlt().solve(atb);
  if (!sol.allFinite())
    throw InvalidInput("points", "a sphere is not determined (singular system)");
  Sphere out;
  out.center_mm = mean + s * sol.head<3>();
  out.radius_mm = s * std::sqrt(std::max(0.0, sol[3] + sol.head<3>().squaredNorm()));
  return out;
}

struct MsacResult {
  Sphere sphere;
  int iterations = 0;
  bool found = false;
};

// MSAC with minimal 4-point samples, scored on a random subset, then an algebraic fit to the best
// hypothesis' inliers (local optimisation, twice).
MsacResult Msac(const Eigen::Matrix3Xd& pts, const SphereFitOptions& o) {
  const Eigen::Index n = pts.cols();
  std::mt19937_64 rng(o.seed);
  // Scoring subset.
  const Eigen::Index m = std::min<Eigen::Index>(n, std::max(o.ransac_score_points, 16));
  std::vector<Eigen::Index> idx(static_cast<size_t>(n));
  std::iota(idx.begin(), idx.end(), 0);
  for (Eigen::Index k = 0; k < m; ++k) {
    std::uniform_int_distribution<Eigen::Index> pick(k, n - 1);
    std::swap(idx[static_cast<size_t>(k)], idx[static_cast<size_t>(pick(rng))]);
  }
  Eigen::Matrix3Xd subset(3, m);
  for (Eigen::Index k = 0; k < m; ++k) subset.col(k) = pts.col(idx[static_cast<size_t>(k)]);

  const double t2 = o.inlier_threshold_mm * o.inlier_threshold_mm;
  const double spread =
      std::sqrt((pts.colwise() - pts.rowwise().mean()).squaredNorm() / static_cast<double>(n));
  std::uniform_int_distribution<Eigen::Index> any(0, n - 1);
  MsacResult best;
  double best_cost = std::numeric_limits<double>::infinity();
  double needed = o.max_ransac_iterations;
  int it = 0;
  for (; it < o.max_ransac_iterations && it < needed; ++it) {
    Eigen::Index s[4];
    for (int j = 0; j < 4; ++j) {
      bool dup;
      do {
        s[j] = any(rng);
        dup = false;
        for (int q = 0; q < j; ++q) dup |= s[q] == s[j];
      } while (dup);
    }
    Sphere h;
    if (!SphereFrom4Points(pts.col(s[0]), pts.col(s[1]), pts.col(s[2]), pts.col(s[3]), &h))
      continue;
    if (!(h.radius_mm < 1e4 * spread)) continue;  // near-planar sample: not a useful hypothesis
    const Eigen::ArrayXd r =
        (subset.colwise() - h.center_mm).colwise().norm().array() - h.radius_mm;
    const Eigen::ArrayXd r2 = r.square();
    const double cost = r2.min(t2).sum();
    if (cost < best_cost) {
      best_cost = cost;
      best.sphere = h;
      best.found = true;
      const double w = static_cast<double>((r2 <= t2).count()) / static_cast<double>(m);
      const double p_good = std::pow(w, 4);
      if (p_good >= 1.0) {
        needed = 0;
      } else if (p_good > 0) {
        needed = std::log(1.0 - o.ransac_confidence) / std::log(1.0 - p_good);
      }
    }
  }
  best.iterations = it;
  if (!best.found) return best;
  // Local optimisation: algebraic refit on the inliers of the current sphere.
  for (int lo = 0; lo < 2; ++lo) {
    const Eigen::ArrayXd r = Residuals(pts, best.sphere).array().abs();
    std::vector<bool> in(static_cast<size_t>(n));
    int64_t count = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      count += (in[static_cast<size_t>(i)] = r[i] <= o.inlier_threshold_mm);
    if (count < 4) break;
    try {
      const Eigen::Matrix3Xd inl = Select(pts, in, count);
      CheckSpherePoints(inl);
      best.sphere = AlgebraicUnchecked(inl);
    } catch (const InvalidInput&) {
      break;  // inliers degenerate: keep the minimal-sample sphere
    }
  }
  return best;
}

}  // namespace

void CheckSpherePoints(const Eigen::Matrix3Xd& p) {
  if (p.cols() < 4)
    throw InvalidInput("points", fmt::format("a sphere needs at least 4 points, got {}", p.cols()));
  if (!p.allFinite()) throw InvalidInput("points", "contain a non-finite coordinate");
  const Eigen::Vector3d mean = p.rowwise().mean();
  const Eigen::Matrix3d scatter = internal::Scatter(p, mean) / static_cast<double>(p.cols());
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  const double scale = std::max(1.0, mean.norm());
  if (!(ev[2] > 1e-24 * scale * scale)) throw InvalidInput("points", "all points are equal");
  if (ev[1] <= 1e-12 * ev[2]) throw InvalidInput("points", "points are collinear: no sphere");
  if (ev[0] <= 1e-12 * ev[2])
    throw InvalidInput("points", "points are coplanar: a sphere is not determined");
}

Sphere FitSphereAlgebraic(const Eigen::Matrix3Xd& p) {
  CheckSpherePoints(p);
  return AlgebraicUnchecked(p);
}

bool SphereFrom4Points(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d, Sphere* sphere) {
  // With d_i = p_i − a, the centre x − a satisfies 2 d_i·(x − a) = |d_i|² (i = 1..3).
  const Eigen::Vector3d d1 = b - a, d2 = c - a, d3 = d - a;
  const double det = 2.0 * d1.dot(d2.cross(d3));
  if (!(std::abs(det) > 1e-9 * d1.norm() * d2.norm() * d3.norm())) return false;
  const Eigen::Vector3d x = (d1.squaredNorm() * d2.cross(d3) + d2.squaredNorm() * d3.cross(d1) +
                             d3.squaredNorm() * d1.cross(d2)) /
                            det;
  sphere->center_mm = a + x;
  sphere->radius_mm = x.norm();
  return std::isfinite(sphere->radius_mm);
}

SphereFitSummary FitSphere(const Eigen::Matrix3Xd& pts, const SphereFitOptions& o) {
  CheckSpherePoints(pts);
  if (o.robust) RequirePositive("inlier_threshold_mm", o.inlier_threshold_mm);
  if (o.max_ransac_iterations < 1) throw InvalidInput("max_ransac_iterations", "must be >= 1");
  if (!(o.ransac_confidence > 0 && o.ransac_confidence < 1))
    throw InvalidInput("ransac_confidence", "must be in (0, 1)");
  if (o.max_solver_iterations < 1) throw InvalidInput("max_solver_iterations", "must be >= 1");
  if (o.num_threads < 1) throw InvalidInput("num_threads", "must be >= 1");

  SphereFitSummary out;
  out.n_points = pts.cols();
  const Eigen::Index n = pts.cols();

  Sphere start;
  if (o.robust) {
    const MsacResult msac = Msac(pts, o);
    out.ransac_iterations = msac.iterations;
    if (!msac.found) {
      out.message = "MSAC found no non-degenerate 4-point sample";
      out.residuals_mm = Eigen::VectorXd::Constant(n, NAN);
      out.is_inlier.assign(static_cast<size_t>(n), false);
      return out;
    }
    start = msac.sphere;
  } else {
    start = AlgebraicUnchecked(pts);
  }

  SolveResult solved = SolveGeometric(pts, start, o.robust, o.loss, o.inlier_threshold_mm, o);
  out.solver_iterations = solved.iterations;
  out.is_inlier.assign(static_cast<size_t>(n), true);
  int64_t n_in = n;
  if (o.robust) {
    const Eigen::VectorXd r = Residuals(pts, solved.sphere);
    n_in = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      n_in += (out.is_inlier[static_cast<size_t>(i)] = std::abs(r[i]) <= o.inlier_threshold_mm);
    if (n_in >= 5) {
      if (o.refit_inliers) {
        const Eigen::Matrix3Xd inliers = Select(pts, out.is_inlier, n_in);
        const bool robust_converged = solved.converged;
        solved = SolveGeometric(inliers, solved.sphere, false, o.loss, 0, o);
        solved.converged = solved.converged && robust_converged;
        out.solver_iterations += solved.iterations;
      }
    }
  }
  out.sphere = solved.sphere;
  out.converged = solved.converged;
  out.n_inliers = n_in;
  // Residuals of every point; statistics and JᵀJ (J = ∂r/∂(c, R) = (−uᵀ, −1)) over the inliers.
  out.residuals_mm.resize(n);
  double sum2 = 0, max_abs = 0;
  double uxx = 0, uxy = 0, uxz = 0, uyy = 0, uyz = 0, uzz = 0, ux = 0, uy = 0, uz = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d d = pts.col(i) - out.sphere.center_mm;
    const double len = d.norm();
    const double r = len - out.sphere.radius_mm;
    out.residuals_mm[i] = r;
    if (!out.is_inlier[static_cast<size_t>(i)]) continue;
    sum2 += r * r;
    max_abs = std::max(max_abs, std::abs(r));
    const Eigen::Vector3d u = d / len;
    uxx += u.x() * u.x();
    uxy += u.x() * u.y();
    uxz += u.x() * u.z();
    uyy += u.y() * u.y();
    uyz += u.y() * u.z();
    uzz += u.z() * u.z();
    ux += u.x();
    uy += u.y();
    uz += u.z();
  }
  Eigen::Matrix4d jtj;
  jtj << uxx, uxy, uxz, ux,  //
      uxy, uyy, uyz, uy,     //
      uxz, uyz, uzz, uz,     //
      ux, uy, uz, static_cast<double>(n_in);
  out.rms_mm = n_in > 0 ? std::sqrt(sum2 / static_cast<double>(n_in)) : NAN;
  out.max_abs_residual_mm = max_abs;
  if (n_in > 4) {
    out.sigma0_mm = std::sqrt(sum2 / static_cast<double>(n_in - 4));
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(jtj);
    if (es.eigenvalues()[0] > 1e-12 * es.eigenvalues()[3]) {
      out.covariance = out.sigma0_mm * out.sigma0_mm * jtj.inverse();
      out.sigma_center_mm = out.covariance.diagonal().head<3>().cwiseSqrt();
      out.sigma_radius_mm = std::sqrt(out.covariance(3, 3));
    }
  }

  if (!out.converged) {
    out.message = "the solver did not converge";
  } else if (n_in < 5) {
    out.message = fmt::format("only {} inliers (need 5): raise `threshold`?", n_in);
  } else if (!std::isfinite(out.sigma_radius_mm)) {
    out.message = "covariance is singular: the sphere is not determined";
  } else if (out.sigma_radius_mm > 0.1 * out.sphere.radius_mm) {
    out.message = "radius not determined (σ_R > R/10): the points are nearly planar";
  } else {
    out.message = "ok";
  }
  return out;
}

bool SphereFitSummary::IsUsable() const {
  return message == "ok" && converged && n_inliers >= 5 && sphere.center_mm.allFinite() &&
         std::isfinite(sphere.radius_mm) && sphere.radius_mm > 0 && std::isfinite(sigma_radius_mm);
}

std::string SphereFitSummary::BriefReport() const {
  return fmt::format(
      "sphere: centre ({:.4f}, {:.4f}, {:.4f}) ± ({:.4f}, {:.4f}, {:.4f}) mm, R {:.4f} ± {:.4f} "
      "mm, "
      "rms {:.4f} mm, max |r| {:.4f} mm, {} of {} points, {} iterations: {}",
      sphere.center_mm.x(), sphere.center_mm.y(), sphere.center_mm.z(), sigma_center_mm.x(),
      sigma_center_mm.y(), sigma_center_mm.z(), sphere.radius_mm, sigma_radius_mm, rms_mm,
      max_abs_residual_mm, n_inliers, n_points, solver_iterations, IsUsable() ? "usable" : message);
}

}  // namespace porthole::fit
