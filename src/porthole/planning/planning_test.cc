// Proves the dive plan against the paper (Section 4 depth of field, Fig. 12 minimum working
// distances from Tables 2 and 5) and against closed forms (thin-lens limits and their inverses,
// a concentric dome preserving the field of view, the pupil moving with focus).
#include "porthole/planning/plan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"
#include "porthole/planning/thin_lens.h"

namespace porthole::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::map<std::string, double> PaperSection4() {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/menna2016_section4_dof.csv");
  EXPECT_TRUE(in.good());
  std::map<std::string, double> v;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("quantity", 0) == 0) continue;
    const auto comma = line.find(',');
    v[line.substr(0, comma)] = std::stod(line.substr(comma + 1));
  }
  EXPECT_EQ(v.size(), 11u);
  return v;
}

Setup PaperSetup(const std::string& lens = "nikkor-24mm-f2.8d", const std::string& port = "nimar-ni320-nominal") {
  Setup s;
  s.camera = catalogue::LoadCamera("nikon-d300");
  s.lens = catalogue::LoadLens(lens);
  s.port = catalogue::LoadPort(port);
  s.env.water_index = 1.341;  // reproduces Table 5
  return s;
}

TEST(ThinLens, LimitsAndInverses) {
  // The paper's air case by hand: s = 1000, f = 24, N = 8, c = 0.015.
  const DofLimits d = ThinLensDof(1000, 24, 8, 0.015);
  EXPECT_NEAR(d.near_mm, 576000.0 / (576 + 0.12 * 976), 1e-9);
  EXPECT_NEAR(d.far_mm, 576000.0 / (576 - 0.12 * 976), 1e-9);
  // The blur at each limit is the circle of confusion; the far-limit inverse round-trips.
  EXPECT_NEAR(BlurDiameterMm(1000, d.near_mm, 24, 8), 0.015, 1e-12);
  EXPECT_NEAR(BlurDiameterMm(1000, d.far_mm, 24, 8), 0.015, 1e-12);
  EXPECT_NEAR(FocusForFarLimitMm(d.far_mm, 24, 8, 0.015), 1000, 1e-9);
  const double h = FocusForFarLimitMm(kInf, 24, 8, 0.015);
  EXPECT_NEAR(h, 24 + 576 / 0.12, 1e-12);
  EXPECT_TRUE(std::isinf(ThinLensDof(h, 24, 8, 0.015).far_mm));
  EXPECT_NEAR(ThinLensDof(h, 24, 8, 0.015).near_mm, h / 2, 1e-9);
  // A +2 dioptre close-up: a subject at 250 mm looks like one at 500 mm.
  EXPECT_NEAR(ApparentDistanceWithCloseupMm(250, 2), 500, 1e-9);
  EXPECT_NEAR(CloseupDioptreNeeded(250, 500), 2, 1e-12);
  EXPECT_EQ(CloseupDioptreNeeded(600, 500), 0);
}

TEST(Plan, MinimumWorkingDistanceFig12) {
  const auto paper = PaperSection4();
  // Linear interpolation of Table 5 at Table 2's closest D_S2EP (226.6 and 176.6 mm) bounds the
  // answer from above (D_S2EP(WD) is concave); the acceptance windows bound it below.
  const Plan p24 = MakePlan(PaperSetup(), {});
  EXPECT_NEAR(p24.closest_d_s2ep_mm, 226.6, 1e-9);  // Table 2
  EXPECT_GE(p24.min_wd_mm, 680);
  EXPECT_LE(p24.min_wd_mm, 500 + 250 * (226.6 - 210.8) / (229.4 - 210.8));
  EXPECT_LE(p24.min_wd_mm, paper.at("min_wd_nikkor_24mm"));
  const Plan p35 = MakePlan(PaperSetup("nikkor-35mm-f2d"), {});
  EXPECT_NEAR(p35.closest_d_s2ep_mm, 176.6, 1e-9);
  EXPECT_GE(p35.min_wd_mm, 240);
  EXPECT_LE(p35.min_wd_mm, 200 + 100 * (176.6 - 164.1) / (184.9 - 164.1));
  EXPECT_LE(p35.min_wd_mm, paper.at("min_wd_nikkor_35mm"));
  // The virtual image of the minimum WD is exactly the lens's closest focus.
  EXPECT_NEAR(ports::ParaxialVirtualImage(p24.system, p24.min_wd_mm).d_s2ep_mm, 226.6, 1e-6);
  EXPECT_NEAR(p24.d_s2ep_infinity_mm, 288.5, 0.2);  // Table 5, infinity
}

