// Proves the simulation reproduces the port optics the paper states (Sections 2.2, 2.3) as fitted
// Brown parameters — identity for a concentric dome, pincushion / barrel / decentring for a
// displaced pupil, c = n_w·c_air and Eq. 1's pincushion for a thin flat port at the pupil — and
// the paper's measured Table 6 change within the uncertainty of its pupil position and estimates.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "porthole/camera/json.h"
#include "porthole/camera/profile.h"
#include "porthole/catalogue/presets.h"
#include "porthole/simulate/report.h"
#include "porthole/simulate/simulate.h"

namespace porthole::simulate {
namespace {

SystemSpec PaperSystem(const std::string& port = "nimar-ni320") {
  SystemSpec s;
  s.port = catalogue::LoadPort(port);
  s.camera = catalogue::LoadCamera("nikon-d300");
  s.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  return s;
}

// The paper's Table 6: parameter → {air, air σ, water, water σ} (0 where not computed).
std::map<std::string, std::array<double, 4>> Table6() {
  std::map<std::string, std::array<double, 4>> t6;
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/menna2016_table6.csv");
  EXPECT_TRUE(in.good());
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("parameter", 0) == 0) continue;
    std::stringstream ss(line);
    std::string key, v;
    std::getline(ss, key, ',');
    std::array<double, 4> row{};
    for (double& x : row) x = std::getline(ss, v, ',') && !v.empty() ? std::stod(v) : 0.0;
    t6[key] = row;
  }
  return t6;
}

// The paper's in-air calibration (Table 6, c, x0, y0, K1, K2), used as a realistic lens.
camera::BrownParams PaperAirLens() {
  auto t6 = Table6();
  camera::BrownParams p;
  p.c_mm = t6["c_mm"][0];
  p.x0_mm = t6["x0_mm"][0];
  p.y0_mm = t6["y0_mm"][0];
  p.K1 = t6["K1"][0];
  p.K2 = t6["K2"][0];
  return p;
}

TEST(Simulate, ConcentricDomeCentredOnThePupilIsTheIdentity) {
  SystemSpec spec = PaperSystem("nimar-ni320-nominal");
  spec.air_calibration = PaperAirLens();
  const Prediction p = Predict(spec);
  const auto truth = PaperAirLens().ToArray();
  for (const BrownFit* f : {&p.water, &p.air}) {
    const auto got = f->params.ToArray();
    EXPECT_NEAR(got[camera::kBrownC], truth[camera::kBrownC], 1e-9);
    EXPECT_NEAR(got[camera::kBrownX0], truth[camera::kBrownX0], 1e-9);
    EXPECT_NEAR(got[camera::kBrownY0], truth[camera::kBrownY0], 1e-9);
    EXPECT_NEAR(got[camera::kBrownK1], truth[camera::kBrownK1], 1e-12);
    EXPECT_NEAR(got[camera::kBrownK2], truth[camera::kBrownK2], 1e-14);
    EXPECT_NEAR(got[camera::kBrownK3], 0, 1e-16);
    EXPECT_NEAR(got[camera::kBrownP1], 0, 1e-12);
    EXPECT_NEAR(got[camera::kBrownP2], 0, 1e-12);
    EXPECT_LT(f->rms_um, 1e-6);
    EXPECT_LT((f->center_in_housing_mm - p.focus.ep_in_housing_mm).norm(), 1e-7);
  }
  // The identity holds at every distance, not just the fitted ones: the bundle is central.
  for (const DistanceError& e : DistanceErrors(p.water_system, p.camera, p.water,
                                               {300, 5000, 50000}, p.options)) {
    EXPECT_LT(e.rms_um, 1e-6) << e.distance_mm;
  }
}

