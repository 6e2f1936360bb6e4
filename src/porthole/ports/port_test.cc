// Proves that port geometry is validated field by field and placed in the housing frame correctly.
#include "porthole/ports/port.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

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

// ---- Every shape of the list: its data and its refractive-camera members agree ----

// One placed example per shape (its pupil, off every symmetry), the only line a new shape adds.
template <typename S>
S Example();
template <>
DomePort Example<DomePort>() {
  DomePort d;
  d.outer = {Vec3(-0.4, -1.0, 21.5), 83.4};
  d.inner = {Vec3(-0.4, -1.5, 20.3), 75.7};
  d.rim_z_mm = 18.0;
  return d;
}
template <>
FlatPort Example<FlatPort>() {
  FlatPort f;
  f.normal = Vec3(0.05, -0.03, 1).normalized();
  f.inner_point_mm = Vec3(1, 2, 50);
  f.thickness_mm = 10;
  return f;
}
template <>
CylinderPort Example<CylinderPort>() {
  CylinderPort c;
  c.axis = Vec3(std::sin(0.2), std::cos(0.2), 0);
  c.axis_point_mm = Vec3(1.5, 0, 30);
  c.inner_radius_mm = 50.8;
  c.outer_radius_mm = 57.15;
  c.rim_z_mm = 25.0;
  return c;
}

template <typename S>
class EveryShape : public ::testing::Test {};
using Shapes = ::testing::Types<DomePort, FlatPort, CylinderPort>;
TYPED_TEST_SUITE(EveryShape, Shapes);

// docs/conventions.md: a JSON key ends in its unit ("_mm", "_deg"), unless it has none ("1").
void ExpectUnitsInKeys(const ParamInfo* p, std::size_t n, std::string_view shape) {
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_FALSE(p[i].name.empty()) << shape;
    if (p[i].unit != "1") EXPECT_TRUE(p[i].json_key.ends_with("_" + std::string(p[i].unit))) << p[i].json_key;
    for (std::size_t j = 0; j < i; ++j) EXPECT_NE(p[i].json_key, p[j].json_key) << shape;
  }
}

TYPED_TEST(EveryShape, StatesItsDataOnce) {
  using S = TypeParam;
  ExpectUnitsInKeys(S::kPortParams.data(), S::kPortParams.size(), S::kName);
  ExpectUnitsInKeys(S::kShellParams.data(), S::kShellParams.size(), S::kName);
  EXPECT_TRUE(S::kPortParamsMeaning.starts_with(std::string(S::kName) + ": "));
  for (double sigma : S::kDefaultPredictedSigma) EXPECT_GT(sigma, 0);
  // The start's first candidate is the prediction itself.
  ASSERT_GE(S::kAxialSearch.param, 0);
  ASSERT_LT(S::kAxialSearch.param, 3);
  EXPECT_EQ(S::kAxialSearch.Candidates(7.5).front(), 7.5);
  // Its name finds it in the list.
  const auto shape = ShapeNamed(S::kName);
  ASSERT_TRUE(shape.has_value());
  EXPECT_TRUE(std::holds_alternative<S>(*shape));
  EXPECT_FALSE(ShapeNamed("no-such-shape").has_value());
  // Every plausible value is one of its port-file keys (what the warning names).
  const S example = Example<S>();
  std::vector<std::string> keys;
  S::Fields(example, [&](std::string_view key, const auto&, FieldUse) { keys.emplace_back(key); });
  for (const PlausibleValue& v : example.PlausibleValues()) {
    if (v.key != "thickness_mm") EXPECT_NE(std::find(keys.begin(), keys.end(), v.key), keys.end()) << v.key;
  }
}

