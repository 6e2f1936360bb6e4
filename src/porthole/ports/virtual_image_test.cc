// Proves the virtual-image computation against the paper's Table 5, closed forms (a thin dome
// images infinity at 4R from its centre; a flat port's apparent depth), and that real rays tend
// to the paraxial image as the aperture goes to zero.
#include "porthole/ports/virtual_image.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::ports {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

PortSystem NominalNi320(double n_glass = 1.5168, double n_water = 1.341) {
  PortSpec s;
  s.frame = PortFrame::kCam;
  DomePort d;
  d.outer.radius_mm = 83.4;
  d.inner.radius_mm = 75.7;
  s.shape = d;
  return Place(s, Vec3(0, 0, 26.9), n_glass, n_water);
}

PortSystem Flat(double ep_to_inner, double thickness, double n_glass, double n_water) {
  PortSpec s;
  s.frame = PortFrame::kCam;
  FlatPort f;
  f.inner_point_mm = Vec3(0, 0, ep_to_inner);
  f.thickness_mm = thickness;
  s.shape = f;
  return Place(s, Vec3(0, 0, 26.9), n_glass, n_water);
}

struct Row {
  double wd, d_s2ep, vwd;
};

std::vector<Row> PaperTable5() {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/menna2016_table5.csv");
  EXPECT_TRUE(in.good());
  std::vector<Row> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 'w') continue;
    std::stringstream ss(line);
    std::string a, b, c;
    std::getline(ss, a, ',');
    std::getline(ss, b, ',');
    std::getline(ss, c, ',');
    rows.push_back({a == "inf" ? kInf : std::stod(a), std::stod(b), std::stod(c)});
  }
  EXPECT_EQ(rows.size(), 10u);
  return rows;
}

TEST(VirtualImage, ReproducesPaperTable5Within0p2mm) {
  const PortSystem port = NominalNi320();
  for (const Row& r : PaperTable5()) {
    const VirtualImage vi = ParaxialVirtualImage(port, r.wd);
    EXPECT_NEAR(vi.d_s2ep_mm, r.d_s2ep, 0.2) << "WD " << r.wd;
    EXPECT_NEAR(vi.vwd_mm, r.vwd, 0.2) << "WD " << r.wd;
  }
}

TEST(VirtualImage, ThinConcentricDomeImagesInfinityAtFourRadii) {
  // Single refracting surface water → air of radius R: image of infinity at R/(n−1) in front of
  // the vertex, i.e. R + R/(n−1) ≈ 4R from the centre for n = 4/3.
  PortSpec s;
  s.frame = PortFrame::kCam;
  DomePort d;
  d.outer.radius_mm = 100.0;
  d.inner.radius_mm = 100.0 - 1e-6;
  s.shape = d;
  const double n = 4.0 / 3.0;
  const PortSystem port = Place(s, Vec3(0, 0, 10), 1.5, n);
  const VirtualImage vi = ParaxialVirtualImage(port, kInf);
  EXPECT_NEAR(vi.d_s2ep_mm, 100.0 + 100.0 / (n - 1), 1e-3);
  EXPECT_NEAR(vi.d_s2ep_mm / 100.0, 4.0, 1e-4);
  // Its focal length: Φ = (1 − n)/R  (diverging), efl = 1/Φ = −3R.
  const FocalProperties f = ParaxialFocal(port);
  EXPECT_NEAR(f.power_per_mm, (1 - n) / 100.0, 1e-9);
  EXPECT_NEAR(f.efl_mm, -300.0, 1e-3);
  EXPECT_NEAR(f.efl_water_mm, -400.0, 1e-3);
}

TEST(VirtualImage, FlatPortApparentDepth) {
  // Closed form: the image lies at WD/n_w + t/n_g in front of the inner surface.
  const double ep_to_inner = 20, t = 10, ng = 1.49, nw = 1.333;
  const PortSystem port = Flat(ep_to_inner, t, ng, nw);
  for (double wd : {100.0, 1000.0, 5000.0}) {
    const VirtualImage vi = ParaxialVirtualImage(port, wd);
    EXPECT_NEAR(vi.d_s2ep_mm, ep_to_inner + t / ng + wd / nw, 1e-9);
    EXPECT_NEAR(vi.magnification, 1.0, 1e-12);  // a plate does not magnify the virtual image
  }
  EXPECT_TRUE(std::isinf(ParaxialVirtualImage(port, kInf).d_s2ep_mm));
  EXPECT_TRUE(std::isinf(ParaxialFocal(port).efl_mm));
}

