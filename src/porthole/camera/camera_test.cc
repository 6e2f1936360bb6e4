// Proves the camera model: Project inverts Correction to 1e-9 mm over a full frame, the signs of
// the conventions (barrel K1 > 0 corrects outward, y up vs v down), Jet = double with derivatives
// = finite differences, and the OpenCV conversion round trip below 0.01 px RMS with barrel → k1 <
// 0.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "porthole/camera/brown.h"
#include "porthole/camera/opencv_model.h"
#include "porthole/camera/sensor.h"
#include "porthole/core/error.h"

namespace porthole::camera {
namespace {

// Nikon D300: 4288 × 2848 px, 5.5 µm pitch.
const Sensor kD300{4288, 2848, 0.0055};

// The paper's in-air calibration of the 24 mm lens (Table 6), radial terms only.
BrownParams PaperLens() {
  BrownParams p;
  p.c_mm = 25.801;
  p.x0_mm = -0.026;
  p.y0_mm = -0.144;
  p.K1 = 1.842e-4;
  p.K2 = -3.030e-7;
  return p;
}

// The same with decentring (Table 6) and an affinity/shear added.
BrownParams FullLens() {
  BrownParams p = PaperLens();
  p.P1 = 6.582e-6;
  p.P2 = 1.620e-5;
  p.B1 = 1e-4;
  p.B2 = -5e-5;
  return p;
}


// ---------------------------------------------------------------------------------------------
// Sensor and pixel conventions.

TEST(Sensor, CentrePixelIsOriginAndVDownIsYUp) {
  const double uc = (kD300.width_px - 1) / 2.0, vc = (kD300.height_px - 1) / 2.0;
  const Vec2<double> o = PixelToImageMm(kD300, uc, vc);
  EXPECT_EQ(o(0), 0.0);
  EXPECT_EQ(o(1), 0.0);
  // One pixel right is +pitch in x; one pixel down is −pitch in y.
  EXPECT_NEAR(PixelToImageMm(kD300, uc + 1, vc)(0), 0.0055, 1e-15);
  EXPECT_NEAR(PixelToImageMm(kD300, uc, vc + 1)(1), -0.0055, 1e-15);
  // The top-left pixel centre: x = −(W−1)/2·pitch, y = +(H−1)/2·pitch.
  const Vec2<double> tl = PixelToImageMm(kD300, 0.0, 0.0);
  EXPECT_NEAR(tl(0), -4287 / 2.0 * 0.0055, 1e-12);
  EXPECT_NEAR(tl(1), 2847 / 2.0 * 0.0055, 1e-12);
}

TEST(Sensor, PixelMmRoundTripAndColmapBoundary) {
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 7, 5)) {
    const Vec2<double> xy = PixelToImageMm(kD300, uv(0), uv(1));
    const Vec2<double> back = ImageMmToPixel(kD300, xy(0), xy(1));
    EXPECT_NEAR(back(0), uv(0), 1e-9);
    EXPECT_NEAR(back(1), uv(1), 1e-9);
  }
  // COLMAP's (0.5, 0.5) is our (0, 0), the centre of the top-left pixel.
  EXPECT_EQ(ColmapToPixel(Eigen::Vector2d(0.5, 0.5)), Eigen::Vector2d(0, 0));
  EXPECT_EQ(PixelToColmap(Eigen::Vector2d(0, 0)), Eigen::Vector2d(0.5, 0.5));
}

TEST(Sensor, InvalidSensorNamesTheField) {
  EXPECT_THROW(ValidateSensor({0, 10, 0.005}), InvalidInput);
  try {
    ValidateSensor({10, 10, -1});
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "pixel_pitch_mm");
  }
}

// ---------------------------------------------------------------------------------------------
// Brown–Conrady formulae against hand-computed values.

