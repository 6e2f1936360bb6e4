// Proves Eq. 2 and the entrance-pupil interpolation against the paper's Table 2, and the mount list.
#include "porthole/lens/lens.h"

#include <gtest/gtest.h>

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

TEST(Lens, MountsAndValidation) {
  EXPECT_EQ(MountByName("mft").flange_focal_distance_mm, 19.25);
  EXPECT_EQ(MountByName("pentax-k").flange_focal_distance_mm, 45.46);
  EXPECT_EQ(KnownMounts().size(), 9u);
  EXPECT_THROW(MountByName("leica-m"), InvalidInput);
  LensSpec bad = Nikkor35();
  bad.pupil = {{300, 25.4}, {kInf, 18.6}};  // unsorted
  EXPECT_THROW(Validate(bad), InvalidInput);
  bad = Nikkor35();
  bad.f_number_max = 1;
  EXPECT_THROW(Validate(bad), InvalidInput);
}

}  // namespace
}  // namespace porthole::lens
