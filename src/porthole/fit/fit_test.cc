// Proves the sphere fit recovers the paper's dome (R 83.4 mm, 170k points, σ 0.05 mm) to 0.01 mm
// (centre) and 0.005 mm (radius), also with 20 % gross outliers in robust mode; that its reported
// σ match the Monte-Carlo spread; that a 30° cap converges; and that degenerate input raises.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "porthole/core/error.h"
#include "porthole/fit/robust.h"
#include "porthole/fit/sphere_fit.h"
#include "porthole/pointcloud/synthetic.h"

namespace porthole::fit {
namespace {

using pointcloud::MakeSyntheticCap;
using pointcloud::SyntheticCapOptions;

// Paper Table 3, outer sphere.
const Eigen::Vector3d kCenter(-0.4, -1.0, 21.5);
constexpr double kRadius = 83.4;

SyntheticCapOptions PaperCap(int64_t n, double sigma, uint64_t seed) {
  SyntheticCapOptions o;
  o.radius_mm = kRadius;
  o.center_mm = kCenter;
  o.axis = {0, 0, 1};
  o.half_angle_deg = 90;
  o.n_points = n;
  o.noise_sigma_mm = sigma;
  o.seed = seed;
  return o;
}

void ExpectNearTruth(const SphereFitSummary& s, double center_tol, double radius_tol) {
  ASSERT_TRUE(s.IsUsable()) << s.BriefReport();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.sphere.center_mm[k], kCenter[k], center_tol) << k;
  EXPECT_NEAR(s.sphere.radius_mm, kRadius, radius_tol);
}

TEST(SphereFit, PaperHemisphere170kPoints) {
  const auto cap = MakeSyntheticCap(PaperCap(170000, 0.05, 7));
  const auto t0 = std::chrono::steady_clock::now();
  const SphereFitSummary s = FitSphere(cap.points);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ExpectNearTruth(s, 0.01, 0.005);
  EXPECT_EQ(s.n_points, 170000);
  EXPECT_EQ(s.n_inliers, 170000);
  // Radial residual of isotropic noise: σ per axis.
  EXPECT_NEAR(s.rms_mm, 0.05, 0.002);
  EXPECT_LT(s.max_abs_residual_mm, 0.05 * 6.5);
  EXPECT_GT(s.sigma_radius_mm, 0);
  EXPECT_LT(s.sigma_radius_mm, 0.001);
  RecordProperty("fit_ms", std::to_string(ms));
  std::printf("%s (%.1f ms)\n", s.BriefReport().c_str(), ms);
}

TEST(SphereFit, PaperHemisphereWith20PercentOutliersRobust) {
  auto o = PaperCap(170000, 0.05, 8);
  o.outlier_fraction = 0.2;
  const auto cap = MakeSyntheticCap(o);
  // The plain fit is ruined by the outliers (so the robust test below can fail).
  const SphereFitSummary plain = FitSphere(cap.points);
  EXPECT_GT(std::abs(plain.sphere.radius_mm - kRadius) + (plain.sphere.center_mm - kCenter).norm(),
            0.5);
  for (RobustLoss loss : {RobustLoss::kCauchy, RobustLoss::kHuber}) {
    SphereFitOptions fo;
    fo.robust = true;
    fo.loss = loss;
    fo.inlier_threshold_mm = 0.25;
    const auto t0 = std::chrono::steady_clock::now();
    const SphereFitSummary s = FitSphere(cap.points, fo);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ExpectNearTruth(s, 0.01, 0.005);
    // Every true inlier within 5σ is kept; nearly every outlier is rejected (a few fall on the
    // shell by chance).
    int64_t kept_outliers = 0;
    for (size_t i = 0; i < cap.is_outlier.size(); ++i)
      kept_outliers += cap.is_outlier[i] && s.is_inlier[i];
    EXPECT_LT(kept_outliers, 340);  // < 1 % of the 34,000 outliers
    EXPECT_GT(s.n_inliers, 136000 - 50);
    EXPECT_NEAR(s.rms_mm, 0.05, 0.003);
    std::printf("%s (%.1f ms, %d MSAC samples)\n", s.BriefReport().c_str(), ms,
                s.ransac_iterations);
  }
}

// The reported σ (from σ̂²(JᵀJ)⁻¹) agree with the spread of 20 independent noisy draws.
TEST(SphereFit, ReportedSigmaMatchesMonteCarloSpread) {
  constexpr int kDraws = 20;
  std::vector<Eigen::Vector4d> est;
  Eigen::Vector4d mean_sigma = Eigen::Vector4d::Zero();
  for (int d = 0; d < kDraws; ++d) {
    const auto cap = MakeSyntheticCap(PaperCap(5000, 0.05, 100 + static_cast<uint64_t>(d)));
    const SphereFitSummary s = FitSphere(cap.points);
    ASSERT_TRUE(s.IsUsable());
    est.emplace_back(s.sphere.center_mm.x(), s.sphere.center_mm.y(), s.sphere.center_mm.z(),
                     s.sphere.radius_mm);
    mean_sigma += Eigen::Vector4d(s.sigma_center_mm.x(), s.sigma_center_mm.y(),
                                  s.sigma_center_mm.z(), s.sigma_radius_mm) /
                  kDraws;
  }
  Eigen::Vector4d truth(kCenter.x(), kCenter.y(), kCenter.z(), kRadius);
  for (int k = 0; k < 4; ++k) {
    // Spread about the known truth (unbiased estimator: divide by the number of draws).
    double ss = 0;
    for (const auto& e : est) ss += (e[k] - truth[k]) * (e[k] - truth[k]);
    const double spread = std::sqrt(ss / kDraws);
    const double ratio = mean_sigma[k] / spread;
    EXPECT_GT(ratio, 1 / 1.5) << "parameter " << k << " σ " << mean_sigma[k] << " spread "
                              << spread;
    EXPECT_LT(ratio, 1.5) << "parameter " << k << " σ " << mean_sigma[k] << " spread " << spread;
  }
}

TEST(SphereFit, ThirtyDegreeCapConverges) {
  auto o = PaperCap(20000, 0.0, 3);
  o.half_angle_deg = 30;
  o.axis = Eigen::Vector3d(0.3, -0.2, 1.0);
  // Noiseless: exact.
  SphereFitSummary s = FitSphere(MakeSyntheticCap(o).points);
  ExpectNearTruth(s, 1e-6, 1e-6);
  // Noisy: within 4σ of the truth, and σ small enough to be useful.
  o.noise_sigma_mm = 0.05;
  s = FitSphere(MakeSyntheticCap(o).points);
  ASSERT_TRUE(s.IsUsable()) << s.BriefReport();
  EXPECT_LT(s.sigma_radius_mm, 0.05);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(s.sphere.center_mm[k], kCenter[k], 4 * s.sigma_center_mm[k] + 1e-4) << k;
  EXPECT_NEAR(s.sphere.radius_mm, kRadius, 4 * s.sigma_radius_mm + 1e-4);
}

// One point's residual |p − c| − R, for the per-point reference problem.
struct OnePoint {
  Eigen::Vector3d p;
  template <typename T>
  bool operator()(const T* x, T* r) const {
    using std::sqrt;
    const T dx = T(p.x()) - x[0], dy = T(p.y()) - x[1], dz = T(p.z()) - x[2];
    r[0] = sqrt(dx * dx + dy * dy + dz * dz) - x[3];
    return true;
  }
};

TEST(SphereFit, RobustLossInsideChunksEqualsCeresPerPointLoss) {
  // Reference: one residual block per point with ceres::CauchyLoss / HuberLoss.
  auto o = PaperCap(3000, 0.05, 11);
  o.outlier_fraction = 0.1;
  const auto cap = MakeSyntheticCap(o);
  for (RobustLoss loss : {RobustLoss::kCauchy, RobustLoss::kHuber}) {
    SphereFitOptions fo;
    fo.robust = true;
    fo.loss = loss;
    fo.refit_inliers = false;
    const SphereFitSummary s = FitSphere(cap.points, fo);
    double x[4] = {s.sphere.center_mm.x() + 0.3, s.sphere.center_mm.y() - 0.2,
                   s.sphere.center_mm.z() + 0.1, s.sphere.radius_mm + 0.05};
    ceres::Problem problem;
    for (Eigen::Index i = 0; i < cap.points.cols(); ++i) {
      ceres::LossFunction* lf = loss == RobustLoss::kCauchy
                                    ? static_cast<ceres::LossFunction*>(new ceres::CauchyLoss(0.25))
                                    : new ceres::HuberLoss(0.25);
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<OnePoint, 1, 4>(new OnePoint{cap.points.col(i)}), lf, x);
    }
    ceres::Solver::Summary summary;
    ceres::Solve(internal::GeometricSolverOptions(200, 1), &problem, &summary);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(x[k], s.sphere.center_mm[k], 1e-6);
    EXPECT_NEAR(x[3], s.sphere.radius_mm, 1e-6);
  }
}