TEST(Brown, RadialCorrectionMatchesClosedForm) {
  const BrownParams p = PaperLens();
  // 10 mm right of the principal point: Δx = x̄ (K1 r² + K2 r⁴) = 10 (1.842e-2 − 3.03e-3).
  const Vec2<double> d = Correction(p, p.x0_mm + 10.0, p.y0_mm);
  EXPECT_NEAR(d(0), 10.0 * (1.842e-4 * 100 - 3.030e-7 * 1e4), 1e-15);
  EXPECT_NEAR(d(1), 0.0, 1e-18);
}

TEST(Brown, DecentringAndAffinityMatchClosedForm) {
  // x̄ = 3, ȳ = 4 (r² = 25): P1 gives Δx = P1 (25 + 18), Δy = 2 P1·12.
  BrownParams p;
  p.c_mm = 20;
  p.P1 = 1e-5;
  Vec2<double> d = Correction(p, 3.0, 4.0);
  EXPECT_NEAR(d(0), 43e-5, 1e-17);
  EXPECT_NEAR(d(1), 24e-5, 1e-17);
  // P2 gives Δx = 2 P2·12, Δy = P2 (25 + 32).
  p = BrownParams{};
  p.c_mm = 20;
  p.P2 = 1e-5;
  d = Correction(p, 3.0, 4.0);
  EXPECT_NEAR(d(0), 24e-5, 1e-17);
  EXPECT_NEAR(d(1), 57e-5, 1e-17);
  // B1, B2 act on x only: Δx = B1 x̄ + B2 ȳ.
  p = BrownParams{};
  p.c_mm = 20;
  p.B1 = 1e-3;
  p.B2 = -2e-3;
  d = Correction(p, 3.0, 4.0);
  EXPECT_NEAR(d(0), 3e-3 - 8e-3, 1e-17);
  EXPECT_EQ(d(1), 0.0);
}

TEST(Brown, BarrelLensCorrectsEdgePointsOutward) {
  const BrownParams p = PaperLens();  // K1 > 0: barrel in the correction convention
  ASSERT_GT(p.K1, 0);
  const Eigen::Vector2d pp(p.x0_mm, p.y0_mm);
  const double W = kD300.width_px - 1, H = kD300.height_px - 1;
  for (const auto& uv :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(W, 0), Eigen::Vector2d(0, H), Eigen::Vector2d(W, H),
        Eigen::Vector2d(W / 2, 0), Eigen::Vector2d(0, H / 2), Eigen::Vector2d(W, H / 2)}) {
    const Vec2<double> measured = PixelToImageMm(kD300, uv(0), uv(1));
    const Vec2<double> ideal = Undistort(p, measured(0), measured(1));
    EXPECT_GT((ideal - pp).norm(), (measured - pp).norm() + 0.05) << uv.transpose();
    // Radial: the correction is parallel to the radius vector.
    const Eigen::Vector2d rm = measured - pp, ri = ideal - pp;
    EXPECT_NEAR(rm(0) * ri(1) - rm(1) * ri(0), 0.0, 1e-12);
  }
}

TEST(Brown, UnprojectMatchesCollinearity) {
  // A point 100 mm right, 50 mm down, 1000 mm ahead, with no distortion: x̄ = c·X/Z, ȳ = −c·Y/Z.
  BrownParams p;
  p.c_mm = 25;
  p.x0_mm = 0.1;
  p.y0_mm = -0.2;
  const auto xy = Project(p, Vec3<double>(100, 50, 1000));
  ASSERT_TRUE(xy);
  EXPECT_NEAR((*xy)(0), 0.1 + 2.5, 1e-14);
  EXPECT_NEAR((*xy)(1), -0.2 - 1.25, 1e-14);  // Y down (50 mm below) → y up negative
  const Vec3<double> ray = Unproject(p, (*xy)(0), (*xy)(1));
  EXPECT_NEAR(ray(0) / ray(2), 0.1, 1e-15);
  EXPECT_NEAR(ray(1) / ray(2), 0.05, 1e-15);
  EXPECT_NEAR(ray.norm(), 1.0, 1e-15);
  // Behind the camera: no projection.
  EXPECT_FALSE(Project(p, Vec3<double>(0, 0, -1)));
}

