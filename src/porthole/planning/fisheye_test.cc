// Proves plan and flat for fisheye lenses against closed forms: the field of view in air is the
// projection's (equisolid 4·asin(r/2f)); a dome concentric with the pupil passes every chief ray
// undeviated, even beyond 90° off axis, and images the object sphere at one distance (no field
// curvature); a hemisphere's rim in the pupil plane cuts the field at exactly 90°; a flat port
// cuts it at 90° in air and at the critical angle in water.
#include <gtest/gtest.h>

#include <cmath>

#include "porthole/catalogue/presets.h"
#include "porthole/planning/flat.h"
#include "porthole/planning/plan.h"

namespace porthole::planning {
namespace {

constexpr double kDeg = 180.0 / M_PI;

Setup FisheyeSetup(camera::Projection p, double f_mm, const std::string& port) {
  Setup s;
  s.camera = catalogue::LoadCamera("nikon-d300");
  s.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  s.lens.projection = p;
  s.lens.focal_length_mm = f_mm;
  s.lens.f_number_min = 2.8;
  s.lens.min_focus_mm = 80;
  s.port = catalogue::LoadPort(port);
  s.env.water_index = 1.341;
  return s;
}

// The nominal NI320 (centred on the pupil) with its rim pulled 60 mm behind the pupil: a dome
// that passes rays up to ~128° off axis.
Setup DeepDome(camera::Projection p, double f_mm) {
  Setup s = FisheyeSetup(p, f_mm, "nimar-ni320-nominal");
  std::get<ports::DomePort>(s.port.shape).rim_z_mm = -60;
  return s;
}

TEST(Fisheye, AirFieldOfViewIsTheProjections) {
  const planning::Setup s = FisheyeSetup(camera::Projection::kEquisolid, 10.5, "nimar-ni320-nominal");
  const Plan p = MakePlan(s, {});  // no target: the lens at infinity, c = f
  const double hw = 0.5 * s.camera.SensorWidthMm(), hd = 0.5 * s.camera.SensorDiagonalMm();
  EXPECT_NEAR(p.fov.air.horizontal_deg, 4 * std::asin(hw / 21) * kDeg, 1e-9);
  EXPECT_NEAR(p.fov.air.diagonal_deg, 4 * std::asin(hd / 21) * kDeg, 1e-9);
}

TEST(Fisheye, ConcentricDomeKeepsTheFieldBeyondNinetyDegrees) {
  // Equidistant 8 mm on the D300: the corner is 14.16/8 rad = 101.4° off axis.
  const planning::Setup s = DeepDome(camera::Projection::kEquidistant, 8);
  PlanOptions o;
  o.subject_distance_mm = 1000;
  const Plan p = MakePlan(s, o);
  ASSERT_TRUE(p.target);
  const double c = p.principal_distance_mm;
  EXPECT_NEAR(p.fov.air.diagonal_deg, 2 * 0.5 * s.camera.SensorDiagonalMm() / c * kDeg, 1e-9);
  EXPECT_GT(p.fov.air.diagonal_deg, 180);
  EXPECT_NEAR(p.fov.water.diagonal_deg, p.fov.air.diagonal_deg, 1e-9);  // radial rays pass undeviated
  EXPECT_EQ(p.field_cut.blocked_fraction, 0);
  ASSERT_TRUE(p.target->field);
  const auto& rows = p.target->field->rows;
  ASSERT_EQ(rows.size(), 11u);
  EXPECT_GT(rows.back().field_angle_deg, 90);
  // The object sphere about the centre is imaged on a concentric sphere: no sag at any angle.
  for (const FieldRow& r : rows) {
    ASSERT_TRUE(std::isfinite(r.d_s2ep_mm)) << r.field_angle_deg;
    EXPECT_NEAR(r.sag_mm, 0, 1e-3 * r.d_s2ep_mm) << r.field_angle_deg;
  }
}

TEST(Fisheye, HemisphereRimInThePupilPlaneCutsAtNinetyDegrees) {
  const planning::Setup s = FisheyeSetup(camera::Projection::kEquidistant, 8, "nimar-ni320-nominal");
  const Plan p = MakePlan(s, {});
  EXPECT_NEAR(p.field_cut.clear_angle_deg, 90, 1e-6);
  EXPECT_NEAR(p.field_cut.clear_radius_mm, 8 * M_PI / 2, 1e-6);
  // The part of the frame beyond the image circle of radius 4π mm, by area (a 64 x 43 grid).
  const double w = s.camera.SensorWidthMm(), h = s.camera.SensorHeightMm(), r = 4 * M_PI;
  // The circle crosses the long edges only (r > h/2, r < w/2 is false here: 12.57 > 11.79).
  EXPECT_GT(r, 0.5 * w);
  double outside = 0;  // area of the frame outside the circle, by fine integration
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double x = -0.5 * w + (i + 0.5) * w / n;
    const double half = r * r > x * x ? std::sqrt(r * r - x * x) : 0;
    outside += std::max(0.0, h - 2 * std::min(half, 0.5 * h)) * w / n;
  }
  EXPECT_NEAR(p.field_cut.blocked_fraction, outside / (w * h), 0.01);
  EXPECT_EQ(p.field_cut.what, "the corners");
  EXPECT_TRUE(std::isnan(p.fov.water.diagonal_deg));
}

TEST(Fisheye, FlatPortCutsAtNinetyInAirAndTheCriticalAngleInWater) {
  const planning::Setup s = FisheyeSetup(camera::Projection::kEquidistant, 8, "flat-acrylic-10mm");
  const FlatAnalysis a = AnalyseFlat(s, {});
  EXPECT_NEAR(a.field_cut.clear_angle_deg, 90, 1e-3);
  EXPECT_GT(a.field_cut.blocked_fraction, 0);
  EXPECT_LE(a.field_cut.clear_water_angle_deg, a.critical_angle_deg + 1e-9);
  EXPECT_NEAR(a.field_cut.clear_water_angle_deg, a.critical_angle_deg, 0.05);
  // Rows stop short of 90°, and their radii follow the projection.
  for (const FlatRow& r : a.rows) EXPECT_NEAR(r.image_radius_mm, a.principal_distance_mm * r.theta_air_deg / kDeg, 1e-9);
  EXPECT_LT(a.rows.back().theta_air_deg, 90);
}

}  // namespace
}  // namespace porthole::planning