TEST(Plan, Section4DepthOfField) {
  const auto paper = PaperSection4();
  PlanOptions o;
  o.subject_distance_mm = 1000;
  o.f_number = 8;
  o.coc_mm = 0.015;
  const Plan p = MakePlan(PaperSetup(), o);
  ASSERT_TRUE(p.target);
  const TargetPlan& t = *p.target;
  EXPECT_NEAR(t.water.virtual_focus_mm, paper.at("water_virtual_focus"), 1.0);
  EXPECT_NEAR(t.water.virtual_near_mm, paper.at("water_virtual_near"), 1.0);
  EXPECT_NEAR(t.water.virtual_far_mm, paper.at("water_virtual_far"), 1.0);
  EXPECT_NEAR(t.water.near_mm, paper.at("water_near"), 0.02 * paper.at("water_near"));
  EXPECT_NEAR(t.water.far_mm, paper.at("water_far"), 0.03 * paper.at("water_far"));
  EXPECT_NEAR(t.air.near_mm, paper.at("air_near"), 3);
  EXPECT_NEAR(t.air.far_mm, 1255, 3);  // the thin-lens value; the paper prints 1260 (rounded)
  EXPECT_NEAR(t.air.total_mm, t.air.far_mm - t.air.near_mm, 1e-9);
  EXPECT_NEAR(t.water.total_mm, t.water.far_mm - t.water.near_mm, 1e-9);
  // Under water the limits, pushed back through the port, land on the thin-lens virtual limits.
  EXPECT_NEAR(ports::ParaxialVirtualImage(p.system, t.water.near_wd_mm).d_s2ep_mm, t.water.virtual_near_mm, 1e-6);
  EXPECT_GT(t.dof_ratio_water_to_air, 1.2);
  EXPECT_LT(t.dof_ratio_water_to_air, 1.45);
  // The focus is reachable (238 > 226.6) and set by Eq. 2.
  ASSERT_TRUE(t.focus.focus_distance_mm);
  EXPECT_NEAR(*t.focus.focus_distance_mm - 46.5 - t.focus.ep_to_flange_mm, t.focus.d_s2ep_mm, 1e-6);
  EXPECT_EQ(t.focus.closeup_dioptre, 0);
}

TEST(Plan, ConcentricDomeKeepsTheFieldOfView) {
  PlanOptions o;
  o.wd_mm = 1000;
  const Plan p = MakePlan(PaperSetup(), o);
  EXPECT_NEAR(p.fov.water.horizontal_deg, p.fov.air.horizontal_deg, 1e-9);
  EXPECT_NEAR(p.fov.water.diagonal_deg, p.fov.air.diagonal_deg, 1e-9);
  const double c = p.principal_distance_mm;
  EXPECT_NEAR(p.fov.air.horizontal_deg, 2 * std::atan(0.5 * 4288 * 0.0055 / c) * 180 / M_PI, 1e-9);
}

TEST(Plan, FieldCurvatureBlursTheCorners) {
  PlanOptions o;
  o.wd_mm = 1000;
  o.coc_mm = 0.015;
  const Plan p = MakePlan(PaperSetup(), o);
  ASSERT_TRUE(p.target && p.target->field);
  const FieldCurvature& fc = *p.target->field;
  ASSERT_EQ(fc.rows.size(), 11u);
  EXPECT_NEAR(fc.rows.front().blur_px, 0, 1e-9);
  // A concentric dome images a flat object plane onto a surface curving toward the camera: the
  // off-axis virtual image of a farther object point is still nearer than the axial one.
  for (std::size_t k = 1; k < fc.rows.size(); ++k) {
    EXPECT_GT(fc.rows[k].sag_mm, fc.rows[k - 1].sag_mm) << k;
    EXPECT_GT(fc.rows[k].object_height_mm, fc.rows[k - 1].object_height_mm);
  }
  // Stopping down to the f-number reported removes the corner blur (thin lens: blur ∝ 1/N).
  PlanOptions o2 = o;
  o2.f_number = std::clamp(fc.f_number_for_sharp_corners, 2.8, 22.0);
  const Plan p2 = MakePlan(PaperSetup(), o2);
  if (fc.f_number_for_sharp_corners <= 22) {
    EXPECT_NEAR(p2.target->field->corner_blur_px * 0.0055, 0.015, 0.0015);
  }
}