// Section 2.3: pupil ahead of the centre (toward the glass) → pincushion, behind → barrel; a
// lateral offset → decentring. Brown corrections: pincushion lowers K1 (barrel K1 > 0).
TEST(Simulate, AxialPupilOffsetGivesPincushionAheadAndBarrelBehind) {
  const Prediction p = Predict(PaperSystem("nimar-ni320-nominal"));
  const auto rows = SweepPupilOffset(p, 2, {-5.0, 5.0});
  const BrownFit& behind = rows[0].water;
  const BrownFit& ahead = rows[1].water;
  const double r = 14.0;  // near the D300's half diagonal, mm
  const double ahead_um = 1000 * camera::RadialProfileMm(ahead.params, r);
  const double behind_um = 1000 * camera::RadialProfileMm(behind.params, r);
  EXPECT_LT(ahead.params.K1 - rows[1].air.params.K1, -1e-6);
  EXPECT_GT(behind.params.K1 - rows[0].air.params.K1, 1e-6);
  EXPECT_LT(ahead_um, -5.0);  // pincushion: the correction pulls edge points inward
  EXPECT_GT(behind_um, 5.0);
  // The port's angular magnification: ahead the view narrows toward a flat port's (c grows),
  // behind it widens. On the axis nothing tilts, so no decentring.
  EXPECT_GT(ahead.params.c_mm / rows[1].air.params.c_mm, 1.005);
  EXPECT_LT(behind.params.c_mm / rows[0].air.params.c_mm, 0.995);
  for (const SweepRow& row : rows) {
    EXPECT_LT(std::hypot(row.water.params.P1, row.water.params.P2), 1e-10);
    EXPECT_LT(std::hypot(row.water.params.x0_mm, row.water.params.y0_mm), 1e-8);
  }
}

TEST(Simulate, EpOffsetMovesThePupilRelativeToACamFramePort) {
  SystemSpec spec = PaperSystem("nimar-ni320-nominal");
  spec.ep_offset_mm = Vec3(0, 0, 5);
  const Prediction offset = Predict(spec);
  const SweepRow swept = SweepPupilOffset(Predict(PaperSystem("nimar-ni320-nominal")), 2, {5.0})[0];
  EXPECT_LT(offset.change.K1, -1e-6);
  // The same geometry up to the focus (the offset pupil sees a slightly different virtual image).
  EXPECT_NEAR(offset.change.K1, swept.water.params.K1 - swept.air.params.K1,
              0.05 * std::abs(offset.change.K1));
}

TEST(Simulate, LateralPupilOffsetGivesDecentringAlongIt) {
  const Prediction p = Predict(PaperSystem("nimar-ni320-nominal"));
  const BrownFit x = SweepPupilOffset(p, 0, {1.0})[0].water;
  const BrownFit y = SweepPupilOffset(p, 1, {1.0})[0].water;
  // P1 pairs with x, P2 with y; the other one vanishes by symmetry.
  EXPECT_GT(std::abs(x.params.P1), 1e-6);
  EXPECT_LT(std::abs(x.params.P2), 1e-4 * std::abs(x.params.P1));
  EXPECT_GT(std::abs(y.params.P2), 1e-6);
  EXPECT_LT(std::abs(y.params.P1), 1e-4 * std::abs(y.params.P2));
  // Housing +Y is image −y: the same offset gives decentring of opposite sign and similar size
  // (not equal: the 3:2 frame samples the two directions differently).
  EXPECT_LT(y.params.P2 * x.params.P1, 0);
  EXPECT_NEAR(std::abs(y.params.P2 / x.params.P1), 1.0, 0.3);
  // The principal point moves along the offset too (a 1 mm offset tilts the bundle).
  EXPECT_GT(std::abs(x.params.x0_mm), 1e-3);
}

