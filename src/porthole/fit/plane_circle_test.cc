// Proves plane and 3D circle fits recover synthetic flange targets, that their reported σ match
// the Monte-Carlo spread, and that degenerate target sets raise.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "porthole/core/error.h"
#include "porthole/fit/plane_fit.h"

namespace porthole::fit {
namespace {

// n targets on a circle (centre c, unit normal nrm, radius r) with isotropic noise σ.
Eigen::Matrix3Xd CircleTargets(const Eigen::Vector3d& c, const Eigen::Vector3d& nrm, double r,
                               int n, double sigma, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, sigma);
  const Eigen::Vector3d u = nrm.unitOrthogonal(), v = nrm.cross(u);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n + 0.1;
    p.col(i) =
        c + r * (std::cos(a) * u + std::sin(a) * v) + Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  return p;
}

const Eigen::Vector3d kC(3.0, -2.0, 41.0);
const Eigen::Vector3d kN = Eigen::Vector3d(0.05, -0.03, 1.0).normalized();

TEST(PlaneFit, RecoversPlaneAndOrientsNormal) {
  const Eigen::Matrix3Xd p = CircleTargets(kC, kN, 45, 24, 0.0, 1);
  PlaneFitSummary s = FitPlane(p, {.normal_hint = Eigen::Vector3d(0, 0, -1)});
  EXPECT_NEAR(s.plane.normal.dot(-kN), 1.0, 1e-12);
  EXPECT_NEAR(s.plane.offset_mm, -kN.dot(kC), 1e-9);
  s = FitPlane(p);  // default: largest component positive
  EXPECT_NEAR(s.plane.normal.dot(kN), 1.0, 1e-12);
  EXPECT_LT(s.max_abs_residual_mm, 1e-9);
}

TEST(PlaneFit, SigmaMatchesMonteCarlo) {
  constexpr int kDraws = 400;
  double ss_tilt = 0, ss_off = 0, sig_tilt = 0, sig_off = 0;
  for (int d = 0; d < kDraws; ++d) {
    const PlaneFitSummary s = FitPlane(CircleTargets(kC, kN, 45, 16, 0.02, 10 + d));
    ss_tilt += (s.plane.normal - kN).squaredNorm();
    ss_off += std::pow(s.plane.offset_mm - kN.dot(kC), 2);
    sig_tilt += s.sigma_tilt_rad / kDraws;
    sig_off += s.sigma_offset_mm / kDraws;
  }
  EXPECT_NEAR(sig_tilt / std::sqrt(ss_tilt / kDraws), 1.0, 0.2);
  EXPECT_NEAR(sig_off / std::sqrt(ss_off / kDraws), 1.0, 0.2);
}

TEST(PlaneFit, DegenerateRaises) {
  EXPECT_THROW(FitPlane(Eigen::Matrix3Xd::Random(3, 2)), InvalidInput);
  EXPECT_THROW(FitPlane(Eigen::Matrix3Xd::Constant(3, 5, 1.0)), InvalidInput);
  Eigen::Matrix3Xd line(3, 5);
  for (int i = 0; i < 5; ++i) line.col(i) = kC + i * kN;
  EXPECT_THROW(FitPlane(line), InvalidInput);
  // Three points: an exact plane, no σ.
  const PlaneFitSummary three = FitPlane(CircleTargets(kC, kN, 45, 3, 0.0, 1));
  EXPECT_FALSE(three.IsUsable());
  EXPECT_NEAR(std::abs(three.plane.normal.dot(kN)), 1.0, 1e-12);
}

TEST(CircleFit, RecoversFlangeCircle) {
  const CircleFitSummary exact = FitCircle3d(CircleTargets(kC, kN, 45, 24, 0.0, 1));
  ASSERT_TRUE(exact.IsUsable()) << exact.BriefReport();
  EXPECT_LT((exact.circle.center_mm - kC).norm(), 1e-9);
  EXPECT_NEAR(exact.circle.radius_mm, 45, 1e-9);
  EXPECT_NEAR(exact.circle.normal.dot(kN), 1.0, 1e-12);
  // A partial arc (targets over 120°) still converges from the algebraic start.
  Eigen::Matrix3Xd arc = CircleTargets(kC, kN, 45, 36, 0.0, 1).leftCols(12);
  const CircleFitSummary a = FitCircle3d(arc);
  EXPECT_LT((a.circle.center_mm - kC).norm(), 1e-8);
}

TEST(CircleFit, SigmaMatchesMonteCarlo) {
  constexpr int kDraws = 400;
  Eigen::Vector4d ss = Eigen::Vector4d::Zero(), sig = Eigen::Vector4d::Zero();
  for (int d = 0; d < kDraws; ++d) {
    const CircleFitSummary s = FitCircle3d(CircleTargets(kC, kN, 45, 16, 0.02, 1000 + d));
    ASSERT_TRUE(s.IsUsable());
    const Eigen::Vector3d dc = s.circle.center_mm - kC;
    ss += Eigen::Vector4d(dc.x() * dc.x(), dc.y() * dc.y(), dc.z() * dc.z(),
                          std::pow(s.circle.radius_mm - 45, 2));
    sig += Eigen::Vector4d(s.sigma_center_mm.x(), s.sigma_center_mm.y(), s.sigma_center_mm.z(),
                           s.sigma_radius_mm) /
           kDraws;
  }
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(sig[k] / std::sqrt(ss[k] / kDraws), 1.0, 0.25) << k;
}

TEST(CircleFit, DegenerateRaises) {
  Eigen::Matrix3Xd line(3, 6);
  for (int i = 0; i < 6; ++i) line.col(i) = kC + i * Eigen::Vector3d(1, 2, 0);
  try {
    FitCircle3d(line);
    ADD_FAILURE();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos);
  }
  EXPECT_THROW(FitCircle3d(Eigen::Matrix3Xd::Random(3, 2)), InvalidInput);
  const CircleFitSummary three = FitCircle3d(CircleTargets(kC, kN, 45, 3, 0.0, 1));
  EXPECT_FALSE(three.IsUsable());
  EXPECT_NEAR(three.circle.radius_mm, 45, 1e-9);
}

}  // namespace
}  // namespace porthole::fit