TEST(Plan, AsBuiltDomeMovesThePupilWithFocus) {
  // Housing-frame dome: the pupil sits at D_EP2F(FD) of the solved focus, consistently.
  PlanOptions o;
  o.wd_mm = 1000;
  const Plan p = MakePlan(PaperSetup("nikkor-24mm-f2.8d", "nimar-ni320"), o);
  const TargetPlan& t = *p.target;
  ASSERT_TRUE(t.focus.focus_distance_mm);
  const lens::LensSpec l = catalogue::LoadLens("nikkor-24mm-f2.8d");
  EXPECT_NEAR(p.system.ep_in_housing_mm.z(), l.PupilToFlangeMm(*t.focus.focus_distance_mm), 1e-8);
  EXPECT_NEAR(ports::ParaxialVirtualImage(p.system, 1000).d_s2ep_mm,
              *t.focus.focus_distance_mm - 46.5 - p.system.ep_in_housing_mm.z(), 1e-6);
  EXPECT_GT(p.system.ep_in_housing_mm.z(), 24.6);  // moved forward from its infinity position
  EXPECT_LT(p.system.ep_in_housing_mm.z(), 26.9);
}

TEST(Plan, BadInputNamesTheFlag) {
  PlanOptions o;
  o.wd_mm = -5;
  try {
    MakePlan(PaperSetup(), o);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "wd_mm");
  }
  o.wd_mm.reset();
  o.subject_distance_mm = 50;  // the dome's outer surface is 83.4 mm from the pupil
  EXPECT_THROW(MakePlan(PaperSetup(), o), InvalidInput);
  PlanOptions n;
  n.f_number = 32;
  try {
    MakePlan(PaperSetup(), n);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "f_number");
  }
}

TEST(Plan, CloseupBringsACloserSubjectIntoReach) {
  PlanOptions o;
  o.wd_mm = 300;  // inside the 24 mm's minimum WD
  const Plan p = MakePlan(PaperSetup(), o);
  const TargetPlan& t = *p.target;
  EXPECT_FALSE(t.focus.focus_distance_mm);
  EXPECT_GT(t.focus.closeup_dioptre, 0);
  // With exactly that close-up the virtual image looks like the lens's closest subject.
  EXPECT_NEAR(ApparentDistanceWithCloseupMm(t.focus.d_s2ep_mm, t.focus.closeup_dioptre), p.closest_d_s2ep_mm,
              1e-6);
  // Each stronger close-up covers a nearer WD range.
  for (std::size_t k = 1; k < p.closeup.size(); ++k) EXPECT_LT(p.closeup[k].min_wd_mm, p.closeup[k - 1].min_wd_mm);
}