// Section 2.2: a thin flat port with the pupil at the glass keeps the bundle central; paraxially
// c_w = n_w·c, and Eq. 1 (r'/r = sqrt((n² − sin²θa)/(1 − sin²θa))) expanded to third order in
// r/c gives the Brown correction K1 = −(1 − 1/n²)/(2 c_air²): pincushion.
TEST(Simulate, ThinFlatPortAtThePupilMultipliesCByTheWaterIndex) {
  ports::PortSpec spec;
  spec.name = "thin-flat";
  spec.frame = ports::PortFrame::kCam;
  ports::FlatPort flat;
  flat.inner_point_mm = Vec3(0, 0, 1e-4);
  flat.thickness_mm = 1e-3;
  spec.shape = flat;
  const ports::Environment env;
  CameraSetup cam;
  cam.sensor = catalogue::LoadCamera("nikon-d300").sensor;
  cam.lens.c_mm = 100;  // narrow field: 8° half diagonal
  cam.ep_in_housing_mm = Vec3(0, 0, 30);
  const ports::PortSystem water = ports::MakeSystem(spec, env, cam.ep_in_housing_mm);
  FitOptions o;
  o.reference_distance_mm = 2000;
  const BrownFit fit = SimulateFit(water, cam, o);
  const double n = water.n_water;
  EXPECT_NEAR(fit.params.c_mm / (n * cam.lens.c_mm), 1.0, 0.01);
  const double k1 = -(1 - 1 / (n * n)) / (2 * cam.lens.c_mm * cam.lens.c_mm);  // c in air
  EXPECT_NEAR(fit.params.K1 / k1, 1.0, 0.05);
  // Strong: tens of µm at the frame corner, against zero for the lens in air.
  EXPECT_LT(1000 * camera::RadialProfileMm(fit.params, 14.0), -30.0);
  EXPECT_LT(fit.rms_um, 0.05);
}

TEST(Simulate, FocusIsTheFixedPointOfEq2AndTheVirtualImage) {
  const SystemSpec spec = PaperSystem();
  const housing::FocusSetting f = FocusUnderWater(spec);
  const lens::Mount& mount = lens::MountByName(spec.lens.mount);
  ASSERT_TRUE(f.focus_distance_mm);
  const double fd_mm = *f.focus_distance_mm;
  EXPECT_NEAR(lens::SubjectToPupilMm(spec.lens, mount, fd_mm), f.d_s2ep_mm, 1e-6);
  EXPECT_NEAR(spec.lens.PupilToFlangeMm(fd_mm), f.ep_in_housing_mm.z(), 1e-9);
  // Paper Section 4: an object 1 m from a pupil concentric with the dome is imaged 238 mm from
  // the pupil; this pupil is ~5 mm ahead of the centre, so the image comes a little closer.
  EXPECT_GT(f.d_s2ep_mm, 220);
  EXPECT_LT(f.d_s2ep_mm, 238);
  // The lens must focus closer than its 300 mm minimum scale would allow on the real object.
  EXPECT_GT(fd_mm, spec.lens.min_focus_mm);
}

// A flat port 20 mm ahead of the pupil makes a strongly non-central bundle: the Brown model that
// absorbs it at 0.8–1.3 m is microns off at 0.3 m and at infinity. The as-built dome (pupil
// 5.4 mm off centre) stays almost central: sub-micron at every distance.
TEST(Simulate, ModelErrorGrowsOutsideTheFittedDistancesForANonCentralPort) {
  SystemSpec flat = PaperSystem("flat-acrylic-10mm");
  const Prediction p = Predict(flat);
  const auto e = DistanceErrors(p.water_system, p.camera, p.water, {300, 1050, 1e6}, p.options);
  EXPECT_GT(e[0].rms_um, 10 * e[1].rms_um);
  EXPECT_GT(e[2].rms_um, 10 * e[1].rms_um);
  EXPECT_GT(e[0].rms_um, 2.0);
  const Prediction d = Predict(PaperSystem());
  for (const DistanceError& x :
       DistanceErrors(d.water_system, d.camera, d.water, {300, 1050, 1e6}, d.options)) {
    EXPECT_LT(x.rms_um, 1.0) << x.distance_mm;
  }
}

