// Proves the calibration comparison: the χ² survival function against closed forms and table
// values, the paper's Table 6 (air vs water) differences, curves and maps from the published
// parameters, that the χ² test accepts two calibrations of one camera and rejects a changed one, and
// that it tests only the parameters both calibrations adjusted (one adjusted in one only is listed).
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "porthole/calib/compare.h"
#include "porthole/calib/synthetic.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

TEST(CompareTest, ChiSquareSurvival) {
  for (double x : {0.1, 1.0, 4.0, 20.0}) {  // 2 degrees of freedom: exp(−x/2)
    EXPECT_NEAR(UpperIncompleteGammaQ(1.0, 0.5 * x), std::exp(-0.5 * x), 1e-12);
  }
  // Critical values of χ² at 5 % (any statistics table): 1 dof 3.841, 7 dof 14.067.
  EXPECT_NEAR(UpperIncompleteGammaQ(0.5, 0.5 * 3.841), 0.05, 1e-4);
  EXPECT_NEAR(UpperIncompleteGammaQ(3.5, 0.5 * 14.067), 0.05, 1e-4);
}

// The paper's Table 6 as two records (diagonal covariance from the published σ; empty = not
// adjusted), on the D300 sensor (4288×2848 px, 5.5 µm).
std::pair<CalibrationRecord, CalibrationRecord> Table6() {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/menna2016_table6.csv");
  std::string line;
  nlohmann::json air = {{"camera", nlohmann::json::object()}, {"sigma", nlohmann::json::object()}};
  nlohmann::json water = air;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("parameter", 0) == 0) continue;
    std::stringstream ss(line);
    std::string key, av, as, wv, ws;
    std::getline(ss, key, ',');
    std::getline(ss, av, ',');
    std::getline(ss, as, ',');
    std::getline(ss, wv, ',');
    std::getline(ss, ws, ',');
    if (!av.empty()) air["camera"][key] = std::stod(av), air["sigma"][key] = std::stod(as);
    if (!wv.empty()) water["camera"][key] = std::stod(wv), water["sigma"][key] = std::stod(ws);
  }
  const nlohmann::json sensor = {{"width_px", 4288}, {"height_px", 2848}, {"pixel_pitch_mm", 0.0055}};
  air["sensor"] = water["sensor"] = sensor;
  return {CalibrationFromJson(air, "air"), CalibrationFromJson(water, "water")};
}

// A calibration whose format holds no σ (OpenCV YAML, COLMAP, mrcal: covariance NaN, unknown):
// the table shows no σ and no z for it, and no χ² is computed. (Before, its σ counted as 0, so
// z = Δ/σ_other alone looked significant.)
TEST(CompareTest, UnknownSigmaIsNotZero) {
  auto [air, water] = Table6();
  water.covariance.setConstant(NAN);
  water.has_covariance = false;
  water.covariance_note = "σ unknown: opencv-yaml holds none";
  const auto r = Compare(air, water);
  const auto& c = r.rows[camera::kBrownC];
  EXPECT_NEAR(c.sigma_a, 0.006, 1e-12);  // Table 6, in air
  EXPECT_TRUE(std::isnan(c.sigma_b));
  EXPECT_TRUE(std::isnan(c.sigma_diff));
  EXPECT_TRUE(std::isnan(c.z));
  EXPECT_TRUE(std::isnan(r.chi2));
  EXPECT_FALSE(r.significant);
  EXPECT_NE(r.covariance_note.find("opencv-yaml holds none"), std::string::npos) << r.covariance_note;
  // A record that says it has a covariance but leaves an adjusted σ at 0: unknown too.
  auto [a2, b2] = Table6();
  b2.covariance(camera::kBrownK1, camera::kBrownK1) = 0;
  const auto r2 = Compare(a2, b2);
  EXPECT_TRUE(std::isnan(r2.rows[camera::kBrownK1].z));
  EXPECT_TRUE(std::isnan(r2.chi2));
}