// Issue 12: a 16 mm lens focusing to 150 mm behind an 8-inch (R 101.6 / 93.6 mm) concentric dome
// focuses on the whole virtual-image range; the plan used to print "minimum working distance 0 mm"
// and "+2 dioptre: WD 0 to inf" as if the lens set them. It must say the glass sets the closest
// distance, give where that is, and mark close-up lenses as not needed. The image of an object
// touching the glass: the outer surface images it in place; the inner surface (glass → air,
// R2 = 93.6, object t = 8 mm before it) puts it at 1/s' = (1 − n_g)/R2 − n_g/t (closed form).
TEST(Plan, WideLensBehindALargeDomeIsLimitedByTheGlassNotTheLens) {
  planning::Setup s = PaperSetup();
  ports::PortSpec dome;
  dome.name = "8in";
  dome.frame = ports::PortFrame::kCam;
  ports::DomePort d;
  d.outer.radius_mm = 101.6;
  d.inner.radius_mm = 93.6;
  dome.shape = d;
  s.port = dome;
  s.env.glass_index = 1.5168;
  s.lens.focal_length_mm = 16;
  s.lens.min_focus_mm = 150;
  s.lens.pupil = {{kInf, 40.0}};
  const Plan p = MakePlan(s, {});
  ASSERT_LT(p.closest_d_s2ep_mm, 101.6);  // 150 − 46.5 − 40 = 63.5 mm: nearer than the glass
  EXPECT_TRUE(p.lens_covers_virtual_range);
  EXPECT_EQ(p.min_wd_mm, 0);
  const double ng = p.system.n_glass;
  ASSERT_NEAR(ng, 1.5168, 1e-12);
  EXPECT_NEAR(p.d_s2ep_touching_mm, 93.6 - 1 / ((1 - ng) / 93.6 - ng / 8.0), 1e-6);
  EXPECT_NEAR(p.pupil_to_outer_mm, 101.6, 1e-9);
  for (const CloseupRow& r : p.closeup) EXPECT_FALSE(r.needed) << r.dioptre;
  bool says_glass = false;
  for (const std::string& w : p.warnings) says_glass |= w.find("whole virtual-image range") != std::string::npos;
  EXPECT_TRUE(says_glass);
  // The paper's 24 mm behind the NI320 does not reach the glass: its minimum WD is the lens's.
  const Plan paper = MakePlan(PaperSetup(), {});
  EXPECT_FALSE(paper.lens_covers_virtual_range);
  for (const CloseupRow& r : paper.closeup) EXPECT_TRUE(r.needed);
}

// Issue 12, advice: the extension ring that puts the pupil at the dome's centre. The paper's as-built
// NI320 with the 24 mm focused under water at 1 m: the pupil is 5.4 mm ahead of the outer sphere's
// centre (Table 4: pupil at 26.9 mm, centre at 21.5 mm from the flange) and sqrt(0.4² + 1.0²) mm
// off its axis. A port moved forward by the advised length, refocused, has the pupil at its centre.
TEST(Plan, ExtensionRingThatCentresThePupil) {
  PlanOptions o;
  o.wd_mm = 1000;
  const planning::Setup s = PaperSetup("nikkor-24mm-f2.8d", "nimar-ni320");
  const Plan p = MakePlan(s, o);
  ASSERT_TRUE(p.centring.has_value());
  const PupilCentring& c = *p.centring;
  EXPECT_NEAR(c.axial_offset_mm, 26.9 - 21.5, 0.1);  // Table 4, to its 0.1 mm (pupil at FD 300; here farther)
  EXPECT_NEAR(c.axial_offset_mm, p.system.ep_in_housing_mm.z() - 21.5, 1e-9);
  EXPECT_NEAR(c.lateral_offset_mm, std::hypot(0.4, 1.0), 1e-9);
  ASSERT_TRUE(c.focus_distance_mm.has_value());
  EXPECT_NEAR(*c.focus_distance_mm, *p.target->focus.focus_distance_mm, 1e-6);
  // Closed loop: move the port by the advised length and plan again.
  planning::Setup moved = s;
  auto& d = std::get<ports::DomePort>(moved.port.shape);
  d.outer.center_mm.z() += c.extension_mm;
  d.inner.center_mm.z() += c.extension_mm;
  const Plan after = MakePlan(moved, o);
  EXPECT_NEAR(after.centring->axial_offset_mm, 0, 1e-6);
  EXPECT_NEAR(after.centring->extension_mm, 0, 1e-6);
  // The ring is the offset to first order; refocusing moves the pupil by less than 0.1 mm here.
  EXPECT_NEAR(c.extension_mm, c.axial_offset_mm, 0.1);
  // A concentric dome written about the pupil is centred whatever the lens; a flat port has no centre.
  const Plan nominal = MakePlan(PaperSetup(), o);
  EXPECT_NEAR(nominal.centring->axial_offset_mm, 0, 1e-12);
  EXPECT_NEAR(nominal.centring->extension_mm, 0, 1e-12);
  EXPECT_FALSE(MakePlan(PaperSetup("nikkor-24mm-f2.8d", "flat-acrylic-10mm"), o).centring.has_value());
}

}  // namespace
}  // namespace porthole::planning
