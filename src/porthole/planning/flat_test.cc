// Proves the flat-port analysis: Eq. 1 equals an exact trace of a thin port with the pupil at the
// glass, the maximum field of view from the critical angle (97.2 deg for n_w = 1.333), the
// paraxial focal-length increase n_w, Snell's law for the field of view, and lateral colour from
// the water's dispersion.
#include "porthole/planning/flat.h"

#include <gtest/gtest.h>

#include <cmath>

#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"

namespace porthole::planning {
namespace {

constexpr double kDeg = 180.0 / M_PI;

ports::PortSpec ThinFlat() {  // the pupil at the glass: a 1 um plate 1 um ahead of it
  ports::PortSpec s;
  s.name = "thin";
  s.frame = ports::PortFrame::kCam;
  ports::FlatPort f;
  f.inner_point_mm = Vec3(0, 0, 1e-3);
  f.thickness_mm = 1e-3;
  s.shape = f;
  return s;
}

Setup FlatSetup(const ports::PortSpec& port, double n_w) {
  Setup s;
  s.camera = catalogue::LoadCamera("nikon-d300");
  s.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  s.port = port;
  s.env.water_index = n_w;
  return s;
}

TEST(Flat, Eq1EqualsAnExactTraceOfAThinPort) {
  for (double nw : {1.333, 1.341}) {
    const ports::PortSystem sys = ports::MakeSystem(ThinFlat(), ports::Environment{}, Vec3(0, 0, 26.9));
    ports::PortSystem s = sys;
    s.n_water = nw;
    for (double deg = 0.5; deg < 89.5; deg += 0.5) {
      const double ta = deg / kDeg;
      EXPECT_NEAR(FlatDistortionFactor(ta, nw), TracedDistortionFactor(s, ta), 1e-9 * FlatDistortionFactor(ta, nw))
          << deg;
    }
    EXPECT_NEAR(FlatDistortionFactor(0, nw), nw, 1e-15);  // paraxially the focal length grows by n_w
  }
}

TEST(Flat, MaximumFieldOfViewFromTheCriticalAngle) {
  const FlatAnalysis a = AnalyseFlat(FlatSetup(ThinFlat(), 1.333), {});
  EXPECT_NEAR(a.max_fov_deg, 97.2, 0.1);
  EXPECT_NEAR(std::sin(a.critical_angle_deg / kDeg) * 1.333, 1.0, 1e-12);
  EXPECT_NEAR(a.apparent_focal_length_mm, 1.333 * 24, 1e-9);
  EXPECT_NEAR(a.focal_length_increase_pct, 33.3, 1e-9);
}

TEST(Flat, RealPortFieldOfViewFollowsSnell) {
  const FlatAnalysis a = AnalyseFlat(FlatSetup(catalogue::LoadPort("flat-acrylic-10mm"), 1.341), {.wd_mm = 1000});
  // A plate with parallel faces: n_w sin θ_w = sin θ_a for every edge ray, whatever its thickness.
  EXPECT_NEAR(a.water_traced.horizontal_deg, a.water_thin.horizontal_deg, 1e-9);
  EXPECT_NEAR(a.water_traced.diagonal_deg, a.water_thin.diagonal_deg, 1e-9);
  EXPECT_LT(a.water_traced.diagonal_deg, a.air.diagonal_deg);
  // The real port starts the water rays 20 mm + 10 mm ahead of the pupil, displaced sideways: it
  // covers more of the scene at 1 m than a thin port at the pupil.
  EXPECT_GT(a.coverage_traced_mm, a.coverage_thin_mm);
  const double ta = 0.5 * a.air.horizontal_deg / kDeg, tw = 0.5 * a.water_thin.horizontal_deg / kDeg;
  const double tg = std::asin(std::sin(ta) / a.n_glass);
  EXPECT_NEAR(a.coverage_traced_mm, 2 * (20 * std::tan(ta) + 10 * std::tan(tg) + 1000 * std::tan(tw)), 1e-6);
  // Blue is refracted more: its image lies farther out (positive blue-minus-red), growing with angle.
  EXPECT_GT(a.n_water_blue, a.n_water_red);
  EXPECT_GT(a.lateral_colour_corner_px, 1);
  for (std::size_t k = 1; k < a.rows.size(); ++k) {
    EXPECT_GT(a.rows[k].lateral_colour_px, a.rows[k - 1].lateral_colour_px);
    EXPECT_GT(a.rows[k].distortion_px, a.rows[k - 1].distortion_px);  // pincushion
  }
}

// Issue 12: a 10 mm lens on the D300 (110 deg across the diagonal in air) behind the 10 mm acrylic
// port. Light from the air into the water is never totally reflected: the corner ray must trace
// into the water, and no warning may claim that the corners see the housing by total reflection.
// What limits the field is the critical angle for light coming in (the water field stays below
// 2 asin(1/n_w)) and the port's aperture (the corner rays' radius on the outer face, closed form).
TEST(Flat, WideLensIsLimitedByTheCriticalAngleInwardAndTheAperture) {
  planning::Setup s = FlatSetup(catalogue::LoadPort("flat-acrylic-10mm"), 1.341);
  s.lens.focal_length_mm = 10;
  const FlatAnalysis a = AnalyseFlat(s, {.wd_mm = 1000});
  ASSERT_GT(a.air.diagonal_deg, a.max_fov_deg);
  for (const FlatRow& r : a.rows) EXPECT_TRUE(std::isfinite(r.distortion_factor_traced)) << r.theta_air_deg;
  EXPECT_LT(a.water_traced.diagonal_deg, a.max_fov_deg);
  // Snell through parallel faces: n_w sin(θ_w) = sin(θ_a) at the corner.
  EXPECT_NEAR(a.n_water * std::sin(0.5 * a.water_traced.diagonal_deg / kDeg), std::sin(0.5 * a.air.diagonal_deg / kDeg),
              1e-9);
  for (const std::string& w : a.warnings) {
    EXPECT_EQ(w.find("inside of the housing"), std::string::npos) << w;
    EXPECT_EQ(w.find("total internal reflection"), std::string::npos) << w;
  }
  // The corner ray leaves the pupil at θ_a, crosses 20 mm of air and 10 mm of acrylic.
  const double ta = 0.5 * a.air.diagonal_deg / kDeg, tg = std::asin(std::sin(ta) / a.n_glass);
  EXPECT_NEAR(a.corner_outer_radius_mm, 20 * std::tan(ta) + 10 * std::tan(tg), 1e-9);
  EXPECT_NEAR(a.clear_aperture_needed_mm, 2 * a.corner_outer_radius_mm, 1e-12);
  bool names_critical = false, names_aperture = false;
  for (const std::string& w : a.warnings) {
    names_critical |= w.find("critical angle") != std::string::npos;
    names_aperture |= w.find("clear aperture") != std::string::npos;
  }
  EXPECT_TRUE(names_critical);
  EXPECT_TRUE(names_aperture);
}

TEST(Flat, RejectsADome) { EXPECT_THROW(AnalyseFlat(FlatSetup(catalogue::LoadPort("nimar-ni320"), 1.341), {}), InvalidInput); }

}  // namespace
}  // namespace porthole::planning