// Measured → ray (Unproject) → Project must give back the measured point, and a projected point
// must satisfy the collinearity equations, over the whole frame.
void ExpectInverse(const BrownParams& p, const char* label) {
  double max_err = 0, max_colin = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 87, 58)) {
    const Vec2<double> m = PixelToImageMm(kD300, uv(0), uv(1));
    const Vec3<double> ray = Unproject(p, m(0), m(1));
    const auto back = Project(p, Vec3<double>(3000.0 * ray));  // a point 3 m along the ray
    ASSERT_TRUE(back) << uv.transpose();
    max_err = std::max(max_err, (*back - m).norm());
    // Collinearity at the projected point, evaluated with Correction only.
    const Vec3<double> X = 3000.0 * ray;
    const Vec2<double> d = Correction(p, (*back)(0), (*back)(1));
    max_colin = std::max(max_colin, std::hypot((*back)(0) - p.x0_mm + d(0) - p.c_mm * X(0) / X(2),
                                               (*back)(1) - p.y0_mm + d(1) + p.c_mm * X(1) / X(2)));
  }
  std::printf("[%s] max |Project(Unproject(m)) - m| = %.3g mm, max collinearity misfit = %.3g mm\n",
              label, max_err, max_colin);
  EXPECT_LT(max_err, 1e-9);
  EXPECT_LT(max_colin, 1e-9);
}

TEST(Brown, ProjectInvertsCorrectionOverTheFrame) {
  ExpectInverse(PaperLens(), "paper lens");
  ExpectInverse(FullLens(), "paper lens + P, B");
}

// ---------------------------------------------------------------------------------------------
// Jets and doubles.

constexpr int kNumDerivs = kBrownNumParams + 3;
using Jet = ceres::Jet<double, kNumDerivs>;

// Finite-difference steps: a small fraction of each parameter's typical size.
std::array<double, kNumDerivs> FdSteps(const std::array<double, kNumDerivs>& v) {
  const std::array<double, kNumDerivs> typical = {25,   0.1,  0.1,  1e-4, 1e-7, 1e-10, 1e-5,
                                                  1e-5, 1e-4, 1e-4, 100,  100,  1000};
  std::array<double, kNumDerivs> h;
  for (int i = 0; i < kNumDerivs; ++i) h[i] = 1e-5 * std::max(std::abs(v[i]), typical[i]);
  return h;
}

// f maps (params[10], X[3]) of scalar T to a 2-vector; checks Jet values = double values and Jet
// derivatives = central differences of the double evaluation (1e-6 relative).
template <typename F>
void ExpectJetMatchesDouble(const std::array<double, kNumDerivs>& v, F f) {
  std::array<Jet, kNumDerivs> vj;
  for (int i = 0; i < kNumDerivs; ++i) vj[i] = Jet(v[i], i);
  const Vec2<Jet> fj = f(vj);
  const Vec2<double> fd = f(v);
  const auto h = FdSteps(v);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(fj(k).a, fd(k), 1e-13 * (1 + std::abs(fd(k))));
    for (int i = 0; i < kNumDerivs; ++i) {
      auto vp = v, vm = v;
      vp[i] += h[i];
      vm[i] -= h[i];
      const double num = (f(vp)(k) - f(vm)(k)) / (2 * h[i]);
      // Relative 1e-6, with a floor at a 1e-13 mm change over the step (round-off of the FD).
      EXPECT_NEAR(fj(k).v(i), num, 1e-6 * std::abs(num) + 1e-13 / h[i])
          << "output " << k << " derivative " << i;
    }
  }
}

