// Proves the exact forward projection through a port inverts the optics tracer: pixel → lens ray →
// Snell trace out through the port (optics::TraceSequence, the brute-force backward projection)
// → a point 0.2–20 m out → ForwardDirection → lens → the same pixel to 1e-9 px over the whole
// image, for flat ports tilted up to 5°, concentric and non-concentric domes with the pupil up to
// 10 mm off centre, the paper's as-built NI320 and cylindrical ports with the pupil on and off
// the axis; and that its Jets equal central differences.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "porthole/camera/camera.h"
#include "porthole/core/error.h"
#include "porthole/refraction/refraction.h"
#include "porthole/refraction/shell_json.h"
#include "porthole/refraction/test_camera.h"

namespace porthole::refraction {
namespace {

using camera::Camera;
using camera::CameraModelId;
using ports::DomePort;
using ports::FlatPort;
using ports::PortSpec;
using ports::PortSystem;

constexpr double kPi = 3.14159265358979323846;

using refraction::testing::D300Brown;

// A Kannala–Brandt fisheye close to the Nikkor 10.5 mm on the D300, cropped to 100° across.
Camera D300Fisheye() {
  Camera c = Camera::Ideal(CameraModelId::kKannalaBrandt, camera::Sensor{4288, 2848, 0.0055}, 1909);
  c.params[4] = -0.04;
  c.params[5] = 0.002;
  return c;
}

PortSystem Dome(const Vec3& outer_c, const Vec3& inner_c, const Vec3& ep, double ro = 83.4,
                double ri = 75.7) {
  PortSpec s;
  s.name = "dome";
  DomePort d;
  d.outer = {outer_c, ro};
  d.inner = {inner_c, ri};
  s.shape = d;
  return ports::Place(s, ep, 1.5168, 1.341);
}

PortSystem Flat(double tilt_deg, double azimuth_deg, double distance, double thickness,
                double n_glass) {
  PortSpec s;
  s.name = "flat";
  FlatPort f;
  const double t = tilt_deg * kPi / 180, a = azimuth_deg * kPi / 180;
  f.normal = Vec3(std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t));
  const Vec3 ep(0, 0, 26.9);
  f.inner_point_mm = ep + distance * f.normal;
  f.thickness_mm = thickness;
  s.shape = f;
  return ports::Place(s, ep, n_glass, 1.341);
}

// An acrylic tube (inner radius 50 mm, 6 mm wall) whose axis lies at `angle_deg` from +Y toward
// +X, the pupil at `pupil_from_axis` from its axis.
PortSystem Cylinder(const Vec3& pupil_from_axis, double angle_deg, double ri = 50, double ro = 56) {
  PortSpec s;
  s.name = "cylinder";
  ports::CylinderPort c;
  const double a = angle_deg * kPi / 180;
  const Vec3 ep(0, 0, 26.9);
  c.axis = Vec3(std::sin(a), std::cos(a), 0);
  c.axis_point_mm = ep - pupil_from_axis;
  c.inner_radius_mm = ri;
  c.outer_radius_mm = ro;
  s.shape = c;
  return ports::Place(s, ep, 1.49, 1.341);
}

struct Case {
  std::string name;
  PortSystem sys;
  bool axial;
};

std::vector<Case> Cases() {
  const Vec3 ep(0, 0, 26.9);
  std::vector<Case> c;
  c.push_back({"flat acrylic 10 mm at 20 mm, square", Flat(0, 0, 20, 10, 1.49), true});
  c.push_back({"flat acrylic tilted 5 deg", Flat(5, 30, 20, 10, 1.49), true});
  c.push_back({"flat glass 6 mm at 60 mm tilted 3 deg", Flat(3, -120, 60, 6, 1.5168), true});
  c.push_back({"concentric dome, pupil at the centre", Dome(ep, ep, ep), true});
  c.push_back({"concentric dome, pupil 10 mm behind the centre",
               Dome(ep + Vec3(0, 0, 10), ep + Vec3(0, 0, 10), ep), true});
  c.push_back({"concentric dome, pupil 10 mm off centre sideways",
               Dome(ep + Vec3(6, -8, 0), ep + Vec3(6, -8, 0), ep), true});
  c.push_back({"non-concentric on-axis dome, pupil 5 mm ahead",
               Dome(ep - Vec3(0, 0, 5), ep - Vec3(0, 0, 6.3), ep), true});
  c.push_back({"as-built NI320 (Tables 3-4)",
               Dome(Vec3(-0.4, -1.0, 21.5), Vec3(-0.4, -1.5, 20.3), ep), false});
  c.push_back({"non-concentric dome, pupil 10 mm off centre",
               Dome(ep - Vec3(3, -4, 8.66), ep - Vec3(3, -4, 8.66) + Vec3(0.3, -0.5, -1.2), ep),
               false});
  c.push_back({"cylinder, pupil on the axis", Cylinder(Vec3::Zero(), 0), false});
  c.push_back({"cylinder rolled 4 deg, pupil 3 mm off, 5 mm behind the axis",
               Cylinder(Vec3(3, 1, -5), 4), false});
  return c;
}

// Maximum round-trip error (px) over a grid of pixels spanning the whole frame (corners included)
// and points 0.2, 1, 5 and 20 m out along each traced ray; counts the points tested.
double RoundTripMaxPx(const Case& c, const Camera& cam, int* n_tested, int* n_solved_axial) {
  const Shell shell = ShellOf(c.sys);
  const auto p = ParamsOf(c.sys);
  const std::vector<optics::Interface> seq = c.sys.Outward();
  double worst = 0;
  const int nu = 23, nv = 16;
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const Eigen::Vector2d uv(i * (cam.sensor.width_px - 1.0) / (nu - 1),
                               j * (cam.sensor.height_px - 1.0) / (nv - 1));
      const auto ray = cam.Unproject(uv);
      if (!ray) continue;
      optics::Ray in{c.sys.ep_in_housing_mm, *ray}, out;
      if (optics::TraceSequence(seq, in, &out) != optics::RayStatus::kOk) continue;
      for (double s : {200.0, 1000.0, 5000.0, 20000.0}) {
        const Vec3 point_in_cam = out.origin + s * out.dir - c.sys.ep_in_housing_mm;
        const auto sol = SolveDirection(MakeGeometry<double>(shell, p.data()), point_in_cam);
        EXPECT_TRUE(sol.has_value()) << c.name << " at " << uv.transpose() << ", " << s << " mm";
        if (!sol) continue;
        if (sol->axial) ++*n_solved_axial;
        const auto d = ForwardDirection<double>(shell, p.data(), point_in_cam);
        const auto back = cam.Project(*d);
        EXPECT_TRUE(back.has_value());
        if (!back) continue;
        worst = std::max(worst, (*back - uv).norm());
        ++*n_tested;
      }
    }
  }
  return worst;
}