// Table 6 (swimming pool: fresh water). The paper's std values are the calibration's own
// precision; the dominant uncertainty of the prediction is the pupil's axial position, located to
// "some tenths of a millimetre" (Section 3.1): 0.5 mm × the simulated sensitivity.
TEST(Simulate, PredictsThePapersTable6Change) {
  auto t6 = Table6();  // air, air σ, water, water σ
  const camera::BrownParams air = PaperAirLens();
  SystemSpec spec = PaperSystem();
  spec.env.water = "freshwater";
  spec.air_calibration = air;
  FitOptions o;
  o.fit_k3 = false;  // the paper did not adjust K3
  const Prediction p = Predict(spec, o);
  ASSERT_TRUE(p.predicted_water.has_value());
  const auto sweep = SweepPupilOffset(p, 2, {-0.5, 0.5});
  auto ratio = [](const BrownFit& w, const BrownFit& a) { return w.params.c_mm / a.params.c_mm; };

  const double paper_ratio = t6["c_mm"][2] / t6["c_mm"][0];
  const double paper_ratio_sigma =
      paper_ratio * std::hypot(t6["c_mm"][1] / t6["c_mm"][0], t6["c_mm"][3] / t6["c_mm"][2]);
  const double pupil_spread =
      0.5 * std::abs(ratio(sweep[1].water, sweep[1].air) - ratio(sweep[0].water, sweep[0].air));
  const double predicted_ratio = p.predicted_water->c_mm / air.c_mm;
  EXPECT_NEAR(predicted_ratio, paper_ratio, 2 * std::hypot(paper_ratio_sigma, pupil_spread));
  EXPECT_GT(predicted_ratio, 1.005);

  // Radial profile change (water − air) at mid field and the frame edge: less barrel under
  // water. The paper's σ of δr from σ(K1), σ(K2) taken uncorrelated (an upper bound: they are
  // negatively correlated).
  for (double r : {10.0, 14.0}) {
    const double r3 = r * r * r, r5 = r3 * r * r;
    const double paper_um = 1000 * ((t6["K1"][2] - t6["K1"][0]) * r3 + (t6["K2"][2] - t6["K2"][0]) * r5);
    const double paper_sigma_um =
        1000 * std::sqrt(std::pow(t6["K1"][1] * r3, 2) + std::pow(t6["K2"][1] * r5, 2) +
                         std::pow(t6["K1"][3] * r3, 2) + std::pow(t6["K2"][3] * r5, 2));
    auto change_um = [r](const BrownFit& w, const BrownFit& a) {
      return 1000 * (camera::RadialProfileMm(w.params, r) - camera::RadialProfileMm(a.params, r));
    };
    const double ours_um = 1000 * (camera::RadialProfileMm(*p.predicted_water, r) -
                                   camera::RadialProfileMm(air, r));
    const double spread_um =
        0.5 * std::abs(change_um(sweep[1].water, sweep[1].air) - change_um(sweep[0].water, sweep[0].air));
    EXPECT_LT(ours_um, 0) << r;
    EXPECT_NEAR(ours_um, paper_um, 2 * std::hypot(paper_sigma_um, spread_um)) << "r = " << r;
  }
}

TEST(Simulate, InvalidOptionsNameTheField) {
  FitOptions o;
  o.num_distances = 1;
  EXPECT_THROW(Validate(o), InvalidInput);
  o = {};
  o.distances_mm = {500, 500};
  try {
    Validate(o);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "distances_mm");
  }
  SystemSpec spec = PaperSystem();
  spec.object_distance_mm = 50;  // inside the dome
  EXPECT_THROW(FocusUnderWater(spec), InvalidInput);
}