// Its parameters and shell, as placed in the housing frame (PortParams, AsShell), make in the cam
// frame (SurfacesAt) the surfaces of the same shape moved by the pupil (AtSurfaces): the two
// statements of what its parameters mean agree; and its shell values read back what they set.
TYPED_TEST(EveryShape, ParametersAndShellDescribeIt) {
  using S = TypeParam;
  const S s = Example<S>();
  const Vec3 ep(0.3, -0.2, 26.9);
  ASSERT_NO_THROW(s.RequirePupilInside(ep));
  const auto p = s.PortParams(ep);
  const CamShell shell = s.AsShell();
  CamSurfaces<double> g;
  g.n_glass = 1.5;
  g.n_water = 1.34;
  S::template SurfacesAt<double>(shell, p.data(), nullptr, &g);
  S back = S::AtSurfaces(g);
  back.Translate(ep);
  const auto q = back.PortParams(ep);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(q[i], p[i], 1e-12) << S::kName << " parameter " << i;
  const auto v = S::ShellValues(shell);
  const auto w = S::ShellValues(back.AsShell());
  for (std::size_t i = 0; i < v.size(); ++i) EXPECT_NEAR(w[i], v[i], 1e-12) << S::kName << " shell value " << i;
  EXPECT_NEAR(back.AsShell().rim_from_outer_z_mm, shell.rim_from_outer_z_mm, 1e-12);
  // The same surfaces trace the same rays as the shape placed in the housing frame.
  const auto cam = S::template InterfacesAt<double>(g);
  const auto housing = s.Outward(1.5, 1.34);
  const Vec3 dir = Vec3(0.2, -0.1, 1).normalized();
  optics::Ray a, b;
  ASSERT_EQ(optics::TraceSequence<double>({housing.begin(), housing.end()}, {ep, dir}, &a), optics::RayStatus::kOk);
  ASSERT_EQ(optics::TraceSequence<double>({cam.begin(), cam.end()}, {Vec3::Zero(), dir}, &b), optics::RayStatus::kOk);
  EXPECT_LE((a.origin - ep - b.origin).norm(), 1e-9) << S::kName;
  EXPECT_LE((a.dir - b.dir).norm(), 1e-12) << S::kName;
  EXPECT_TRUE(S::InWater(g, b.origin + 100 * b.dir));
  EXPECT_FALSE(S::InWater(g, Vec3::Zero()));
  // Values set are values read; values that are no shell are refused.
  CamShell other;
  std::array<double, S::kShellParams.size()> set{};
  for (std::size_t i = 0; i < set.size(); ++i) set[i] = v[i] + 0.25 * (i + 1);
  S::SetShellValues(set.data(), &other);
  EXPECT_EQ(S::ShellValues(other), set);
  EXPECT_NO_THROW(S::ValidateShellValues(v.data(), "shell"));
  std::array<double, S::kShellParams.size()> bad = v;
  bad[S::kShellParams.size() > 1 ? 1 : 0] = -1;  // an inner radius or a thickness
  EXPECT_THROW(S::ValidateShellValues(bad.data(), "shell"), InvalidInput);
}