TEST(ForwardProjection, RoundTripOverTheWholeImage) {
  for (const Camera& cam : {D300Brown(), D300Fisheye()}) {
    for (const Case& c : Cases()) {
      int n = 0, axial = 0;
      const double worst = RoundTripMaxPx(c, cam, &n, &axial);
      // The fisheye sees beyond a dome's rim plane in the corners: those rays are not traced.
      EXPECT_GT(n, cam.model == CameraModelId::kBrown ? 23 * 16 * 4 - 1 : 300) << c.name;
      EXPECT_LE(worst, 1e-9) << c.name << " (" << cam.model_name() << ")";
      EXPECT_EQ(axial, c.axial ? n : 0) << c.name;
      std::printf("round trip %-50s %-15s %5d points, max %.2e px\n", c.name.c_str(),
                  std::string(cam.model_name()).c_str(), n, worst);
    }
  }
}

TEST(ForwardProjection, CentredConcentricDomeBendsNothing) {
  const Vec3 ep(0, 0, 26.9);
  const PortSystem sys = Dome(ep, ep, ep);
  const auto p = ParamsOf(sys);
  const Vec3 x(300, -200, 900);
  const auto d = ForwardDirection<double>(ShellOf(sys), p.data(), x);
  ASSERT_TRUE(d.has_value());
  EXPECT_LE((*d - x.normalized()).norm(), 1e-15);
}