// A cylindrical port with the pupil on its axis is two ports in one. Across the axis its
// section is two circles about the pupil: that section is a concentric dome's, and so is its focal
// line (the dome of the same radii, by the y–nu trace). Along the axis its section is two straight
// lines square to Z: a flat port r_in from the pupil, t thick, whose closed form is
// r_in + t/n_g + WD/n_w. The cylinder's focal lines, from its traced parabasal rays, are these two.
TEST(VirtualImage, CylinderFocalLinesAreTheConcentricDomeAndTheFlatPort) {
  const double ri = 50, ro = 56, ng = 1.49, nw = 1.341;
  PortSpec s;
  s.frame = PortFrame::kCam;
  CylinderPort c;
  c.inner_radius_mm = ri;
  c.outer_radius_mm = ro;
  s.shape = c;
  const PortSystem port = Place(s, Vec3(0, 0, 26.9), ng, nw);
  EXPECT_NEAR(port.OuterVertexZ() - 26.9, ro, 1e-12);
  EXPECT_NEAR(port.InnerVertexZ() - 26.9, ri, 1e-12);
  PortSpec ds;
  ds.frame = PortFrame::kCam;
  DomePort d;
  d.outer.radius_mm = ro;
  d.inner.radius_mm = ri;
  ds.shape = d;
  const PortSystem dome = Place(ds, Vec3(0, 0, 26.9), ng, nw);
  double worst = 0;
  for (double wd : {300.0, 1000.0, 5000.0}) {
    const VirtualImage vi = ParaxialVirtualImage(port, wd);
    const double flat = ri + (ro - ri) / ng + wd / nw, across = ParaxialVirtualImage(dome, wd).d_s2ep_mm;
    ASSERT_LT(across, flat);  // a dome's image is the nearer
    EXPECT_NEAR(vi.focal_line_near_d_s2ep_mm, across, 1e-6 * across) << wd;
    EXPECT_NEAR(vi.focal_line_far_d_s2ep_mm, flat, 1e-6 * flat) << wd;
    worst = std::max({worst, std::abs(vi.focal_line_near_d_s2ep_mm - across) / across,
                      std::abs(vi.focal_line_far_d_s2ep_mm - flat) / flat});
    // The least-squares image lies between its focal lines.
    EXPECT_GT(vi.d_s2ep_mm, across);
    EXPECT_LT(vi.d_s2ep_mm, flat);
    // Real rays through a small pupil meet there too.
    const auto real = RealRayVirtualImage(port, wd, 0.05);
    ASSERT_TRUE(real.has_value());
    EXPECT_NEAR(real->d_s2ep_mm, vi.d_s2ep_mm, 1e-4 * vi.d_s2ep_mm) << wd;
  }
  std::printf("cylinder focal lines: worst relative difference from the dome's and the flat port's %.2e\n", worst);
  // A dome is not astigmatic: both lines are its image.
  const VirtualImage ni320 = ParaxialVirtualImage(NominalNi320(), 1000);
  EXPECT_EQ(ni320.focal_line_near_d_s2ep_mm, ni320.d_s2ep_mm);
  EXPECT_EQ(ni320.focal_line_far_d_s2ep_mm, ni320.d_s2ep_mm);
}

TEST(VirtualImage, RealRaysTendToParaxialAsApertureShrinks) {
  for (const PortSystem& port : {NominalNi320(), Flat(20, 10, 1.49, 1.333)}) {
    for (double wd : {200.0, 1000.0, kInf}) {
      if (!port.IsDome() && std::isinf(wd)) continue;
      const double par = ParaxialVirtualImage(port, wd).d_s2ep_mm;
      double prev_err = kInf;
      for (double h : {8.0, 4.0, 2.0, 1.0, 0.01}) {
        const auto real = RealRayVirtualImage(port, wd, h);
        ASSERT_TRUE(real.has_value());
        const double err = std::abs(real->d_s2ep_mm - par);
        EXPECT_LE(err, prev_err + 1e-9) << "h " << h;  // aberration shrinks with the aperture
        prev_err = err;
      }
      // Longitudinal aberration ∝ h²: at h = 0.01 mm it is negligible.
      EXPECT_NEAR(RealRayVirtualImage(port, wd, 0.01)->d_s2ep_mm, par, 1e-6 * par) << wd;
    }
  }
}

