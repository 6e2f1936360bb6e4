// Proves the analytic Jacobians of the calibration residuals (residual.h) equal automatic
// differentiation through camera/brown.h (Jets) and central finite differences, in both forms, for
// large, small and zero rotations, and that the reduced-camera covariance equals Ceres's.
#include "porthole/calib/residual.h"

#include <gtest/gtest.h>

#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/synthetic.h"

namespace porthole::calib {
namespace {

using camera::kBrownNumParams;

// The paper's in-water camera (Table 6) with every additional parameter non-zero, so that each
// Jacobian column is exercised; a 5.5 µm pitch.
constexpr double kPitch = 0.0055;
const std::array<double, kBrownNumParams> kCamera = {26.2,    -0.058, -0.207,  1.66e-4, -2.58e-7,
                                                     3.0e-10, 6.6e-6, 1.62e-5, 2.0e-4,  -1.0e-4};
// Arbitrary positive scales (the adjustment's are the half-diagonal powers).
const CameraScales kScales = {10, 10, 10, 1e-3, 1e-5, 1e-8, 1e-5, 1e-5, 1e-3, 1e-3};

struct Case {
  std::array<double, 3> rotation, translation, point;
  double x_mm, y_mm;  // observation: near the projection, off by a few px
};

std::vector<Case> Cases() {
  return {
      {{0.3, -0.2, 0.1}, {-150, 80, 900}, {200, 125, 0}, 0, 0},
      {{1e-7, -2e-7, 5e-8}, {-100, -70, 700}, {25, 50, 0}, 0, 0},  // below the series threshold
      {{0, 0, 0}, {-300, -200, 600}, {40, 10, 0}, 0, 0},              // identity: corner of image
      {{-0.6, 0.4, 2.5}, {50, 20, 1200}, {100, 175, 3}, 0, 0},       // large angle, off-plane point
  };
}

// Observations a few pixels from the projection, so the residuals are not zero.
void PlaceObservations(std::vector<Case>* cases) {
  for (auto& c : *cases) {
    double r[2];
    std::array<double, kBrownNumParams> scaled;
    for (int i = 0; i < kBrownNumParams; ++i) scaled[i] = kCamera[i] / kScales[i];
    ASSERT_TRUE(EvaluateResidual<Form::kProject>(scaled.data(), kScales, c.rotation.data(),
                                                 c.translation.data(), c.point.data(), 0, 0,
                                                 kPitch, r, nullptr, nullptr, nullptr, nullptr));
    c.x_mm = r[0] * kPitch + 3 * kPitch;
    c.y_mm = r[1] * kPitch - 2 * kPitch;
  }
}

// Value-only residual for Ceres's numeric differentiation.
template <Form kForm>
struct ValueOnly {
  double x_mm, y_mm;
  bool operator()(const double* cam, const double* rot, const double* tr, const double* pt,
                  double* r) const {
    return EvaluateResidual<kForm>(cam, kScales, rot, tr, pt, x_mm, y_mm, kPitch, r, nullptr,
                                   nullptr, nullptr, nullptr);
  }
};

// Evaluates `cost` (blocks camera, rotation, translation, point) and returns its 2×19 Jacobian.
Eigen::Matrix<double, 2, 19> Jacobian(const ceres::CostFunction& cost, const Case& c,
                                      Eigen::Vector2d* residual) {
  std::array<double, kBrownNumParams> scaled;
  for (int i = 0; i < kBrownNumParams; ++i) scaled[i] = kCamera[i] / kScales[i];
  const double* params[] = {scaled.data(), c.rotation.data(), c.translation.data(),
                            c.point.data()};
  Eigen::Matrix<double, 2, kBrownNumParams, Eigen::RowMajor> jc;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> jr, jt, jp;
  double* jac[] = {jc.data(), jr.data(), jt.data(), jp.data()};
  EXPECT_TRUE(cost.Evaluate(params, residual->data(), jac));
  Eigen::Matrix<double, 2, 19> j;
  j << jc, jr, jt, jp;
  return j;
}

template <Form kForm>
void CheckForm() {
  auto cases = Cases();
  PlaceObservations(&cases);
  for (const auto& c : cases) {
    const AnalyticResidual<kForm, true> analytic(c.x_mm, c.y_mm, kPitch, kScales,
                                                 Eigen::Vector3d::Zero());
    const ceres::AutoDiffCostFunction<AutoDiffResidual<kForm>, 2, kBrownNumParams, 3, 3, 3> jets(
        new AutoDiffResidual<kForm>{c.x_mm, c.y_mm, kPitch, kScales});
    ceres::NumericDiffOptions nd;
    nd.relative_step_size = 1e-6;
    const ceres::NumericDiffCostFunction<ValueOnly<kForm>, ceres::CENTRAL, 2, kBrownNumParams, 3,
                                         3, 3>
        numeric(new ValueOnly<kForm>{c.x_mm, c.y_mm}, ceres::TAKE_OWNERSHIP, 2, nd);
    Eigen::Vector2d ra, rj, rn;
    const auto ja = Jacobian(analytic, c, &ra);
    const auto jj = Jacobian(jets, c, &rj);
    const auto jn = Jacobian(numeric, c, &rn);
    EXPECT_GT(ra.norm(), 1.0);  // px: a real residual, not the optimum
    EXPECT_NEAR((ra - rj).norm(), 0, 1e-9);
    // Ceres's angle-axis formula loses ~ε/θ of relative precision in its Jets at small angles θ
    // (cancellation in 1 − cos θ); the analytic series does not.
    const double theta = Eigen::Vector3d(c.rotation.data()).norm();
    const double jet_tol = 1e-9 + (theta > 0 ? 1e-15 / theta : 0);
    for (int k = 0; k < 19; ++k) {
      const double scale = std::max(1.0, jj.col(k).norm());
      EXPECT_NEAR((ja.col(k) - jj.col(k)).norm() / scale, 0, jet_tol) << "column " << k;
      EXPECT_NEAR((ja.col(k) - jn.col(k)).norm() / scale, 0, 1e-5) << "column " << k;
    }
    // The fixed-point cost is the same residual without the point block.
    const AnalyticResidual<kForm, false> fixed(c.x_mm, c.y_mm, kPitch, kScales,
                                               Eigen::Vector3d(c.point.data()));
    std::array<double, kBrownNumParams> scaled;
    for (int i = 0; i < kBrownNumParams; ++i) scaled[i] = kCamera[i] / kScales[i];
    const double* params[] = {scaled.data(), c.rotation.data(), c.translation.data()};
    Eigen::Vector2d rf;
    RowJacobianCamera jc;
    RowJacobian3 jr, jt;
    double* jac[] = {jc.data(), jr.data(), jt.data()};
    ASSERT_TRUE(fixed.Evaluate(params, rf.data(), jac));
    EXPECT_NEAR((rf - ra).norm(), 0, 1e-12);
    EXPECT_NEAR((jc - ja.template leftCols<kBrownNumParams>()).norm(), 0, 1e-12);
  }
}

TEST(ResidualTest, ImageResidualJacobianMatchesJetsAndFiniteDifferences) {
  CheckForm<Form::kProject>();
}

TEST(ResidualTest, CorrectionResidualJacobianMatchesJetsAndFiniteDifferences) {
  CheckForm<Form::kCorrect>();
}

TEST(ResidualTest, ParamJacobianIsTheCorrectionBasis) {
  // Correction = CorrectionParamJacobian · (K1 … B2): Δ is linear in the additional parameters.
  const double x = 9.3, y = -5.1;
  const auto b = camera::CorrectionParamJacobian<double>(kCamera.data(), x, y);
  const Eigen::Map<const Eigen::Matrix<double, camera::kBrownNumAdditional, 1>> add(
      kCamera.data() + camera::kBrownK1);
  const camera::Vec2<double> d = camera::Correction<double>(kCamera.data(), x, y);
  EXPECT_NEAR((b * add - d).norm(), 0, 1e-15);
}

TEST(ResidualTest, ReducedCameraCovarianceEqualsCeres) {
  SyntheticOptions so;
  so.camera = camera::FromBrown(
      {26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0}, {4288, 2848, kPitch});
  so.target = ParseTarget("chessboard:13x9:40");
  so.n_images = 12;
  so.noise_px = 0.3;
  const auto set = MakeSyntheticSet(so);
  CalibrationOptions o;
  o.pixel_pitch_mm = kPitch;
  o.reject_k = 0;
  o.free = ParseFreeParameters(camera::CameraModelId::kBrown, "all");  // every column, including the weak K3, B1, B2
  const auto fast = Calibrate(set.detections, so.target, o);
  o.ceres_covariance = true;
  const auto ref = Calibrate(set.detections, so.target, o);
  ASSERT_TRUE(fast.covariance_ok && ref.covariance_ok) << fast.message << ref.message;
  for (int i = 0; i < kBrownNumParams; ++i) {
    EXPECT_NEAR(fast.sigma[i] / ref.sigma[i], 1, 1e-6) << camera::kBrownParamInfo[i].name;
    for (int j = 0; j < kBrownNumParams; ++j) {
      EXPECT_NEAR(fast.correlation(i, j), ref.correlation(i, j), 1e-6);
    }
  }
}

}  // namespace
}  // namespace porthole::calib