TEST(ForwardProjection, PointsNotInTheWaterHaveNoProjection) {
  const PortSystem flat = Flat(0, 0, 20, 10, 1.49);
  const auto pf = ParamsOf(flat);
  EXPECT_FALSE(ForwardDirection<double>(ShellOf(flat), pf.data(), Vec3(0, 0, 25)).has_value());
  EXPECT_FALSE(ForwardDirection<double>(ShellOf(flat), pf.data(), Vec3(0, 0, -500)).has_value());
  const Vec3 ep(0, 0, 26.9);
  const PortSystem dome = Dome(ep, ep, ep);
  const auto pd = ParamsOf(dome);
  EXPECT_FALSE(ForwardDirection<double>(ShellOf(dome), pd.data(), Vec3(0, 0, 50)).has_value());
  EXPECT_FALSE(ForwardDirection<double>(ShellOf(dome), pd.data(), Vec3(0, 0, -500)).has_value());
  EXPECT_FALSE(
      ForwardDirection<double>(ShellOf(dome), pd.data(), Vec3(NAN, 0, 500)).has_value());
}

// Jets (the implicit-function step) against central differences of the double projection, for
// the port parameters, the point, the lens parameters and the shell's values (water index factor,
// radii and inner-centre offset or thickness): ≤ 1e-6 relative per column.
TEST(ForwardProjection, JacobiansEqualCentralDifferences) {
  using camera::BrownModel;
  constexpr int kLens = 6, kShell = 6 + camera::kBrownNumParams;
  constexpr int kN = kShell + kShellNumParams;
  using J = ceres::Jet<double, kN>;
  const Camera cam = D300Brown();
  double worst = 0, worst_no_shell = 0;
  for (const Case& c : Cases()) {
    const Shell shell = ShellOf(c.sys);
    const auto p = ParamsOf(c.sys);
    for (const Vec3& x : {Vec3(180, -120, 600), Vec3(-2500, 1500, 5000), Vec3(40, 30, 300),
                          Vec3(-9000, -6000, 20000)}) {
      // Values in one array: port [0, 3), point [3, 6), camera [6, kShell), shell [kShell, kN).
      std::array<double, kN> v;
      std::copy(p.begin(), p.end(), v.begin());
      for (int k = 0; k < 3; ++k) v[3 + k] = x(k);
      std::copy(cam.params.begin(), cam.params.end(), v.begin() + kLens);
      const ShellArray sv = ShellValues(shell);
      std::copy(sv.begin(), sv.end(), v.begin() + kShell);
      auto project = [&](const auto* q) {
        using T = std::remove_cv_t<std::remove_pointer_t<decltype(q)>>;
        return Project<BrownModel, T>(cam.sensor, q + kLens, shell, q,
                                      Vec3T<T>(q[3], q[4], q[5]), q + kShell);
      };
      std::array<J, kN> vj;
      for (int k = 0; k < kN; ++k) vj[k] = J(v[k], k);
      const auto pj = project(vj.data());
      ASSERT_TRUE(pj.has_value()) << c.name;
      const auto p0 = project(v.data());
      ASSERT_TRUE(p0.has_value());
      EXPECT_LE(std::abs((*pj)(0).a - (*p0)(0)), 1e-9);
      for (int k = 0; k < kN; ++k) {
        // A step that moves the pixel by about 0.01 px: large against round-off, small against
        // the curvature (0.001 px for the shell values: a dome's radius curves the pixel more).
        const double col = std::hypot((*pj)(0).v(k), (*pj)(1).v(k));
        // Below 1e-9 px per unit a column is zero up to round-off (the shell values at a pupil in
        // the centre of a concentric dome bend nothing: the difference quotient is exactly 0).
        if (!(col > 1e-9)) {
          EXPECT_LE(col, 1e-9) << c.name << " column " << k;
          continue;
        }
        const double h = (k >= kShell ? 1e-3 : 1e-2) / col;
        auto plus = v, minus = v;
        plus[k] += h;
        minus[k] -= h;
        const auto a = project(plus.data()), b = project(minus.data());
        ASSERT_TRUE(a && b) << c.name << " column " << k;
        const Eigen::Vector2d fd = (*a - *b) / (2 * h);
        const Eigen::Vector2d jet((*pj)(0).v(k), (*pj)(1).v(k));
        const double rel = (jet - fd).norm() / std::max(jet.norm(), 1e-300);
        EXPECT_LE(rel, 1e-6) << c.name << " column " << k << " jet " << jet.transpose()
                             << " fd " << fd.transpose();
        worst = std::max(worst, rel);
        if (k < kShell) worst_no_shell = std::max(worst_no_shell, rel);
      }
    }
  }
  std::printf("Jacobian vs central differences: worst relative difference %.2e (port, point and "
              "lens columns %.2e)\n", worst, worst_no_shell);
}