TEST(VirtualImage, DecentredPortStillTracesAndStaysNearTheNominal) {
  PortSpec s;
  s.frame = PortFrame::kHousing;
  DomePort d;
  d.outer = {Vec3(-0.4, -1.0, 21.5), 83.4};
  d.inner = {Vec3(-0.4, -1.5, 20.3), 75.7};
  s.shape = d;
  const PortSystem port = Place(s, Vec3(0, 0, 26.9), 1.5168, 1.341);
  EXPECT_FALSE(port.IsCentral());
  const auto real = RealRayVirtualImage(port, 1000, 1.5);
  ASSERT_TRUE(real.has_value());
  // The pupil 5.4 mm ahead of the centre: the image moves by a few mm, not tens.
  EXPECT_NEAR(real->d_s2ep_mm, ParaxialVirtualImage(port, 1000).d_s2ep_mm, 1.0);
  EXPECT_NEAR(real->d_s2ep_mm, ParaxialVirtualImage(NominalNi320(), 1000).d_s2ep_mm, 10.0);
}

// Issue 12: for a decentred dome the paraxial image is defined about the chief ray, as the limit of
// real rays; it was the y-nu trace along the axis, up to 1 % off that limit, and the difference was
// reported as spherical aberration. Domes: the NI320 as built (centres 1.3 mm apart), a concentric
// shell displaced 3 mm sideways from the pupil, and a shell with both centres displaced and apart.
TEST(VirtualImage, DecentredDomesParaxialIsTheLimitOfRealRays) {
  struct Case {
    Vec3 outer, inner;
  };
  for (const Case& c : {Case{Vec3(-0.4, -1.0, 21.5), Vec3(-0.4, -1.5, 20.3)},
                        Case{Vec3(3.0, 0.0, 26.9), Vec3(3.0, 0.0, 26.9)},
                        Case{Vec3(2.0, -1.0, 24.0), Vec3(0.0, 1.5, 21.0)}}) {
    PortSpec s;
    s.frame = PortFrame::kHousing;
    DomePort d;
    d.outer = {c.outer, 83.4};
    d.inner = {c.inner, 75.7};
    s.shape = d;
    const PortSystem port = Place(s, Vec3(0, 0, 26.9), 1.5168, 1.341);
    for (double wd : {100.0, 1000.0, kInf}) {
      const VirtualImage par = ParaxialVirtualImage(port, wd);
      double prev_err = kInf;
      for (double h : {4.0, 1.0, 0.1, 0.01}) {
        const auto real = RealRayVirtualImage(port, wd, h);
        ASSERT_TRUE(real.has_value());
        const double err = std::abs(real->d_s2ep_mm - par.d_s2ep_mm);
        EXPECT_LE(err, prev_err + 1e-9) << "h " << h << " WD " << wd;
        prev_err = err;
      }
      const auto limit = RealRayVirtualImage(port, wd, 0.01);
      EXPECT_NEAR(limit->d_s2ep_mm, par.d_s2ep_mm, 1e-6 * par.d_s2ep_mm) << "WD " << wd << " outer " << c.outer.x();
      EXPECT_NEAR(limit->vwd_mm, par.vwd_mm, 1e-6 * par.d_s2ep_mm) << "WD " << wd;
      EXPECT_NEAR(limit->lateral_offset_mm, par.lateral_offset_mm, 1e-5) << "WD " << wd;
    }
  }
}

// docs/port-optics.md: the NI320's longitudinal spherical aberration at 1 m, h = 1.5 mm (f/8 on the
// 24 mm lens), is about -0.03 mm; and it is the difference from the paraxial image (real rays
// focus nearer to the dome, as for any spherical surface).
TEST(VirtualImage, Ni320SphericalAberrationAtOneMetre) {
  for (double nw : {1.341, 1.34094}) {
    const PortSystem port = NominalNi320(1.5168, nw);
    const double sa = RealRayVirtualImage(port, 1000, 1.5)->d_s2ep_mm - ParaxialVirtualImage(port, 1000).d_s2ep_mm;
    EXPECT_NEAR(sa, -0.03, 0.005) << nw;
  }
}

TEST(VirtualImage, RejectsNonPositiveWorkingDistance) {
  EXPECT_THROW(ParaxialVirtualImage(NominalNi320(), 0), InvalidInput);
  EXPECT_THROW(ParaxialVirtualImage(NominalNi320(), NAN), InvalidInput);
  EXPECT_THROW(RealRayVirtualImage(NominalNi320(), 100, -1), InvalidInput);
}

}  // namespace
}  // namespace porthole::ports