// A fisheye lens is fitted with the list's fisheye model (Kannala–Brandt). Behind a dome
// concentric with the pupil every chief ray passes undeviated, so water and air give the lens's
// own projection: for equisolid 2 sin(θ/2) = θ − θ³/24 + θ⁵/1920 − θ⁷/322560 + …, KB's k1..k4
// are its Taylor coefficients (to the truncation the fit spreads over k3, k4), fx = c / pitch.
TEST(Simulate, FisheyeBehindAConcentricDomeFitsTheProjectionsSeries) {
  SystemSpec spec = PaperSystem("nimar-ni320-nominal");
  spec.lens = catalogue::LoadLens("nikkor-10.5mm-f2.8g-fisheye");
  const Prediction p = Predict(spec);
  ASSERT_TRUE(p.water_fisheye && p.air_fisheye);
  for (const CameraFit* f : {&*p.water_fisheye, &*p.air_fisheye}) {
    EXPECT_EQ(f->camera.model, camera::CameraModelId::kKannalaBrandt);
    EXPECT_TRUE(f->converged);
    EXPECT_LT(f->rms_px, 1e-3);
    const auto& k = f->camera.params;
    EXPECT_NEAR(k[0] * spec.camera.sensor.pixel_pitch_mm, p.camera.lens.c_mm, 1e-6);
    EXPECT_NEAR(k[4], -1.0 / 24, 1e-5);
    EXPECT_NEAR(k[5], 1.0 / 1920, 2e-5);
  }
  // The views: the lens keeps its projection, so no correction anywhere and focal ratio 1.
  EXPECT_NEAR(p.water_view().c_mm() / p.air_view().c_mm(), 1.0, 1e-6);
  for (const MapPoint& m : DistortionMap(p)) {
    EXPECT_LT(m.water_um.norm(), 0.05) << m.x_mm << ", " << m.y_mm;
    EXPECT_LT(m.difference_um.norm(), 0.05);
  }
  spec.air_calibration = PaperAirLens();
  EXPECT_THROW(Predict(spec), InvalidInput);  // a Brown calibration cannot describe a fisheye
}

// The 10.5 mm fisheye behind a thin flat port (1 µm of glass) 0.1 µm ahead of its pupil.
SystemSpec FisheyeBehindAThinFlatPort() {
  SystemSpec spec = PaperSystem();
  spec.lens = catalogue::LoadLens("nikkor-10.5mm-f2.8g-fisheye");
  ports::FlatPort flat;
  flat.inner_point_mm = Vec3(0, 0, 1e-4);
  flat.thickness_mm = 1e-3;
  spec.port.name = "thin-flat";
  spec.port.frame = ports::PortFrame::kCam;
  spec.port.shape = flat;
  return spec;
}

// A fisheye behind a thin flat port at its pupil: every chief ray is bent by Snell's law alone,
// sin θa = n sin θw, and the bundle stays central. Paraxially the focal length grows by n; an image
// point at radius r (θa = g⁻¹(r/c) through the equisolid lens) must move to n·c·g(θw) to obey the
// lens's projection in water: the correction the view reports, in closed form.
TEST(Simulate, FisheyeBehindAThinFlatPortFollowsSnellsLaw) {
  SystemSpec spec = FisheyeBehindAThinFlatPort();
  // c = 20 mm keeps the field within 42° in air (29.5° in water), where Kannala–Brandt's series
  // follows the Snell mapping; at the lens's 10.5 mm the field reaches 85° in air, near grazing
  // in the glass, and no polynomial in θw follows it (the fit's RMS is then 4 px).
  spec.c_mm = 20;
  const Prediction p = Predict(spec);
  ASSERT_TRUE(p.water_fisheye);
  const double n = p.water_system.n_water, c = 20;
  const FitView water = p.water_view(), air = p.air_view();
  EXPECT_NEAR(water.c_mm() / (n * air.c_mm()), 1.0, 2e-3);
  const double corner = ProfileRadiiMm(p.camera.sensor).back();
  const auto g = [](double t) { return 2 * std::sin(t / 2); };
  const auto expected_um = [&](double r) {
    const double theta_air = 2 * std::asin(r / (2 * c));
    const double theta_water = std::asin(std::sin(theta_air) / n);
    return 1000 * (n * c * g(theta_water) - r);
  };
  const double scale = std::abs(expected_um(corner));
  EXPECT_LT(p.water_fisheye->rms_px, 0.01);
  EXPECT_GT(scale, 300);  // strong: a flat port squeezes a fisheye's field
  for (double r : {4.0, 8.0, 12.0, corner}) {
    EXPECT_NEAR(1000 * water.RadialProfileMm(r), expected_um(r), 0.01 * scale) << "r = " << r;
    EXPECT_LT(std::abs(1000 * air.RadialProfileMm(r)), 0.5);  // in air the lens keeps its projection
  }
}

