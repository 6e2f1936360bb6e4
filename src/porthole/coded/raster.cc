#include "porthole/coded/raster.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace porthole::coded {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

// Adds, for one horizontal line at image row coordinate `vl` (weight `w`), the inked length of
// target `t` to the pixels of row `row` between columns u_lo and u_hi.
struct LineRaster {
  const Eigen::Matrix3d& sheet_from_image;
  const RasterOptions& o;
  double ri, ro;

  bool Ink(const RawTarget& t, double u, double vl) const {
    const Eigen::Vector3d p = sheet_from_image * Eigen::Vector3d(u, vl, 1);
    const double dx = p.x() / p.z() - t.centre_mm.x(), dy = p.y() / p.z() - t.centre_mm.y();
    const double rho2 = dx * dx + dy * dy;
    if (rho2 <= o.radius_mm * o.radius_mm) return t.dot;
    if (rho2 < ri * ri || rho2 > ro * ro) return false;
    double phi = std::atan2(dy, dx);
    if (phi < 0) phi += kTwoPi;
    const int seg = std::min(o.bits - 1, static_cast<int>(phi / kTwoPi * o.bits));
    return (t.ring >> (o.bits - 1 - seg)) & 1u;
  }

  void Line(const RawTarget& t, double vl, double weight, int u_lo, int u_hi, double* row) const {
    // Sheet point along the line: (a·u + b) / (g·u + h) per coordinate.
    const Eigen::Vector3d a = sheet_from_image.col(0);
    const Eigen::Vector3d b = sheet_from_image.col(1) * vl + sheet_from_image.col(2);
    const double p1 = a.x() - t.centre_mm.x() * a.z(), p0 = b.x() - t.centre_mm.x() * b.z();
    const double q1 = a.y() - t.centre_mm.y() * a.z(), q0 = b.y() - t.centre_mm.y() * b.z();
    const double w1 = a.z(), w0 = b.z();
    const double lo = u_lo - 0.5, hi = u_hi + 0.5;
    double cuts[40];  // 2 ends + 3 circles x 2 + up to 14 radial edges
    int n = 0;
    cuts[n++] = lo;
    cuts[n++] = hi;
    for (double r : {o.radius_mm, ri, ro}) {
      const double qa = p1 * p1 + q1 * q1 - r * r * w1 * w1;
      const double qb = 2 * (p1 * p0 + q1 * q0 - r * r * w1 * w0);
      const double qc = p0 * p0 + q0 * q0 - r * r * w0 * w0;
      const double disc = qb * qb - 4 * qa * qc;
      if (disc < 0 || qa == 0) continue;
      const double s = std::sqrt(disc);
      const double q = -0.5 * (qb + (qb >= 0 ? s : -s));  // stable roots
      for (double root : {q / qa, q != 0 ? qc / q : lo}) {
        if (root > lo && root < hi) cuts[n++] = root;
      }
    }
    for (int k = 0; k < o.bits; ++k) {  // radial edges of the segments
      const double th = kTwoPi * k / o.bits, sn = std::sin(th), cs = std::cos(th);
      const double c1 = p1 * sn - q1 * cs, c0 = p0 * sn - q0 * cs;
      if (c1 != 0) {
        const double root = -c0 / c1;
        if (root > lo && root < hi) cuts[n++] = root;
      }
    }
    std::sort(cuts, cuts + n);
    for (int i = 0; i + 1 < n; ++i) {
      const double x0 = cuts[i], x1 = cuts[i + 1];
      if (!(x1 > x0) || !Ink(t, 0.5 * (x0 + x1), vl)) continue;
      // Spread the inked interval [x0, x1] over the pixels it crosses.
      for (int px = static_cast<int>(std::floor(x0 + 0.5)); px <= u_hi && px - 0.5 < x1; ++px) {
        const double len = std::min(x1, px + 0.5) - std::max(x0, px - 0.5);
        if (len > 0 && px >= u_lo) row[px] += weight * len;
      }
    }
  }
};

}  // namespace

