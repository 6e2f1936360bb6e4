// Proves Eq. 2 and the entrance-pupil interpolation against the paper's Table 2, and the mount list.
#include "porthole/lens/lens.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "porthole/core/error.h"

namespace porthole::lens {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

LensSpec Nikkor35() {  // Menna et al. 2016, Table 2
  LensSpec l;
  l.name = "nikkor-35mm-f2d";
  l.mount = "nikon-f";
  l.focal_length_mm = 35;
  l.f_number_min = 2;
  l.f_number_max = 22;
  l.min_focus_mm = 250;
  l.pupil = {{kInf, 18.6}, {300, 25.4}, {250, 26.9}};
  return l;
}

TEST(Lens, Eq2ReproducesTable2) {
  const Mount& f = MountByName("nikon-f");
  EXPECT_EQ(f.flange_focal_distance_mm, 46.5);
  // Table 2: D_S2EP at FD 300 mm = 228.1, at FD 250 mm = 176.6.
  EXPECT_NEAR(SubjectToPupilMm(Nikkor35(), f, 300), 228.1, 1e-9);
  EXPECT_NEAR(SubjectToPupilMm(Nikkor35(), f, 250), 176.6, 1e-9);
  EXPECT_TRUE(std::isinf(SubjectToPupilMm(Nikkor35(), f, kInf)));
}

TEST(Lens, PupilInterpolatesInReciprocalFocusAndRejectsTooClose) {
  const LensSpec l = Nikkor35();
  EXPECT_EQ(l.PupilToFlangeMm(kInf), 18.6);
  // Halfway in 1/FD between infinity (0) and 300 mm (1/300) is FD = 600 mm.
  EXPECT_NEAR(l.PupilToFlangeMm(600), 0.5 * (18.6 + 25.4), 1e-12);
  EXPECT_THROW(l.PupilToFlangeMm(200), InvalidInput);
}

TEST(Lens, FocusForSubjectInvertsEq2) {
  const Mount& f = MountByName("nikon-f");
  const LensSpec l = Nikkor35();
  for (double fd : {250.0, 280.0, 300.0, 450.0, 1000.0, 5000.0}) {
    const auto back = FocusForSubjectMm(l, f, SubjectToPupilMm(l, f, fd));
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(*back, fd, 1e-6 * fd);
  }
  EXPECT_FALSE(FocusForSubjectMm(l, f, 150).has_value());  // closer than 176.6 mm: out of reach
}

TEST(Lens, DefaultFNumberIsF8OrTheNearestTheLensHas) {
  LensSpec l = Nikkor35();
  EXPECT_EQ(DefaultFNumber(l), 8.0);  // f/2-22 has f/8
  l.f_number_min = l.f_number_max = 2.8;  // a fixed aperture (an action camera): its own
  EXPECT_EQ(DefaultFNumber(l), 2.8);
  l.f_number_min = 2.8;
  l.f_number_max = 5.6;  // stops at f/5.6: the nearest to f/8
  EXPECT_EQ(DefaultFNumber(l), 5.6);
  l.f_number_min = 11;
  l.f_number_max = 32;  // a mirror lens at f/11 and beyond
  EXPECT_EQ(DefaultFNumber(l), 11.0);
}

TEST(Lens, MountsAndValidation) {
  EXPECT_EQ(MountByName("mft").flange_focal_distance_mm, 19.25);
  EXPECT_EQ(MountByName("pentax-k").flange_focal_distance_mm, 45.46);
  EXPECT_EQ(MountByName("fixed").flange_focal_distance_mm, 0.0);
  EXPECT_EQ(KnownMounts().size(), 10u);
  EXPECT_THROW(MountByName("leica-m"), InvalidInput);
  LensSpec bad = Nikkor35();
  bad.pupil = {{300, 25.4}, {kInf, 18.6}};  // unsorted
  EXPECT_THROW(Validate(bad), InvalidInput);
  bad = Nikkor35();
  bad.f_number_max = 1;
  EXPECT_THROW(Validate(bad), InvalidInput);
}

// The pupil's distance from the sensor (FFD + D_EP2F) is what a lens's optical design fixes: on an
// adapter, or on another of its mounts, Eq. 2 gives the same subject distance for the same FD.
TEST(Lens, MountingKeepsThePupilsDistanceFromTheSensor) {
  const LensSpec l = Nikkor35();
  CameraBody sony;
  sony.name = "a sony";
  sony.mount = "sony-e";
  sony.sensor = {6000, 4000, 0.006};
  EXPECT_THROW(MountOn(l, sony), InvalidInput);  // no adapter allowed
  const LensSpec a = MountOn(l, sony, /*allow_adapter=*/true);
  EXPECT_EQ(a.mount, "sony-e");
  for (double fd : {kInf, 1000.0, 300.0}) {
    EXPECT_NEAR(a.PupilToFlangeMm(fd), l.PupilToFlangeMm(fd) + 46.5 - 18.0, 1e-12);
    if (!std::isinf(fd)) {
      EXPECT_NEAR(SubjectToPupilMm(a, MountByName("sony-e"), fd), SubjectToPupilMm(l, MountByName("nikon-f"), fd),
                  1e-9);
    }
  }
  LensSpec multi = l;
  multi.other_mounts = {"sony-e"};
  EXPECT_NEAR(MountOn(multi, sony).PupilToFlangeMm(kInf), l.PupilToFlangeMm(kInf) + 28.5, 1e-12);
  // A short-flange lens cannot reach infinity on a long-flange body, adapter or not.
  CameraBody nikon = sony;
  nikon.mount = "nikon-f";
  LensSpec e = l;
  e.mount = "sony-e";
  EXPECT_THROW(MountOn(e, nikon, true), InvalidInput);
}

TEST(Lens, ThinLensPrincipalDistanceAndProjection) {
  EXPECT_NEAR(PrincipalDistanceMm(24, 1000), 24 * 1000 / 976.0, 1e-12);
  EXPECT_EQ(PrincipalDistanceMm(24, kInf), 24);
  EXPECT_THROW(PrincipalDistanceMm(24, 20), InvalidInput);
  LensSpec l = Nikkor35();
  l.projection = camera::Projection::kEquisolid;
  // Equisolid r = 2 f sin(θ/2): 90° off axis at f·√2.
  EXPECT_NEAR(ImageRadiusMm(l, 10, M_PI / 2), 10 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(*FieldAngleRad(l, 10, 10 * std::sqrt(2.0)), M_PI / 2, 1e-12);
}

}  // namespace
}  // namespace porthole::lens