// The shell's values as parameters are the shell itself: the Shell's own values project as no
// values at all, a water index factor as the water index scaled, and a port spec with other values
// traces as those values say; values that are no shell are refused.
TEST(ShellValues, AreTheShellsOwnAndRefuseNonsense) {
  const Camera cam = D300Brown();
  const Vec3 x(-700, 400, 1500);
  for (const Case& c : Cases()) {
    const Shell shell = ShellOf(c.sys);
    const auto p = ParamsOf(c.sys);
    ShellArray v = ShellValues(shell);
    const auto a = ForwardDirection<double>(shell, p.data(), x);
    const auto b = ForwardDirection<double>(shell, p.data(), x, v.data());
    ASSERT_TRUE(a && b) << c.name;
    EXPECT_EQ(*a, *b) << c.name;
    v[0] = 1.01;
    Shell wetter = shell;
    wetter.n_water *= 1.01;
    const auto d = ForwardDirection<double>(shell, p.data(), x, v.data());
    const auto e = ForwardDirection<double>(wetter, p.data(), x);
    ASSERT_TRUE(d && e) << c.name;
    EXPECT_EQ(*d, *e) << c.name;
    v[0] = 1;
    v[1] += 0.5;  // outer radius or flat thickness
    const PortSystem moved = ports::Place(SpecWithParams(c.sys, p, v), c.sys.ep_in_housing_mm,
                                          c.sys.n_glass, c.sys.n_water);
    const auto f = ForwardDirection<double>(shell, p.data(), x, v.data());
    const auto g = ForwardDirection<double>(ShellOf(moved), ParamsOf(moved).data(), x);
    ASSERT_TRUE(f && g) << c.name;
    EXPECT_LE((*f - *g).norm(), 1e-12) << c.name;
    EXPECT_EQ(WithShellValues(shell, v).n_water, shell.n_water);
    EXPECT_NO_THROW(ValidateShellValues(shell, v, "shell"));
    ShellArray bad = v;
    bad[0] = 0.5;  // water index below 1
    EXPECT_THROW(ValidateShellValues(shell, bad, "shell"), InvalidInput) << c.name;
    bad = v;
    bad[shell.kind == PortKind::kDome ? 2 : 1] = -1;  // inner radius or thickness negative
    EXPECT_THROW(ValidateShellValues(shell, bad, "shell"), InvalidInput) << c.name;
  }
}

