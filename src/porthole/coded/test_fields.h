// Target fields with uncoded dots and their exact renders, for the tests of MatchUncodedDots
// (coded_detect_test) and of detection through calib (calib/detect_test). Tests only.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <vector>

#include "porthole/coded/detect.h"
#include "porthole/coded/ellipse.h"
#include "porthole/coded/raster.h"
#include "porthole/coded/sheet.h"

namespace porthole::coded::testing {

// A test field on a grid of pitch 8r: coded targets (IDs from 1) at two grid points in three, plain
// dots (IDs from 1001, above every profile's code count) at the others and at every cell's centre;
// with `raise_mm`, some of both stand that far toward the camera (Z < 0): a 3-D field.
inline std::vector<PlacedTarget> GridField(int cols, int rows, double pitch, double raise_mm) {
  std::vector<PlacedTarget> f;
  int coded = 1, plain = 1001;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      const double z = raise_mm > 0 && (3 * i + j) % 5 == 0 ? -raise_mm : 0.0;
      f.push_back({(i + 2 * j) % 3 != 0 ? coded++ : plain++, Eigen::Vector3d(pitch * i, pitch * j, z)});
      if (i + 1 < cols && j + 1 < rows) {
        const double zc = raise_mm > 0 && (i + j) % 4 == 1 ? -raise_mm : 0.0;
        f.push_back({plain++, Eigen::Vector3d(pitch * (i + 0.5), pitch * (j + 0.5), zc)});
      }
    }
  }
  return f;
}

// A pinhole view (raster.h) with radial distortion of its ideal pixels about the principal point:
// x_d = x (1 + k1 ρ²), ρ = |x| / f (k1 < 0: barrel).
struct FieldView {
  SheetView cam;
  double k1 = 0;
};

// How a dot at field point x images: its plane's homography (the plane Z = x.z), then the
// distortion to first order about the dot's centre — exact ellipses (hence exact truth) whose
// positions follow the distortion, which no global projective map follows.
inline Eigen::Matrix3d DotHomography(const FieldView& fv, const Eigen::Vector3d& x) {
  Eigen::Matrix3d m;
  m << fv.cam.rot.col(0), fv.cam.rot.col(1), fv.cam.rot.col(2) * x.z() + fv.cam.t;
  const Eigen::Matrix3d h = fv.cam.K() * m;
  if (fv.k1 == 0) return h;
  const Eigen::Vector3d c = h * Eigen::Vector3d(x.x(), x.y(), 1);
  const Eigen::Vector2d p0 = c.head<2>() / c.z();
  const Eigen::Vector2d pp((fv.cam.width - 1) / 2.0, (fv.cam.height - 1) / 2.0);
  const Eigen::Vector2d d = p0 - pp;
  const double f2 = fv.cam.f_px * fv.cam.f_px, g = 1 + fv.k1 * d.squaredNorm() / f2;
  const Eigen::Matrix2d j = g * Eigen::Matrix2d::Identity() + 2 * fv.k1 / f2 * d * d.transpose();
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
  a.topLeftCorner<2, 2>() = j;
  a.topRightCorner<2, 1>() = pp + g * d - j * p0;
  return a * h;
}

// A plain dot drawn beside the field (a look-alike): field position and radius factor.
struct ExtraDot {
  Eigen::Vector3d xyz_mm;
  double radius_factor = 1;
};

struct FieldCoverage {
  std::vector<double> ink;               // fraction of each pixel inked, row-major (raster.h)
  std::map<int, Eigen::Vector2d> truth;  // ellipse centre of every dot drawn
  std::set<int> eligible;                // uncoded dots drawn whose dot and gap (1.7 r) are inside the image
};

// Draws `field` (dot radius r) through `fv`: coded IDs with their rings, uncoded IDs as plain dots;
// IDs in `missing` are not drawn; `extra` dots are drawn too.
inline FieldCoverage DrawField(const std::vector<PlacedTarget>& field, double r, Profile p, int bits,
                               const FieldView& fv, int subrows, const std::set<int>& missing = {},
                               const std::vector<ExtraDot>& extra = {}) {
  FieldCoverage s;
  RasterOptions ro;
  ro.bits = bits;
  ro.profile = p;
  ro.radius_mm = r;
  ro.subrows = subrows;
  std::vector<RawTarget> raw;
  const int w = fv.cam.width, h = fv.cam.height;
  for (const auto& t : field) {
    if (missing.count(t.id)) continue;
    const Eigen::Matrix3d hl = DotHomography(fv, t.xyz_mm);
    const bool plain = IsUncodedId(p, bits, t.id);
    raw.push_back({t.xyz_mm.head<2>(), plain ? 0u : CodeOfId(p, bits, t.id), true, hl});
    s.truth[t.id] = ConicCentreOfCircle<double>(hl, t.xyz_mm.head<2>(), r);
    bool inside = plain;
    for (int k = 0; k < 32 && inside; ++k) {
      const double a = std::numbers::pi * k / 16;
      const Eigen::Vector3d q = hl * Eigen::Vector3d(t.xyz_mm.x() + 1.7 * r * std::cos(a), t.xyz_mm.y() + 1.7 * r * std::sin(a), 1);
      inside = q.z() > 0 && q.x() / q.z() > 1 && q.y() / q.z() > 1 && q.x() / q.z() < w - 2 && q.y() / q.z() < h - 2;
    }
    if (inside) s.eligible.insert(t.id);
  }
  s.ink = RasterizeRaw(w, h, Eigen::Matrix3d::Identity(), raw, ro);
  for (const auto& e : extra) {  // drawn apart, each at its own size (the rasteriser's radius is global)
    RasterOptions re = ro;
    re.radius_mm = r * e.radius_factor;
    const std::vector<double> c =
        RasterizeRaw(w, h, Eigen::Matrix3d::Identity(), {{e.xyz_mm.head<2>(), 0u, true, DotHomography(fv, e.xyz_mm)}}, re);
    for (std::size_t k = 0; k < s.ink.size(); ++k) s.ink[k] = std::min(1.0, s.ink[k] + c[k]);
  }
  return s;
}

}  // namespace porthole::coded::testing