TEST(CompareTest, PaperTable6AirVersusWater) {
  const auto [air, water] = Table6();
  ASSERT_TRUE(air.has_covariance && water.has_covariance);
  EXPECT_FALSE(air.free[camera::kBrownP1]);  // not significant in air (Table 6 "-")
  EXPECT_TRUE(water.free[camera::kBrownP1]);
  const auto r = Compare(air, water);
  const auto& c = r.rows[camera::kBrownC];
  EXPECT_NEAR(c.diff, 26.208 - 25.801, 1e-12);
  EXPECT_NEAR(c.sigma_diff, std::hypot(0.006, 0.002), 1e-12);
  const auto& p1 = r.rows[camera::kBrownP1];  // adjusted in water only: its σ alone, not tested
  EXPECT_NEAR(p1.sigma_diff, 1.2e-6, 1e-15);
  EXPECT_FALSE(p1.tested);
  EXPECT_TRUE(std::isnan(p1.z));
  EXPECT_EQ(p1.left_out, "adjusted in B only");
  // Diagonal covariance: χ² is the sum of z² over the 5 parameters adjusted in both (c, x0, y0,
  // K1, K2); P1 and P2, adjusted under water only, are left out and named.
  double chi2 = 0;
  for (const auto& row : r.rows)
    if (row.adjusted_a && row.adjusted_b) chi2 += row.z * row.z;
  EXPECT_EQ(r.dof, 5);
  EXPECT_EQ(r.tested, (std::vector<int>{camera::kBrownC, camera::kBrownX0, camera::kBrownY0,
                                        camera::kBrownK1, camera::kBrownK2}));
  EXPECT_EQ(r.left_out, (std::vector<int>{camera::kBrownP1, camera::kBrownP2}));
  EXPECT_NE(r.left_out_note.find("P1, P2 (adjusted in B only)"), std::string::npos) << r.left_out_note;
  EXPECT_NEAR(r.chi2, chi2, 1e-9 * chi2);
  EXPECT_TRUE(r.significant);  // c alone moves by 64σ
  // Fig. 14 (a): δr(10 mm) = K1·10³ + K2·10⁵ in mm; barrel (> 0) in both, less in water.
  for (const auto& p : r.curves) {
    const double r3 = std::pow(p.r_mm, 3), r5 = std::pow(p.r_mm, 5);
    EXPECT_NEAR(p.radial_a_um, 1e3 * (1.842e-4 * r3 - 3.030e-7 * r5), 1e-9);
    EXPECT_NEAR(p.decentring_b_um, 1e3 * std::hypot(6.582e-6, 1.620e-5) * p.r_mm * p.r_mm, 1e-9);
    EXPECT_EQ(p.decentring_a_um, 0);
  }
  // Fig. 15 (c): the largest difference lies on the frame border.
  const ComparePoint* worst = &r.map[0];
  for (const auto& p : r.map) if (p.diff_um.norm() > worst->diff_um.norm()) worst = &p;
  EXPECT_TRUE(worst->u_px == 0 || worst->v_px == 0 || worst->u_px == 4287 || worst->v_px == 2847);
  EXPECT_NEAR(worst->diff_um.norm(), r.max_diff_um, 1e-12);
}

TEST(CompareTest, ChiSquareAcceptsSameCameraRejectsChangedOne) {
  SyntheticOptions o;
  o.camera = camera::FromBrown(
      {26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0}, {4288, 2848, 0.0055});
  o.target = ParseTarget("chessboard:13x9:40");
  o.n_images = 12;
  CalibrationOptions c;
  c.pixel_pitch_mm = 0.0055;
  c.reject_k = 0;
  auto record = [&](const SyntheticOptions& so) {
    const auto r = Calibrate(MakeSyntheticSet(so).detections, so.target, c);
    return CalibrationFromJson(nlohmann::json::parse(CalibrationToJson(r, so.target, c).dump()),
                               "x");
  };
  const auto a = record(o);
  o.noise_seed = 77;
  o.pose_seed = 5;
  const auto b = record(o);
  const auto same = Compare(a, b);
  EXPECT_EQ(same.covariance_note, "full");
  EXPECT_EQ(same.dof, 7);
  EXPECT_GT(same.p_value, 0.01) << same.chi2;
  o.camera.params[camera::kBrownC] += 0.03;  // ~10σ
  const auto changed = Compare(a, record(o));
  EXPECT_LT(changed.p_value, 1e-6) << changed.chi2;

  // The same calibration with B1 and B2 "adjusted" in B with a tiny σ and a value off 0 (what a
  // Brown camera read back from Metashape's fx, fy carries): before, they entered the χ² as if
  // measured against A's fixed 0 (χ² ≈ 10⁶, "differ"); now they are left out and named, and the
  // seven parameters both adjusted agree exactly.
  auto refit = a;
  for (int i : {camera::kBrownB1, camera::kBrownB2}) {
    refit.free[i] = true;
    refit.camera.params[i] = 2e-7;
    refit.covariance(i, i) = 1e-20;  // σ 1e-10
  }
  const auto round_trip = Compare(a, refit);
  EXPECT_EQ(round_trip.dof, 7);
  EXPECT_EQ(round_trip.chi2, 0);
  EXPECT_FALSE(round_trip.significant);
  EXPECT_EQ(round_trip.left_out, (std::vector<int>{camera::kBrownB1, camera::kBrownB2}));
  EXPECT_NE(round_trip.left_out_note.find("B1, B2 (adjusted in B only)"), std::string::npos)
      << round_trip.left_out_note;
  EXPECT_TRUE(std::isnan(round_trip.rows[camera::kBrownB1].z));
  // …and a genuinely changed calibration with the same extra B1, B2 still differs.
  auto moved = refit;
  moved.camera.params[camera::kBrownC] += 10 * std::sqrt(a.covariance(camera::kBrownC, camera::kBrownC));
  EXPECT_LT(Compare(a, moved).p_value, 1e-6);
}

TEST(CompareTest, DifferentSensorsNameBoth) {
  auto [air, water] = Table6();
  water.camera.sensor.pixel_pitch_mm = 1.0;
  try {
    Compare(air, water);
    FAIL() << "accepted two sensors";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("pixel pitch 0.0055 mm; B 4288x2848 px, pixel pitch 1 mm"),
              std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace porthole::calib