std::array<double, kNumDerivs> JetTestPoint(const BrownParams& p, const Vec3<double>& X) {
  std::array<double, kNumDerivs> v;
  const auto a = p.ToArray();
  std::copy(a.begin(), a.end(), v.begin());
  v[10] = X(0);
  v[11] = X(1);
  v[12] = X(2);
  return v;
}

TEST(Jet, CorrectionJetMatchesDoubleAndFiniteDifferences) {
  BrownParams p = FullLens();
  p.K3 = 2e-10;  // exercise every term
  // Use the point slots 10, 11 as the measured image point (mm); slot 12 unused.
  const auto v = JetTestPoint(p, Vec3<double>(9.0, -6.5, 1.0));
  ExpectJetMatchesDouble(v, [](const auto& a) {
    using T = std::decay_t<decltype(a[0])>;
    return Correction<T>(a.data(), a[10], a[11]);
  });
}

TEST(Jet, ProjectJetMatchesDoubleAndFiniteDifferences) {
  BrownParams p = FullLens();
  p.K3 = 2e-10;
  // A point imaged near the top-right corner (about 11 mm right, 7 mm up).
  const auto v = JetTestPoint(p, Vec3<double>(430, -280, 1000));
  ExpectJetMatchesDouble(v, [](const auto& a) {
    using T = std::decay_t<decltype(a[0])>;
    const auto xy = Project<T>(a.data(), Vec3<T>(a[10], a[11], a[12]));
    EXPECT_TRUE(xy);
    return xy ? *xy : Vec2<T>(T(0), T(0));
  });
}

TEST(Jet, ReprojectionResidualIsZeroAtTruthAndSignedProjectedMinusObserved) {
  const BrownParams p = FullLens();
  const Vec3<double> X(-300, 200, 1500);
  const auto xy = Project(p, X);
  ASSERT_TRUE(xy);
  auto params = p.ToArray();
  double point[3] = {X(0), X(1), X(2)};
  const double* blocks[2] = {params.data(), point};
  double r[2];
  std::unique_ptr<ceres::CostFunction> cost(
      BrownReprojectionResidual::Create((*xy)(0) - 0.01, (*xy)(1) + 0.02, 0.5));
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 0.01 / 0.5, 1e-12);
  EXPECT_NEAR(r[1], -0.02 / 0.5, 1e-12);

  // Bundle form: rotate 90° about Z (angle-axis (0, 0, π/2)): R·(a, b, c) = (−b, a, c). Choose
  // point_in_world so that R·p + t = X.
  const double aa[3] = {0, 0, M_PI / 2};
  const double t[3] = {10, -20, 30};
  const double pw[3] = {X(1) - t[1], -(X(0) - t[0]), X(2) - t[2]};
  const double* bblocks[4] = {params.data(), aa, t, pw};
  std::unique_ptr<ceres::CostFunction> bcost(BrownBundleResidual::Create((*xy)(0), (*xy)(1)));
  ASSERT_TRUE(bcost->Evaluate(bblocks, r, nullptr));
  EXPECT_NEAR(r[0], 0.0, 1e-10);
  EXPECT_NEAR(r[1], 0.0, 1e-10);
}

// ---------------------------------------------------------------------------------------------
// OpenCV.

TEST(OpenCV, ForwardModelMatchesHandComputedPoint) {
  // fx 1000, fy 1100, cx 640, cy 480, k1 −0.1, k2 0.01, p1 0.001, p2 −0.002, k3 0.001;
  // X/Z = 0.3, Y/Z = −0.2: r² = 0.13, radial = 1 − 0.013 + 0.000169 + 0.000002197 = 0.987171197,
  // x_d = 0.3·radial + 2·0.001·(−0.06) − 0.002·(0.13 + 0.18) = 0.2954113591,
  // y_d = −0.2·radial + 0.001·(0.13 + 0.08) + 2·(−0.002)·(−0.06) = −0.1969842394,
  // u = 1000 x_d + 640 = 935.4113591, v = 1100 y_d + 480 = 263.31733666.
  const OpenCVParams o{1000, 1100, 640, 480, -0.1, 0.01, 0.001, -0.002, 0.001};
  const auto a = o.ToArray();
  const auto uv = OpenCVProject(a.data(), Vec3<double>(0.6, -0.4, 2.0));
  ASSERT_TRUE(uv);
  EXPECT_NEAR((*uv)(0), 935.4113591, 1e-9);
  EXPECT_NEAR((*uv)(1), 263.31733666, 1e-9);
  // And its inverse.
  const auto n = OpenCVUnprojectNormalized(o, 935.4113591, 263.31733666);
  ASSERT_TRUE(n);
  EXPECT_NEAR((*n)(0), 0.3, 1e-10);
  EXPECT_NEAR((*n)(1), -0.2, 1e-10);
}