// The `shell` JSON block has the keys shell_json.h documents for each shape (the shapes'
// kShellJsonKeys) and reads back to the same shell; a block that is no shell is refused.
TEST(ShellJson, HasEachShapesKeysAndReadsBack) {
  const std::map<std::string, std::vector<std::string>> keys = {
      {"dome", {"outer_radius_mm", "inner_radius_mm", "inner_from_outer_mm", "rim_from_outer_z_mm"}},
      {"flat", {"thickness_mm"}},
      {"cylinder", {"outer_radius_mm", "inner_radius_mm", "rim_from_axis_z_mm"}}};
  for (const Case& c : Cases()) {
    const Shell shell = ShellOf(c.sys);
    const std::string kind(PortKindName(shell.kind));
    const nlohmann::ordered_json j = ShellToJson(shell);
    std::vector<std::string> got;
    for (const auto& [k, v] : j.items()) got.push_back(k);
    std::vector<std::string> want = {"frame", "n_glass", "n_water"};
    for (const std::string& k : keys.at(kind)) want.push_back(k);
    EXPECT_EQ(got, want) << c.name;
    const Shell back = ShellFromJson(kind, nlohmann::json::parse(j.dump()), "shell");
    EXPECT_EQ(back.kind, shell.kind);
    EXPECT_EQ(ShellValues(back), ShellValues(shell)) << c.name;
    EXPECT_EQ(back.rim_from_outer_z_mm, shell.rim_from_outer_z_mm) << c.name;
    EXPECT_EQ(back.n_glass, shell.n_glass);
    EXPECT_EQ(back.n_water, shell.n_water);
    nlohmann::json bad = nlohmann::json::parse(j.dump());
    bad[kind == "flat" ? "thickness_mm" : "inner_radius_mm"] = kind == "flat" ? -1.0 : 1e4;
    EXPECT_THROW(ShellFromJson(kind, bad, "shell"), InvalidInput) << c.name;
    bad = nlohmann::json::parse(j.dump());
    bad.erase(keys.at(kind).front());
    EXPECT_THROW(ShellFromJson(kind, bad, "shell"), InvalidInput) << c.name;
  }
  EXPECT_THROW(ShellFromJson("sphere", ShellToJson(ShellOf(Cases()[0].sys)), "shell"), InvalidInput);
}

TEST(PortParameters, SpecWithParamsPutsThePupilWhereTheParametersSay) {
  const Vec3 ep(0, 0, 26.9);
  const PortSystem dome = Dome(Vec3(-0.4, -1.0, 21.5), Vec3(-0.4, -1.5, 20.3), ep);
  const auto p = ParamsOf(dome);
  EXPECT_NEAR(p[0], 0.4, 1e-12);
  EXPECT_NEAR(p[1], 1.0, 1e-12);
  EXPECT_NEAR(p[2], 5.4, 1e-12);  // the paper's Table 4: pupil 5.4 mm ahead of the outer centre
  const PortSpec moved = SpecWithParams(dome, {1, 2, 3});
  const PortSystem again = ports::Place(moved, ep, dome.n_glass, dome.n_water);
  const auto q = ParamsOf(again);
  EXPECT_NEAR(q[0], 1, 1e-12);
  EXPECT_NEAR(q[1], 2, 1e-12);
  EXPECT_NEAR(q[2], 3, 1e-12);
  EXPECT_NEAR((again.dome().inner.center_mm - again.dome().outer.center_mm -
               (dome.dome().inner.center_mm - dome.dome().outer.center_mm)).norm(), 0, 1e-12);

  // A cylinder: the pupil's offset across the axis and along Z, and the axis angle.
  const PortSystem cyl = Cylinder(Vec3(2, 7, -3), 10);
  const auto pc = ParamsOf(cyl);
  EXPECT_NEAR(pc[0], 2 * std::cos(10 * kPi / 180) - 7 * std::sin(10 * kPi / 180), 1e-12);
  EXPECT_NEAR(pc[1], -3, 1e-12);
  EXPECT_NEAR(pc[2], 10, 1e-12);
  const PortSystem cyl2 = ports::Place(SpecWithParams(cyl, {1.5, 4, -20}), ep, 1.49, 1.341);
  const auto qc = ParamsOf(cyl2);
  EXPECT_NEAR(qc[0], 1.5, 1e-12);
  EXPECT_NEAR(qc[1], 4, 1e-12);
  EXPECT_NEAR(qc[2], -20, 1e-12);
  EXPECT_NEAR(cyl2.cylinder().outer_radius_mm - cyl2.cylinder().inner_radius_mm, 6, 1e-12);

  const PortSystem flat = Flat(4, 10, 30, 8, 1.49);
  const auto pf = ParamsOf(flat);
  EXPECT_NEAR(pf[2], 30, 1e-12);
  const PortSystem flat2 =
      ports::Place(SpecWithParams(flat, {0.02, -0.01, 25}), flat.ep_in_housing_mm, 1.49, 1.341);
  const auto qf = ParamsOf(flat2);
  EXPECT_NEAR(qf[0], 0.02, 1e-12);
  EXPECT_NEAR(qf[1], -0.01, 1e-12);
  EXPECT_NEAR(qf[2], 25, 1e-12);
}