// Its x–z section (Section: the report's cross-section, the paraxial trace) lies on its traced
// surfaces; off its symmetry it does not claim to revolve about the axis through the pupil; and its [sigma] prior (ShellPrior) names its own shell values.
TYPED_TEST(EveryShape, SectionAndPriorDescribeIt) {
  using S = TypeParam;
  const S s = Example<S>();
  const PortSection sec = s.Section();
  EXPECT_EQ(sec.outer.IsCircle(), sec.inner.IsCircle()) << S::kName;
  // A pupil in the section's plane (y = 0) on the line x = the outer centre's x.
  const Vec3 ep(sec.outer.center_mm.x(), 0, 26.9);
  ASSERT_NO_THROW(s.RequirePupilInside(ep));
  // Where the line {ep + t ẑ} meets each section curve: a circle's top, a plane through its point.
  const auto top = [&](const SectionCurve& c) {
    if (!c.IsCircle()) return c.center_mm.z();
    const Vec3 d = ep - c.center_mm;
    return c.center_mm.z() + std::sqrt(c.radius_mm * c.radius_mm - d.x() * d.x() - d.y() * d.y());
  };
  const double outer_z = top(sec.outer);
  // On the outer surface: the circle's top, a plane's own point.
  const Vec3 on = sec.outer.IsCircle() ? Vec3(ep.x(), 0, outer_z) : sec.outer.center_mm;
  EXPECT_TRUE(s.InsideOuterSurface(on - Vec3(0, 0, 1e-6))) << S::kName;
  EXPECT_FALSE(s.InsideOuterSurface(on + Vec3(0, 0, 1e-6))) << S::kName;
  if (sec.outer.IsCircle()) {
    EXPECT_NEAR(s.VertexZ(ep, true), outer_z, 1e-9) << S::kName;
    EXPECT_NEAR(s.VertexZ(ep, false), top(sec.inner), 1e-9) << S::kName;
    if (sec.rim_z_mm) {
      EXPECT_LT(*sec.rim_z_mm, outer_z);
    }
  } else {
    const Vec3 at(sec.inner.center_mm.x(), sec.inner.center_mm.y(), 0);
    EXPECT_NEAR(s.VertexZ(at, false), sec.inner.center_mm.z(), 1e-9) << S::kName;
  }
  // Every example lies off every symmetry: an axial ray from this pupil bends, and none revolves.
  const auto out = s.Outward(1.5, 1.34);
  optics::Ray r;
  const Vec3 off(0.3, -0.2, 26.9);
  ASSERT_EQ(optics::TraceSequence<double>({out.begin(), out.end()}, {off, Vec3(0, 0, 1)}, &r), optics::RayStatus::kOk);
  EXPECT_GT((r.dir - Vec3(0, 0, 1)).norm(), 1e-6) << S::kName;
  EXPECT_FALSE(s.RevolvesAbout(off)) << S::kName;
  // Every σ stated: each row names shell values of this shape, and frees one it names.
  ShellSigma all;
  all.outer_radius_mm = all.inner_radius_mm = all.thickness_mm = 0.1;
  all.inner_offset_mm = Vec3(0.1, 0.1, 0.1);
  int rows = 0;
  S::ShellPrior(all, [&](const std::optional<double>& sigma, std::initializer_list<std::pair<int, double>> terms,
                         int frees) {
    if (!sigma) return;
    ++rows;
    bool names_freed = false;
    for (const auto& [i, c] : terms) {
      EXPECT_GE(i, 0);
      EXPECT_LT(i, static_cast<int>(S::kShellParams.size())) << S::kName;
      names_freed |= i == frees && c != 0;
    }
    EXPECT_TRUE(names_freed) << S::kName;
  });
  EXPECT_GE(rows, static_cast<int>(S::kShellParams.size())) << S::kName;  // each value can be given a σ
}

// RevolvesAbout where the shape is a surface of revolution about the axis through the pupil (a
// dome with both centres on it, a flat port square to it): the axial ray goes straight through, as
// the paraxial trace assumes; off that axis, or tilted, it is not one.
TEST(RevolvesAbout, OnlyWhereTheAxialRayGoesStraight) {
  DomePort d;
  d.outer = {Vec3(0.5, -1.0, 21.5), 83.4};
  d.inner = {Vec3(0.5, -1.0, 20.3), 75.7};
  FlatPort square;
  square.inner_point_mm = Vec3(1, 2, 50);
  square.thickness_mm = 10;
  FlatPort tilted = square;
  tilted.normal = Vec3(0.05, 0, 1).normalized();
  const Vec3 on(0.5, -1.0, 26.9), off(0.5, -0.7, 26.9);
  const auto straight = [](const TwoInterfaces<double>& out, const Vec3& pupil) {
    optics::Ray r;
    EXPECT_EQ(optics::TraceSequence<double>({out.begin(), out.end()}, {pupil, Vec3(0, 0, 1)}, &r), optics::RayStatus::kOk);
    return (r.dir - Vec3(0, 0, 1)).norm() < 1e-12 && (r.origin - pupil).head<2>().norm() < 1e-9;
  };
  EXPECT_TRUE(d.RevolvesAbout(on));
  EXPECT_TRUE(straight(d.Outward(1.5, 1.34), on));
  EXPECT_FALSE(d.RevolvesAbout(off));
  EXPECT_FALSE(straight(d.Outward(1.5, 1.34), off));
  EXPECT_TRUE(square.RevolvesAbout(off));
  EXPECT_TRUE(straight(square.Outward(1.5, 1.34), off));
  EXPECT_FALSE(tilted.RevolvesAbout(off));
  EXPECT_FALSE(straight(tilted.Outward(1.5, 1.34), off));
}

}  // namespace
}  // namespace porthole::ports
