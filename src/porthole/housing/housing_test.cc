// Proves the one focus solver: its fixed point satisfies Eq. 2 and the virtual image together, a
// pupil offset moves the pupil and not a cam-frame port, and a lens on an adapter or a fixed-lens
// camera keeps its pupil's distance from the sensor.
#include <gtest/gtest.h>

#include "porthole/housing/housed.h"
#include "porthole/catalogue/presets.h"
#include "porthole/ports/virtual_image.h"

namespace porthole::housing {
namespace {

HousedCamera Paper(const std::string& port = "nimar-ni320") {
  HousedCamera h;
  h.camera = catalogue::LoadCamera("nikon-d300");
  h.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  h.port = catalogue::LoadPort(port);
  return h;
}

TEST(Housing, FocusIsTheFixedPointOfEq2AndTheVirtualImage) {
  const HousedCamera h = Paper();
  const Focused f = FocusOnSubject(h, 1000);
  ASSERT_TRUE(f.focus.focus_distance_mm);
  const double fd = *f.focus.focus_distance_mm;
  // Eq. 2 at the solved focus gives the virtual image's distance, and the pupil is where the lens
  // puts it at that focus.
  EXPECT_NEAR(fd - 46.5 - h.lens.PupilToFlangeMm(fd), f.focus.d_s2ep_mm, 1e-6);
  EXPECT_NEAR(f.sys.ep_in_housing_mm.z(), h.lens.PupilToFlangeMm(fd), 1e-9);
  const double wd = 1000 - PupilToOuterMm(f.sys);
  EXPECT_NEAR(ports::ParaxialVirtualImage(f.sys, wd).d_s2ep_mm, f.focus.d_s2ep_mm, 1e-9);
}

TEST(Housing, OffsetMovesThePupilInsideACamFramePort) {
  HousedCamera h = Paper("nimar-ni320-nominal");
  h.ep_offset_mm = Vec3(0, 0, 5);
  const ports::PortSystem sys = SystemAtFocus(h, 1000);
  const Vec3 nominal = NominalPupilAtFocus(h, 1000);
  EXPECT_NEAR((sys.ep_in_housing_mm - nominal - Vec3(0, 0, 5)).norm(), 0, 1e-12);
  // The dome stays centred on the lens's own pupil: its outer vertex is R - 5 mm ahead of the pupil.
  EXPECT_NEAR(PupilToOuterMm(sys), 83.4 - 5, 1e-9);
}

TEST(Housing, UnreachableFocusIsReportedWithItsCloseup) {
  const Focused f = SolveFocus(Paper(), [](const ports::PortSystem&) { return 100.0; });
  EXPECT_FALSE(f.focus.focus_distance_mm);
  const lens::LensSpec l = catalogue::LoadLens("nikkor-24mm-f2.8d");
  const double closest = lens::SubjectToPupilMm(l, lens::MountByName("nikon-f"), l.min_focus_mm);
  EXPECT_NEAR(f.focus.closeup_dioptre, 1000.0 / 100 - 1000.0 / closest, 1e-12);
  EXPECT_THROW(FocusOnSubject(Paper(), 50), InvalidInput);  // inside the dome
}

TEST(Housing, ChiefRaysFollowTheProjectionBeyondNinetyDegrees) {
  lens::LensSpec l = catalogue::LoadLens("nikkor-24mm-f2.8d");
  const Vec3 r = *ChiefRay(l, 24, 10, 0);
  EXPECT_NEAR(std::atan2(r.x(), r.z()), std::atan(10.0 / 24), 1e-12);
  l.projection = camera::Projection::kEquidistant;
  const double c = 8;  // 8 mm equidistant: r = 16 mm is 2 rad = 114.6 deg off axis
  const Vec3 w = *ChiefRay(l, c, 0, 16);
  EXPECT_NEAR(std::acos(w.z()), 2.0, 1e-12);
  EXPECT_LT(w.y(), 0);  // image y up is camera Y up (negative)
  l.projection = camera::Projection::kOrthographic;
  EXPECT_FALSE(ChiefRay(l, c, 0, 9));  // beyond r = c
}

TEST(Housing, ValidateNamesTheField) {
  HousedCamera h = Paper();
  h.lens.mount = "canon-ef";
  try {
    Validate(h);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "lens");
  }
}

}  // namespace
}  // namespace porthole::housing