std::vector<double> RasterizeRaw(int width, int height, const Eigen::Matrix3d& image_from_sheet,
                                 const std::vector<RawTarget>& targets, const RasterOptions& o) {
  std::vector<double> img(static_cast<std::size_t>(width) * height, 0.0);
  const Eigen::Matrix3d sheet_from_image = image_from_sheet.inverse();
  const RingRadii ring = Ring(o.profile);
  const int s = std::max(1, o.subrows);
  for (const auto& t : targets) {
    const Eigen::Matrix3d& h = t.image_from_sheet ? *t.image_from_sheet : image_from_sheet;
    const Eigen::Matrix3d own_inverse = t.image_from_sheet ? t.image_from_sheet->inverse() : Eigen::Matrix3d();
    const LineRaster lr{t.image_from_sheet ? own_inverse : sheet_from_image, o, ring.inner * o.radius_mm,
                        ring.outer * o.radius_mm};
    // Bounding box of the image of the outer circle (sampled densely; every point in front).
    double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
    bool in_front = true;
    for (int k = 0; k < 720; ++k) {
      const double th = kTwoPi * k / 720;
      const Eigen::Vector3d p = h * Eigen::Vector3d(t.centre_mm.x() + 1.01 * lr.ro * std::cos(th),
                                                                   t.centre_mm.y() + 1.01 * lr.ro * std::sin(th), 1);
      if (!(p.z() > 0)) in_front = false;
      umin = std::min(umin, p.x() / p.z());
      umax = std::max(umax, p.x() / p.z());
      vmin = std::min(vmin, p.y() / p.z());
      vmax = std::max(vmax, p.y() / p.z());
    }
    if (!in_front) continue;
    const int u_lo = std::max(0, static_cast<int>(std::floor(umin)) - 2);
    const int u_hi = std::min(width - 1, static_cast<int>(std::ceil(umax)) + 2);
    const int v_lo = std::max(0, static_cast<int>(std::floor(vmin)) - 2);
    const int v_hi = std::min(height - 1, static_cast<int>(std::ceil(vmax)) + 2);
    if (u_lo > u_hi || v_lo > v_hi) continue;
    for (int v = v_lo; v <= v_hi; ++v) {
      double* row = img.data() + static_cast<std::size_t>(v) * width;
      for (int k = 0; k < s; ++k) lr.Line(t, v - 0.5 + (k + 0.5) / s, 1.0 / s, u_lo, u_hi, row);
    }
  }
  for (double& x : img) x = std::clamp(x, 0.0, 1.0);
  return img;
}

std::vector<double> RasterizeTargets(int width, int height, const Eigen::Matrix3d& image_from_sheet,
                                     const std::vector<PlacedTarget>& targets, const RasterOptions& o) {
  std::vector<RawTarget> raw;
  for (const auto& t : targets) raw.push_back({t.xyz_mm.head<2>(), CodeOfId(o.profile, o.bits, t.id, "id"), true, {}});
  return RasterizeRaw(width, height, image_from_sheet, raw, o);
}

Eigen::Matrix3d SheetView::K() const {
  Eigen::Matrix3d k;
  k << f_px, 0, (width - 1) / 2.0, 0, f_px, (height - 1) / 2.0, 0, 0, 1;
  return k;
}

Eigen::Matrix3d SheetView::H() const {
  Eigen::Matrix3d h;
  h << rot.col(0), rot.col(1), t;
  return K() * h;
}

SheetView LookAtSheet(const Eigen::Vector2d& look_at_mm, double distance_mm, double tilt_deg, double axis_deg,
                      double roll_deg, double f_px, int width, int height) {
  SheetView v;
  v.f_px = f_px;
  v.width = width;
  v.height = height;
  const double ax = axis_deg * std::numbers::pi / 180;
  v.rot = Eigen::AngleAxisd(tilt_deg * std::numbers::pi / 180, Eigen::Vector3d(std::cos(ax), std::sin(ax), 0)).toRotationMatrix() *
          Eigen::AngleAxisd(roll_deg * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  v.t = Eigen::Vector3d(0, 0, distance_mm) - v.rot * Eigen::Vector3d(look_at_mm.x(), look_at_mm.y(), 0);
  return v;
}

}  // namespace porthole::coded