// Moving the pupil off the centre of a concentric dome: the change of focal length and of the
// radial profile is odd in the offset to first order, and the sweep's offset 0 is the prediction.
TEST(Simulate, FisheyeSweepIsOddAboutTheDomeCentre) {
  SystemSpec spec = PaperSystem("nimar-ni320-nominal");
  spec.lens = catalogue::LoadLens("nikkor-10.5mm-f2.8g-fisheye");
  const Prediction p = Predict(spec);
  const std::vector<SweepRow> rows = SweepPupilOffset(p, 2, {-1.0, 0.0, 1.0});
  ASSERT_EQ(rows.size(), 3u);
  ASSERT_TRUE(rows[1].water_fisheye);
  EXPECT_NEAR(rows[1].water_view().c_mm(), p.water_view().c_mm(), 1e-9);
  const auto dc = [](const SweepRow& r) { return r.water_view().c_mm() / r.air_view().c_mm() - 1; };
  const auto dr = [](const SweepRow& r) { return r.water_view().RadialProfileMm(12) - r.air_view().RadialProfileMm(12); };
  EXPECT_GT(std::abs(dc(rows[2])), 1e-4);
  EXPECT_GT(std::abs(dr(rows[2])), 1e-3);  // > 1 µm at r = 12 mm
  EXPECT_NEAR(dc(rows[0]) / dc(rows[2]), -1.0, 0.1);
  EXPECT_NEAR(dr(rows[0]) / dr(rows[2]), -1.0, 0.1);
}

// A fisheye's in-air calibration (Kannala–Brandt, decentred, with its own distortion) as the base
// of the prediction: the rays leave by the calibrated lens. Behind a dome concentric with the pupil
// they pass undeviated, so the water and air fits are the calibration itself and the predicted
// underwater calibration equals it.
camera::Camera DecentredFisheyeCalibration(const camera::Sensor& sensor, double f_mm) {
  camera::Camera cal = camera::Camera::Ideal(camera::CameraModelId::kKannalaBrandt, sensor, f_mm / sensor.pixel_pitch_mm);
  cal.params[1] *= 1.002;  // fy
  cal.params[2] += 12.3;   // cx, px
  cal.params[3] -= 7.1;    // cy
  cal.params[4] = -1.0 / 24 + 0.004;  // k1..k4 about the equisolid series
  cal.params[5] = 1.0 / 1920 - 0.0005;
  cal.params[6] = 1e-4;
  cal.params[7] = -2e-5;
  return cal;
}

TEST(Simulate, FisheyeAirCalibrationBehindAConcentricDomeIsPredictedUnchanged) {
  SystemSpec spec = PaperSystem("nimar-ni320-nominal");
  spec.lens = catalogue::LoadLens("nikkor-10.5mm-f2.8g-fisheye");
  const camera::Camera cal = DecentredFisheyeCalibration(spec.camera.sensor, 10.5);
  spec.air_fisheye_calibration = cal;
  const Prediction p = Predict(spec);
  ASSERT_TRUE(p.water_fisheye && p.air_fisheye && p.predicted_water_fisheye);
  EXPECT_NEAR(p.camera.lens.c_mm, 10.5 * (1 + 1.002) / 2, 1e-9);  // the calibration's mean focal length
  for (const CameraFit* f : {&*p.water_fisheye, &*p.air_fisheye}) {
    EXPECT_EQ(f->camera.model, camera::CameraModelId::kKannalaBrandt);
    EXPECT_LT(f->rms_px, 1e-4);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(f->camera.params[i], cal.params[i], 1e-5) << i;
    for (std::size_t i = 4; i < 8; ++i) EXPECT_NEAR(f->camera.params[i], cal.params[i], 1e-7) << i;
  }
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_NEAR(p.predicted_water_fisheye->params[i], cal.params[i], i < 4 ? 1e-5 : 1e-7) << i;
  }
  // A Brown calibration for the fisheye, and a fisheye calibration for a rectilinear lens: refused.
  SystemSpec wrong = spec;
  wrong.air_fisheye_calibration->model = camera::CameraModelId::kBrown;
  EXPECT_THROW(Predict(wrong), InvalidInput);
  wrong = PaperSystem("nimar-ni320-nominal");
  wrong.air_fisheye_calibration = cal;
  EXPECT_THROW(Predict(wrong), InvalidInput);
}

