// Proves that port geometry is validated field by field and placed in the housing frame correctly.
#include "porthole/ports/port.h"

#include <gtest/gtest.h>

#include <cmath>

#include "porthole/core/error.h"

namespace porthole::ports {
namespace {

PortSpec Dome(double r_out, double r_in) {
  PortSpec s;
  s.frame = PortFrame::kCam;
  DomePort d;
  d.outer.radius_mm = r_out;
  d.inner.radius_mm = r_in;
  s.shape = d;
  return s;
}

std::string FieldOf(const PortSpec& s, const Vec3& ep = Vec3(0, 0, 26.9)) {
  try {
    Place(s, ep, 1.5168, 1.341);
  } catch (const InvalidInput& e) {
    return e.field();
  }
  return "";
}

TEST(Port, RejectsBadDomesNamingTheField) {
  EXPECT_EQ(FieldOf(Dome(83.4, 83.4)), "port.inner.radius_mm");
  EXPECT_EQ(FieldOf(Dome(83.4, 90)), "port.inner.radius_mm");
  EXPECT_EQ(FieldOf(Dome(-1, -2)), "port.outer.radius_mm");
  EXPECT_EQ(FieldOf(Dome(NAN, 75.7)), "port.outer.radius_mm");
  PortSpec shifted = Dome(83.4, 75.7);
  std::get<DomePort>(shifted.shape).inner.center_mm = Vec3(0, 0, 8);  // pokes through the outer
  EXPECT_EQ(FieldOf(shifted), "port.inner.center_mm");
  PortSpec housing = Dome(83.4, 75.7);
  housing.frame = PortFrame::kHousing;  // centred on the flange: pupil 100 mm ahead is outside
  EXPECT_EQ(FieldOf(housing, Vec3(0, 0, 100)), "entrance_pupil_mm");
  EXPECT_EQ(FieldOf(housing, Vec3(0, NAN, 1)), "entrance_pupil_mm");
  EXPECT_EQ(FieldOf(Dome(83.4, 75.7)), "");
}

TEST(Port, RejectsBadFlatPorts) {
  PortSpec s;
  s.frame = PortFrame::kCam;
  FlatPort f;
  f.inner_point_mm = Vec3(0, 0, 20);
  f.thickness_mm = -1;
  s.shape = f;
  EXPECT_EQ(FieldOf(s), "port.thickness_mm");
  std::get<FlatPort>(s.shape).thickness_mm = 10;
  std::get<FlatPort>(s.shape).normal = Vec3(0, 0, 2);
  EXPECT_EQ(FieldOf(s), "port.normal");
  std::get<FlatPort>(s.shape).normal = Vec3(0, 0, 1);
  std::get<FlatPort>(s.shape).inner_point_mm = Vec3(0, 0, -5);  // plane behind the pupil
  EXPECT_EQ(FieldOf(s), "entrance_pupil_mm");
}

TEST(Port, CamFramePortsFollowThePupilAndAreCentral) {
  const PortSystem sys = Place(Dome(83.4, 75.7), Vec3(0.5, -1, 26.9), 1.5168, 1.341);
  EXPECT_EQ(sys.spec.frame, PortFrame::kHousing);
  EXPECT_NEAR((sys.dome().outer.center_mm - Vec3(0.5, -1, 26.9)).norm(), 0, 1e-12);
  EXPECT_TRUE(sys.IsCentral());
  EXPECT_NEAR(sys.OuterVertexZ(), 26.9 + 83.4, 1e-12);
  EXPECT_NEAR(sys.InnerVertexZ(), 26.9 + 75.7, 1e-12);
  PortSpec off = Dome(83.4, 75.7);
  std::get<DomePort>(off.shape).outer.center_mm = Vec3(0, 0, -5.4);
  std::get<DomePort>(off.shape).inner.center_mm = Vec3(0, 0, -5.4);
  EXPECT_FALSE(Place(off, Vec3(0, 0, 26.9), 1.5, 1.34).IsCentral());
}

TEST(Port, FlatPortFieldOfViewInWaterIsLimitedTo97p2Degrees) {
  // Snell across any plate: n_w sin θ_w = sin θ_a < 1, so the full field in water is at most
  // 2 asin(1/n_w) = 97.2° for n_w = 1.333 (the paper's Section 2.2 and Fig. 3), whatever the glass.
  PortSpec s;
  s.frame = PortFrame::kCam;
  FlatPort f;
  f.inner_point_mm = Vec3(0, 0, 20);
  f.thickness_mm = 10;
  s.shape = f;
  const PortSystem sys = Place(s, Vec3(0, 0, 26.9), 1.49, 1.333);
  double max_water_deg = 0;
  for (double a_deg = 0; a_deg < 90; a_deg += 0.01) {
    const double a = a_deg * M_PI / 180;
    optics::Ray out;
    ASSERT_EQ(optics::TraceSequence<double>(sys.Outward(), {sys.ep_in_housing_mm, Vec3(std::sin(a), 0, std::cos(a))},
                                            &out),
              optics::RayStatus::kOk);
    max_water_deg = std::max(max_water_deg, std::atan2(out.dir.x(), out.dir.z()) * 180 / M_PI);
  }
  EXPECT_NEAR(2 * max_water_deg, 97.2, 0.05);
  EXPECT_NEAR(2 * std::asin(1 / 1.333) * 180 / M_PI, 97.2, 0.05);
  // From the water, a ray steeper than the critical angle is totally reflected inside the port.
  const double w = 49.0 * M_PI / 180;
  optics::Ray in;
  EXPECT_EQ(optics::TraceSequence<double>(sys.Inward(), {Vec3(0, 0, 100), Vec3(std::sin(w), 0, -std::cos(w))}, &in),
            optics::RayStatus::kTotalInternalReflection);
}

}  // namespace
}  // namespace porthole::ports