TEST(OpenCV, ClosedFormSigns) {
  BrownParams b = PaperLens();
  b.x0_mm = 0.11;  // principal point right of and above the sensor centre
  b.y0_mm = 0.22;
  const OpenCVParams o = BrownToOpenCVClosedForm(b, kD300);
  EXPECT_LT(o.k1, 0);  // barrel: K1 > 0 (correction) ↔ k1 < 0 (forward)
  EXPECT_NEAR(o.fx, 25.801 / 0.0055, 1e-9);
  EXPECT_NEAR(o.cx, 4287 / 2.0 + 20, 1e-9);
  EXPECT_NEAR(o.cy, 2847 / 2.0 - 40, 1e-9);  // y0 up ↔ cy smaller (v down)
  // Closed forms invert each other.
  const BrownParams back = OpenCVToBrownClosedForm(o, kD300);
  EXPECT_NEAR(back.c_mm, b.c_mm, 1e-12);
  EXPECT_NEAR(back.x0_mm, b.x0_mm, 1e-12);
  EXPECT_NEAR(back.y0_mm, b.y0_mm, 1e-12);
  EXPECT_NEAR(back.K1, b.K1, 1e-16);
  EXPECT_NEAR(back.K2, b.K2, 1e-19);
}

// Independent check of a conversion: the image distance (px) between the two models' pixels for
// the same ray, on a grid finer than and offset from the refit grid.
struct Discrepancy {
  double rms = 0, max = 0;
};
Discrepancy BrownVsOpenCV(const BrownParams& b, const OpenCVParams& o) {
  const auto oa = o.ToArray();
  double sum2 = 0, mx = 0;
  int n = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 97, 61)) {
    const Vec2<double> m = PixelToImageMm(kD300, uv(0), uv(1));
    const auto cv = OpenCVProject(oa.data(), Unproject(b, m(0), m(1)));
    const double d = (*cv - uv).norm();
    sum2 += d * d;
    mx = std::max(mx, d);
    ++n;
  }
  return {std::sqrt(sum2 / n), mx};
}