// The same calibration behind a thin flat port at the pupil: the focal lengths grow by the water
// index (paraxially).
TEST(Simulate, FisheyeAirCalibrationBehindAThinFlatPortScalesByTheWaterIndex) {
  SystemSpec spec = FisheyeBehindAThinFlatPort();
  // 20 mm as in FisheyeBehindAThinFlatPortFollowsSnellsLaw: a field Kannala–Brandt can follow.
  camera::Camera cal = DecentredFisheyeCalibration(spec.camera.sensor, 20);
  spec.lens.focal_length_mm = 20;  // a calibration must be of the lens (CheckAirCalibration)
  spec.air_fisheye_calibration = cal;
  const Prediction p = Predict(spec);
  ASSERT_TRUE(p.predicted_water_fisheye);
  const double n = p.water_system.n_water;
  EXPECT_LT(p.water_fisheye->rms_px, 0.02);
  EXPECT_NEAR(p.predicted_water_fisheye->params[0] / (n * cal.params[0]), 1.0, 2e-3);
  EXPECT_NEAR(p.predicted_water_fisheye->params[1] / (n * cal.params[1]), 1.0, 2e-3);
  // In air the thin plate changes nothing: the air fit is the calibration.
  EXPECT_NEAR(p.air_fisheye->camera.params[0], cal.params[0], 1e-3 * cal.params[0]);
}

// An air calibration of another lens or in pixels is refused (it gave c −2.82 mm or a "water c"
// of 4566.9 mm); the paper's lens passes; the bounds are the lens's f − 15 % and its closest-focus
// principal distance + 15 %.
TEST(Simulate, AnAirCalibrationOfAnotherLensIsRefused) {
  SystemSpec spec = PaperSystem();
  const camera::ExpectedCamera e = ExpectedCameraOf(spec);
  EXPECT_EQ(e.focal_length_mm, 24.0);
  EXPECT_GT(e.max_principal_distance_mm, 24.0 * 1.05);  // 0.3 m closest focus: magnification > 0.05
  EXPECT_LT(e.max_principal_distance_mm, 24.0 * 1.2);
  for (double c : {1e-300, 2.92, 19.0, 40.0, 4454.5}) {
    spec.air_calibration = PaperAirLens();
    spec.air_calibration->c_mm = c;
    try {
      Predict(spec);
      ADD_FAILURE() << c;
    } catch (const InvalidInput& err) {
      EXPECT_EQ(err.field(), "air_calibration") << c;
    }
  }
  spec.air_calibration = PaperAirLens();
  spec.air_calibration->x0_mm = 20;  // the principal point off the 23.6 mm wide sensor
  EXPECT_THROW(Predict(spec), InvalidInput);
  spec.air_calibration = PaperAirLens();
  const Prediction p = Predict(spec);
  EXPECT_GT(p.water.params.c_mm, 0);
  EXPECT_TRUE(std::isfinite(p.water.rms_um));
}

TEST(CameraJson, RoundTripAndTyposAreRejected) {
  camera::BrownEstimate e;
  e.value = PaperAirLens();
  e.value.P1 = 6.582e-6;
  e.sigma = camera::BrownParams{0.006, 0.002, 0.003, 1.2e-6, 7.4e-9};
  const auto j = camera::BrownToJson(e);
  EXPECT_EQ(j["units"]["K1"], "mm^-2");
  const camera::BrownEstimate back = camera::BrownFromJson(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.value.ToArray(), e.value.ToArray());
  ASSERT_TRUE(back.sigma.has_value());
  EXPECT_EQ(back.sigma->ToArray(), e.sigma->ToArray());
  try {
    camera::BrownFromJson(nlohmann::json::parse(R"({"c_mm": 25.8, "k1": 1e-4})"), "--air");
    FAIL();
  } catch (const InvalidInput& err) {
    EXPECT_EQ(err.field(), "--air.k1");
  }
  EXPECT_THROW(camera::BrownFromJson(nlohmann::json::parse(R"({"K1": 1e-4})")), InvalidInput);
}

}  // namespace
}  // namespace porthole::simulate