TEST(PortParameters, InterfacesAreTheSystemsOwn) {
  // The cam-frame interfaces trace every ray as the housing-frame system does.
  const Vec3 ep(0, 0, 26.9);
  for (const PortSystem& sys : {Dome(Vec3(-0.4, -1.0, 21.5), Vec3(-0.4, -1.5, 20.3), ep),
                                Flat(5, 30, 20, 10, 1.49), Cylinder(Vec3(3, 1, -5), 4)}) {
    const auto p = ParamsOf(sys);
    const auto cam_seq = Interfaces(ShellOf(sys), p.data());
    const Vec3 dir = Vec3(0.3, -0.2, 1).normalized();
    optics::Ray a, b;
    ASSERT_EQ(optics::TraceSequence(sys.Outward(), optics::Ray{ep, dir}, &a), optics::RayStatus::kOk);
    ASSERT_EQ(optics::TraceSequence(cam_seq, optics::Ray{Vec3::Zero(), dir}, &b),
              optics::RayStatus::kOk);
    EXPECT_LE((a.origin - ep - b.origin).norm(), 1e-12);
    EXPECT_LE((a.dir - b.dir).norm(), 1e-15);
  }
}

TEST(PortParameters, InvalidParametersAreRefused) {
  const Vec3 ep(0, 0, 26.9);
  const Shell dome = ShellOf(Dome(ep, ep, ep));
  const double far[3] = {0, 0, 80};
  EXPECT_THROW(ValidateParams(dome, far, "port"), InvalidInput);
  const double nan[3] = {NAN, 0, 0};
  EXPECT_THROW(ValidateParams(dome, nan, "port"), InvalidInput);
  const Shell flat = ShellOf(Flat(0, 0, 20, 10, 1.49));
  const double behind[3] = {0, 0, -5};
  EXPECT_THROW(ValidateParams(flat, behind, "port"), InvalidInput);
  const double sideways[3] = {0.8, 0.7, 20};
  EXPECT_THROW(ValidateParams(flat, sideways, "port"), InvalidInput);
  const double ok[3] = {0.01, 0, 20};
  EXPECT_NO_THROW(ValidateParams(flat, ok, "port"));
  const Shell cyl = ShellOf(Cylinder(Vec3::Zero(), 0));
  const double outside[3] = {30, 45, 0};  // 54 mm from the axis: beyond the inner radius
  EXPECT_THROW(ValidateParams(cyl, outside, "port"), InvalidInput);
  const double inside[3] = {3, -5, 7};
  EXPECT_NO_THROW(ValidateParams(cyl, inside, "port"));
}

}  // namespace
}  // namespace porthole::refraction