void ExpectInvalidPoints(const Eigen::Matrix3Xd& p, const std::string& part) {
  try {
    FitSphere(p);
    ADD_FAILURE() << "no exception for " << part;
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "points");
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(SphereFit, DegenerateInputRaises) {
  ExpectInvalidPoints(Eigen::Matrix3Xd::Random(3, 3), "at least 4 points, got 3");
  ExpectInvalidPoints(Eigen::Matrix3Xd::Constant(3, 10, 5.0), "all points are equal");
  Eigen::Matrix3Xd line(3, 10);
  for (int i = 0; i < 10; ++i)
    line.col(i) = Eigen::Vector3d(1, 2, 3) + i * Eigen::Vector3d(0.3, -1, 2);
  ExpectInvalidPoints(line, "collinear");
  // Points on a circle: coplanar (and concyclic), so every sphere through the circle fits.
  Eigen::Matrix3Xd circle(3, 12);
  for (int i = 0; i < 12; ++i)
    circle.col(i) = Eigen::Vector3d(50 * std::cos(i * 0.5), 50 * std::sin(i * 0.5), 7);
  ExpectInvalidPoints(circle, "coplanar");
  Eigen::Matrix3Xd nan = Eigen::Matrix3Xd::Random(3, 10);
  nan(1, 4) = NAN;
  ExpectInvalidPoints(nan, "non-finite");
  SphereFitOptions bad;
  bad.robust = true;
  bad.inlier_threshold_mm = 0;
  EXPECT_THROW(FitSphere(MakeSyntheticCap(PaperCap(100, 0, 1)).points, bad), InvalidInput);
}

TEST(SphereFit, NoisyPlaneIsNotAUsableSphere) {
  // Not exactly coplanar (noise), but no sphere is determined: the fit must say so.
  Eigen::Matrix3Xd p(3, 400);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0, 0.01);
  for (int i = 0; i < 400; ++i) p.col(i) = Eigen::Vector3d(i % 20, i / 20, g(rng));
  const SphereFitSummary s = FitSphere(p);
  EXPECT_FALSE(s.IsUsable()) << s.BriefReport();
}

TEST(SphereFit, FourPointSphere) {
  Sphere s;
  const Eigen::Vector3d c(1, 2, 3);
  ASSERT_TRUE(SphereFrom4Points(c + Eigen::Vector3d(5, 0, 0), c + Eigen::Vector3d(0, 5, 0),
                                c + Eigen::Vector3d(0, 0, 5), c + Eigen::Vector3d(-3, 4, 0), &s));
  EXPECT_NEAR((s.center_mm - c).norm(), 0, 1e-12);
  EXPECT_NEAR(s.radius_mm, 5, 1e-12);
  EXPECT_FALSE(SphereFrom4Points(c, c + Eigen::Vector3d(1, 0, 0), c + Eigen::Vector3d(0, 1, 0),
                                 c + Eigen::Vector3d(1, 1, 0), &s));
}

}  // namespace
}  // namespace porthole::fit