// Brown → OpenCV → Brown. max_rms_px bounds both refits; max_round_trip_px bounds the image
// distance between the original and the returned Brown model for the same ray.
void ExpectRoundTrip(const BrownParams& b, const char* label, double max_rms_px = 0.01,
                     double max_round_trip_px = 0.05) {
  const BrownToOpenCVResult to = BrownToOpenCV(b, kD300);
  const Discrepancy d1 = BrownVsOpenCV(b, to.opencv);
  const OpenCVToBrownResult from = OpenCVToBrown(to.opencv, kD300);
  const Discrepancy d2 = BrownVsOpenCV(from.brown, to.opencv);
  std::printf(
      "[%s] Brown->OpenCV refit rms %.3g px max %.3g px (check grid rms %.3g max %.3g); "
      "OpenCV->Brown refit rms %.3g px max %.3g px (check grid rms %.3g max %.3g)\n"
      "  opencv fx %.6f fy %.6f cx %.6f cy %.6f k1 %.6g k2 %.6g p1 %.6g p2 %.6g k3 %.6g\n"
      "  brown  c %.6f x0 %.6f y0 %.6f K1 %.6g K2 %.6g K3 %.6g P1 %.6g P2 %.6g B1 %.6g B2 %.6g\n",
      label, to.fit.rms_px, to.fit.max_px, d1.rms, d1.max, from.fit.rms_px, from.fit.max_px, d2.rms,
      d2.max, to.opencv.fx, to.opencv.fy, to.opencv.cx, to.opencv.cy, to.opencv.k1, to.opencv.k2,
      to.opencv.p1, to.opencv.p2, to.opencv.k3, from.brown.c_mm, from.brown.x0_mm, from.brown.y0_mm,
      from.brown.K1, from.brown.K2, from.brown.K3, from.brown.P1, from.brown.P2, from.brown.B1,
      from.brown.B2);
  EXPECT_EQ(to.fit.num_points, 40 * 30);
  EXPECT_LT(to.fit.rms_px, max_rms_px);
  EXPECT_LT(d1.rms, max_rms_px);
  EXPECT_LT(from.fit.rms_px, 0.01);
  EXPECT_LT(d2.rms, 0.01);
  // Barrel stays barrel; the principal point maps by the closed form (it is not a fit artefact).
  EXPECT_LT(to.opencv.k1, 0);
  EXPECT_GT(from.brown.K1, 0);
  EXPECT_NEAR(to.opencv.cx, 4287 / 2.0 + b.x0_mm / 0.0055, 0.5);
  EXPECT_NEAR(to.opencv.cy, 2847 / 2.0 - b.y0_mm / 0.0055, 0.5);
  // Round trip: the returned Brown model images every ray where the original does.
  double max_rt = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 97, 61)) {
    const Vec2<double> m = PixelToImageMm(kD300, uv(0), uv(1));
    const auto back = Project(from.brown, Unproject(b, m(0), m(1)));
    ASSERT_TRUE(back);
    max_rt = std::max(max_rt, (*back - m).norm() / kD300.pixel_pitch_mm);
  }
  std::printf("  round trip Brown->OpenCV->Brown max image difference %.3g px\n", max_rt);
  EXPECT_LT(max_rt, max_round_trip_px);
}

TEST(OpenCV, RoundTripPaperLens) { ExpectRoundTrip(PaperLens(), "paper lens"); }
TEST(OpenCV, RoundTripWithDecentringAndAffinity) {
  BrownParams b = FullLens();
  b.B2 = 0;  // OpenCV has no shear term: see ShearIsNotRepresentable
  ExpectRoundTrip(b, "paper lens + P1, P2, B1");
}

TEST(OpenCV, ShearIsNotRepresentable) {
  // OpenCV's x_d has no term linear in y alone, so Brown's shear Δx = B2·ȳ stays in the residual:
  // the refit RMS is the RMS of B2·ȳ over the refit grid (in px), and the way back returns B2 ≈ 0.
  const BrownParams b = FullLens();
  double sum2 = 0;
  int n = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 40, 30)) {
    const double yb = PixelToImageMm(kD300, uv(0), uv(1))(1) - b.y0_mm;
    sum2 += std::pow(b.B2 * yb / kD300.pixel_pitch_mm, 2);
    ++n;
  }
  const double bound_px = std::sqrt(sum2 / n);
  const BrownToOpenCVResult to = BrownToOpenCV(b, kD300);
  std::printf("[shear B2 = %g] Brown->OpenCV refit rms %.4g px, predicted %.4g px\n", b.B2,
              to.fit.rms_px, bound_px);
  EXPECT_NEAR(to.fit.rms_px, bound_px, 0.15 * bound_px);
  const OpenCVToBrownResult from = OpenCVToBrown(to.opencv, kD300);
  EXPECT_LT(from.fit.rms_px, 0.01);
  EXPECT_NEAR(from.brown.B2, 0.0, 0.02 * std::abs(b.B2));
  EXPECT_NEAR(from.brown.B1, b.B1, 0.02 * std::abs(b.B1));
  // Everything else survives the trip.
  ExpectRoundTrip(b, "paper lens + P, B (with shear)", 1.15 * bound_px,
                  0.05 + std::abs(b.B2) * 2848 / 2.0);
}

TEST(OpenCV, DecentringSignsSurviveTheRefit) {
  // Brown P1 > 0 ↔ OpenCV p2 < 0; Brown P2 > 0 ↔ OpenCV p1 > 0 (y up vs Y down, correction vs
  // forward). Checked on the refit, so the closed form's signs are tested against least squares.
  BrownParams b = PaperLens();
  // The closed form (p1 = P2·c, p2 = −P1·c) agrees with the refit to first order (20 %).
  b.P1 = 2e-5;
  BrownToOpenCVResult r = BrownToOpenCV(b, kD300);
  EXPECT_LT(r.opencv.p2, -0.5 * 2e-5 * b.c_mm);
  EXPECT_NEAR(r.opencv.p1, 0.0, 0.1 * 2e-5 * b.c_mm);
  EXPECT_NEAR(r.initial.p2, r.opencv.p2, 0.2 * std::abs(r.opencv.p2));
  b.P1 = 0;
  b.P2 = 2e-5;
  r = BrownToOpenCV(b, kD300);
  EXPECT_GT(r.opencv.p1, 0.5 * 2e-5 * b.c_mm);
  EXPECT_NEAR(r.opencv.p2, 0.0, 0.1 * 2e-5 * b.c_mm);
  EXPECT_NEAR(r.initial.p1, r.opencv.p1, 0.2 * std::abs(r.opencv.p1));
  // And the way back recovers Brown's signs.
  const OpenCVToBrownResult back = OpenCVToBrown(r.opencv, kD300);
  EXPECT_NEAR(back.brown.P2, 2e-5, 0.02 * 2e-5);
  EXPECT_NEAR(back.brown.P1, 0.0, 0.02 * 2e-5);
}

TEST(OpenCV, InvalidInputsAreRejected) {
  BrownParams b = PaperLens();
  b.c_mm = 0;
  EXPECT_THROW(BrownToOpenCV(b, kD300), InvalidInput);
  CameraConversionOptions opt;
  opt.grid_cols = 2;
  EXPECT_THROW(BrownToOpenCV(PaperLens(), kD300, opt), InvalidInput);
  EXPECT_THROW(OpenCVToBrown(OpenCVParams{}, kD300), InvalidInput);  // fx = 0
}

TEST(OpenCVConversion, StronglyDistortedLensStaysFiniteAndCountsCorners) {
  // OpenCV's sample calibration of its left01..left14 chessboards (Debian opencv-doc,
  // examples/data/left_intrinsics.yml): k3 = 0.238 makes Brown's K1..K3 correction non-invertible
  // in the extreme corners. The refit must stay finite and say how many grid points it lost.
  const OpenCVParams o{535.91573396163199, 535.91573396163199, 342.28315473308373, 235.57082909788173,
                       -2.6637260909660682e-01, -3.8588898922304653e-02, 1.7831947042852964e-03,
                       -2.8122100441115472e-04, 2.3839153080878486e-01};
  CameraConversionOptions opt;
  opt.fit_k3 = true;
  const auto r = OpenCVToBrown(o, Sensor{640, 480, 1.0}, opt);
  EXPECT_TRUE(std::isfinite(r.fit.rms_px));
  EXPECT_LT(r.fit.rms_px, 0.2);
  EXPECT_LT(r.fit.num_not_projected, r.fit.num_points / 50);  // a few corner points at most
  EXPECT_NEAR(r.brown.c_mm, o.fx, 0.01 * o.fx);
  EXPECT_GT(r.brown.K1, 0);  // barrel (k1 < 0 in OpenCV's forward sense)
}

}  // namespace
}  // namespace porthole::camera
