// The report's figures: for each, a data file (blocks separated by two blank lines, gnuplot's
// `index`; a header names the columns and their units) and the gnuplot commands that plot it.
// The numbers are the gathered library results; nothing is computed here beyond picking points.
#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "porthole/camera/camera.h"
#include "porthole/camera/profile.h"
#include "porthole/report/internal.h"

namespace porthole::report {
namespace {

constexpr double kDeg = 180.0 / M_PI;

// A number for a data file: gnuplot reads NaN as a gap (infinite and missing values).
std::string N(double v) { return std::isfinite(v) ? fmt::format("{:.7g}", v) : "NaN"; }

// Header of one block: its index and column names with units.
std::string Block(int index, const std::string& what, const std::string& columns) {
  return fmt::format("{}# index {}: {}\n# {}\n", index == 0 ? "" : "\n\n", index, OneLine(what), OneLine(columns));
}

double Um(double mm) { return 1000 * mm; }

// Radii from the principal point to the frame corner (image mm), for smooth profile curves.
std::vector<double> Radii(const camera::Sensor& s, int n = 60) {
  const double corner = 0.5 * std::hypot(s.width_px - 1.0, s.height_px - 1.0) * s.pixel_pitch_mm;
  std::vector<double> r;
  for (int k = 0; k <= n; ++k) r.push_back(corner * k / n);
  return r;
}

// The 1σ of a calibration's distortion profiles at radius r_mm (µm), its covariance propagated to
// the curve: σ² = J·Σ·Jᵀ with J the profile's derivative by the Brown parameters. The radial profile
// δr = K1 r³ + K2 r⁵ + K3 r⁷ is linear (J = [r³, r⁵, r⁷] on K1…K3); the decentring profile
// P = sqrt(P1² + P2²) r² is linearised at the estimate (at P1 = P2 = 0, where it has no derivative,
// the larger of the two σ times r²). NaN without a covariance. (Kept in report/ while camera/ and
// calib/ are being refactored; a candidate for camera/profile.h.)
struct ProfileSigma {
  double radial_um = NAN, decentring_um = NAN;
};
ProfileSigma ProfileSigmaUm(const calib::CalibrationRecord& rec, double r_mm) {
  // The covariance is in the model's parameter order: for Brown, camera::BrownIndex.
  if (!rec.has_covariance || rec.camera.model != camera::CameraModelId::kBrown ||
      rec.covariance.rows() != camera::kBrownNumParams || rec.covariance.cols() != camera::kBrownNumParams) {
    return {};
  }
  const Eigen::MatrixXd& S = rec.covariance;
  const camera::BrownParams brown = camera::ToBrown(rec.camera);
  const double r2 = r_mm * r_mm;
  Eigen::Vector3d jr(r_mm * r2, r_mm * r2 * r2, r_mm * r2 * r2 * r2);
  const Eigen::Matrix3d srr = S.block(camera::kBrownK1, camera::kBrownK1, 3, 3);
  ProfileSigma out;
  out.radial_um = Um(std::sqrt(std::max(0.0, jr.dot(srr * jr))));
  const Eigen::Matrix2d spp = S.block(camera::kBrownP1, camera::kBrownP1, 2, 2);
  const double h = std::hypot(brown.P1, brown.P2);
  if (h > 0) {
    const Eigen::Vector2d jp = r2 * Eigen::Vector2d(brown.P1, brown.P2) / h;
    out.decentring_um = Um(std::sqrt(std::max(0.0, jp.dot(spp * jp))));
  } else {
    out.decentring_um = Um(r2 * std::sqrt(std::max(spp(0, 0), spp(1, 1))));
  }
  return out;
}

// Distortion maps: three vector fields over one grid (µm, image axes, y up), drawn as the length
// of each vector on one colour scale shared by the three panels, with arrows giving the direction.
struct MapSample {
  double x_mm = 0, y_mm = 0;
  int row = 0, col = 0;
  std::array<Eigen::Vector2d, 3> v;
};

// Block 0: the grid (x y |v1| |v2| |v3|, rows separated by blank lines); block 1: arrows on about
// 11 columns of the grid, scaled so that the longest arrow of the figure is 0.9 grid steps.
std::string MapData(const std::vector<MapSample>& m, const std::array<std::string, 3>& names, double* max_um,
                    double* arrow_mm_per_um) {
  std::string d = Block(0, "the grid (rows separated by a blank line), length of each correction vector",
                        fmt::format("x_mm y_mm {}_um {}_um {}_um", names[0], names[1], names[2]));
  int last_row = -1, cols = 1, rows = 1;
  double vmax = 0, x_lo = INFINITY, x_hi = -INFINITY;
  for (const auto& p : m) {
    if (last_row >= 0 && p.row != last_row) d += "\n";
    last_row = p.row;
    cols = std::max(cols, p.col + 1);
    rows = std::max(rows, p.row + 1);
    x_lo = std::min(x_lo, p.x_mm);
    x_hi = std::max(x_hi, p.x_mm);
    d += fmt::format("{} {} {} {} {}\n", N(p.x_mm), N(p.y_mm), N(p.v[0].norm()), N(p.v[1].norm()), N(p.v[2].norm()));
    for (const auto& v : p.v) {
      if (std::isfinite(v.norm())) vmax = std::max(vmax, v.norm());
    }
  }
  const int stride = std::max(1, (cols + 10) / 11);
  const double step_mm = cols > 1 ? (x_hi - x_lo) / (cols - 1) * stride : 1;
  const double scale = vmax > 0 ? 0.9 * step_mm / vmax : 0;
  d += Block(1, fmt::format("arrows: every {} grid points, {:.4g} mm of image per µm of correction", stride, scale),
             fmt::format("x_mm y_mm dx_{0} dy_{0} dx_{1} dy_{1} dx_{2} dy_{2} (mm on the chart)", names[0], names[1],
                         names[2]));
  const int r0 = (rows - 1) % stride / 2, c0 = (cols - 1) % stride / 2;  // centred on the grid
  for (const auto& p : m) {
    if ((p.row - r0) % stride != 0 || (p.col - c0) % stride != 0 || p.row < r0 || p.col < c0) continue;
    std::string line = fmt::format("{} {}", N(p.x_mm), N(p.y_mm));
    for (const auto& v : p.v) line += fmt::format(" {} {}", N(scale * v.x()), N(scale * v.y()));
    d += line + "\n";
  }
  *max_um = vmax;
  *arrow_mm_per_um = scale;
  return d;
}

const char* kMapSetup =
    "set size ratio -1\nset xlabel \"x (mm, image)\"\nset ylabel \"y (mm, image, up)\"\n"
    "set palette defined (0 \"#30123b\", 1 \"#4662d7\", 2 \"#36aaf9\", "
    "3 \"#1ae4b6\", 4 \"#72fe5e\", 5 \"#c8ef34\", 6 \"#faba39\", 7 \"#f66b19\", 8 \"#ca2a04\")\n"
    "set autoscale fix\nunset grid\nunset key\n";

// Three panels in a 2×2 layout on one colour scale (0 … max_um), its colour bar in the fourth cell.
// A round step giving about n intervals over `extent` (1, 2 or 5 times a power of ten).
double NiceStep(double extent, int n) {
  if (!(extent > 0)) return 1;
  const double raw = extent / n, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * p >= raw) return m * p;
  }
  return 10 * p;
}

std::string MapPanels(const std::array<std::string, 3>& titles, double max_um, double half_width_mm,
                      double half_height_mm) {
  const double top = max_um > 0 ? max_um : 1;
  std::string b = std::string(kMapSetup) +
                  fmt::format("set cbrange [0:{}]\nset cbtics {}\nset xtics {}\nset ytics {}\nunset colorbox\n", N(top),
                              N(NiceStep(top, 4)), N(NiceStep(half_width_mm, 2)), N(NiceStep(half_height_mm, 2))) +
                  "set multiplot layout 2,2\n";
  for (int k = 0; k < 3; ++k) {
    if (k == 2) {
      b += "set colorbox user horizontal origin screen 0.6,0.25 size screen 0.32,0.04\n"
           "set cblabel \"|Δ| (µm), one scale for (a)–(c)\"\n";
    }
    b += fmt::format(
        "set title \"{}\"\n"
        "plot data index 0 using 1:2:{} with image notitle, \\\n"
        "     data index 1 using 1:2:{}:{} with vectors head filled size screen 0.008,20 lc rgb \"#ffffff\" lw 1.3 notitle\n",
        titles[k], 3 + k, 3 + 2 * k, 4 + 2 * k);
  }
  return b;
}

// The section of a sphere by the housing's x–z plane (y = 0) where the dome has glass (z >= rim):
// points (z, x) from one end of the arc to the other. Empty when the plane misses the glass.
std::vector<std::pair<double, double>> DomeArc(const ports::SphereSpec& s, double rim_z_mm, int n = 181) {
  const double r2 = s.radius_mm * s.radius_mm - s.center_mm.y() * s.center_mm.y();
  if (r2 <= 0) return {};
  const double rs = std::sqrt(r2);  // radius of the circle cut by y = 0
  const double c = (rim_z_mm - s.center_mm.z()) / rs;
  if (c >= 1) return {};
  const double a_max = c <= -1 ? M_PI : std::acos(c);
  std::vector<std::pair<double, double>> pts;
  for (int k = 0; k < n; ++k) {
    const double a = -a_max + 2 * a_max * k / (n - 1);
    pts.emplace_back(s.center_mm.z() + rs * std::cos(a), s.center_mm.x() + rs * std::sin(a));
  }
  return pts;
}

Figure PortRays(const Results& r) {
  const ports::PortSystem& sys = r.plan.system;
  const ports::Vec3 ep = sys.ep_in_housing_mm;
  Figure f{"port-rays", "port", "The port and its rays", "", 960, 700, "", ""};
  std::string& d = f.data;
  const double d_target = r.plan.target->virtual_image.d_s2ep_mm;
  const double z_inf = r.infinity.focused.image_z_mm;  // a point fixed in the housing
  double half = 100, zmin = 0, zmax = 0;
  std::string glass_note;
  const ports::PortSection sec = std::visit([](const auto& shape) { return shape.Section(); }, sys.spec.shape);
  if (sec.outer.IsCircle() && sec.inner.IsCircle()) {
    // A curved port's section (ports::PortSection): a dome's spheres, a cylinder's circles about its axis.
    const ports::SphereSpec outer_s{sec.outer.center_mm, sec.outer.radius_mm}, inner_s{sec.inner.center_mm, sec.inner.radius_mm};
    // The glass as the tracer sees it (ports::PortSystem::Outward): only where z >= the rim plane.
    const double rim_z = sec.rim_z_mm.value_or(outer_s.center_mm.z());
    const auto outer = DomeArc(outer_s, rim_z), inner = DomeArc(inner_s, rim_z);
    half = 1.12 * outer_s.radius_mm;
    d += Block(0, fmt::format("outer surface, glass where z >= rim z = {} mm", N(rim_z)), "z_mm x_mm (housing frame)");
    for (const auto& [z, x] : outer) d += fmt::format("{} {}\n", N(z), N(x));
    d += Block(1, "inner surface", "z_mm x_mm");
    for (const auto& [z, x] : inner) d += fmt::format("{} {}\n", N(z), N(x));
    d += Block(2, "the glass: outer arc, then the inner arc back (closed at the rim)", "z_mm x_mm");
    for (const auto& [z, x] : outer) d += fmt::format("{} {}\n", N(z), N(x));
    for (auto it = inner.rbegin(); it != inner.rend(); ++it) d += fmt::format("{} {}\n", N(it->first), N(it->second));
    if (!outer.empty()) d += fmt::format("{} {}\n", N(outer.front().first), N(outer.front().second));
    zmin = std::min({0.0, ep.z() - 20, rim_z - 10});
    zmax = std::max({sys.OuterVertexZ(), ep.z() + d_target, std::isfinite(z_inf) ? z_inf : 0.0}) + 0.12 * half;
    if (sec.rim_z_mm) glass_note = fmt::format(" The glass ends at the rim plane z = {:.1f} mm.", rim_z);
  } else {
    const double zi = sys.InnerVertexZ(), zo = sys.OuterVertexZ();
    // A flat port drawn as deep as it is wide around the chief rays: the virtual image lies far
    // beyond, its distance given by the arrow.
    double xmax = 0;
    for (const auto& path : r.fan) {
      for (const auto& p : path.points) {
        if (p.z() <= zo + 1e-9) xmax = std::max(xmax, std::abs(p.x() - ep.x()));
      }
    }
    half = std::max(1.6 * xmax, 0.5 * (zo - ep.z()) + 20);
    const double plate = 1.25 * xmax;
    d += Block(0, "outer plane", "z_mm x_mm") + fmt::format("{} {}\n{} {}\n", N(zo), N(ep.x() - plate), N(zo), N(ep.x() + plate));
    d += Block(1, "inner plane", "z_mm x_mm") + fmt::format("{} {}\n{} {}\n", N(zi), N(ep.x() - plate), N(zi), N(ep.x() + plate));
    d += Block(2, "the glass", "z_mm x_mm") +
         fmt::format("{0} {2}\n{1} {2}\n{1} {3}\n{0} {3}\n{0} {2}\n", N(zi), N(zo), N(ep.x() - plate), N(ep.x() + plate));
    zmin = std::min(0.0, ep.z() - 20);
    zmax = zo + 1.6 * half;
  }
  d += Block(3, "chief rays from the entrance pupil to the edges of the frame (one sub-block per ray)", "z_mm x_mm");
  for (const auto& path : r.fan) {
    for (const auto& p : path.points) d += fmt::format("{} {}\n", N(p.z()), N(p.x()));
    d += "\n";
  }
  // The camera sees each object point along its air ray, at the distance of its virtual image.
  const auto& field = r.plan.target->field;
  d += Block(4, "virtual image of the flat object plane at the target WD (real rays; image diagonal)", "z_mm x_mm");
  if (field) {
    std::vector<std::pair<double, double>> pts;
    for (const auto& row : field->rows) {
      const double t = std::tan(row.field_angle_deg / kDeg);
      pts.emplace_back(ep.z() + row.d_s2ep_mm, ep.x() + row.d_s2ep_mm * t);
    }
    for (auto it = pts.rbegin(); it != pts.rend(); ++it) d += fmt::format("{} {}\n", N(it->first), N(2 * ep.x() - it->second));
    for (const auto& p : pts) d += fmt::format("{} {}\n", N(p.first), N(p.second));
  }
  d += Block(5, "the air rays extended (dashed) to the virtual image's distance", "z_mm x_mm");
  for (double a : r.fan_angles_deg) {
    d += fmt::format("{} {}\n{} {}\n\n", N(ep.z()), N(ep.x()), N(ep.z() + d_target), N(ep.x() + d_target * std::tan(a / kDeg)));
  }
  // Marked points, each label placed clear of the others and joined to its point by a leader line.
  d += Block(6, "marked points", "z_mm x_mm label label_z_mm label_x_mm right_aligned");
  auto mark = [&d](double z, double x, const std::string& label, double lz, double lx, bool right = false) {
    d += fmt::format("{} {} \"{}\" {} {} {}\n", N(z), N(x), label, N(lz), N(lx), right ? 1 : 0);
  };
  // Near the pupil the labels go above and below the fan of chief rays (which leaves the pupil
  // within ±atan(half sensor width / c) of the axis), a few mm ahead of it.
  const double fan_tan = std::tan(std::abs(r.fan_angles_deg.empty() ? 30.0 : r.fan_angles_deg.front()) / kDeg);
  const double label_mm = 130 * (zmax - zmin) / 700;  // a 14-character label at 16 px on a ~700 px wide plot
  // A fisheye's fan fills the chart: the labels then stay inside it, over the rays.
  const double lz = ep.z() + 0.05 * half,
               clear = std::min(fan_tan * (0.05 * half + label_mm) + 0.12 * half, 0.7 * half);
  mark(ep.z(), ep.x(), "entrance pupil", lz, ep.x() - clear);
  if (sec.outer.IsCircle() && sec.inner.IsCircle()) {
    // A centre at the pupil (a port concentric about it) is the pupil's mark.
    const ports::Vec3 oc = sec.outer.center_mm, ic = sec.inner.center_mm;
    const auto apart = [&](const ports::Vec3& c) { return std::hypot(c.z() - ep.z(), c.x() - ep.x()) > 1e-6; };
    if (apart(oc)) mark(oc.z(), oc.x(), "outer centre", lz, ep.x() + clear);
    if (apart(ic)) mark(ic.z(), ic.x(), "inner centre", lz, ep.x() + clear + 0.14 * half);
  }
  const bool target_on_chart = ep.z() + d_target < zmax;
  if (target_on_chart) {
    mark(ep.z() + d_target, ep.x(), fmt::format("virtual image (WD {:.0f} mm)", r.plan.target->wd_mm),
         ep.z() + d_target - 0.05 * half, ep.x() - 0.1 * half, true);
  }
  if (std::isfinite(z_inf) && z_inf < zmax) {
    mark(z_inf, ep.x(), "image of infinity", z_inf - 0.05 * half, ep.x() + 0.1 * half, true);
  }
  std::string off_chart;
  if (!target_on_chart) {
    off_chart = fmt::format("set title \"the virtual image of the target lies {:.0f} mm from the pupil, off the chart → \" "
                            "textcolor rgb \"#2a9d5c\"\n", d_target);
  }
  f.caption = fmt::format(
      "Cross-section, to scale, of {} (x–z plane of the housing frame, origin at the lens-mount flange) "
      "with the chief rays to the frame's left and right edges traced from the entrance pupil through the "
      "glass into the water (like the paper's Figs. 5–6).{} The camera sees the object plane at WD {:.0f} mm "
      "as the green virtual image {:.1f} mm ahead of the pupil{}.",
      sys.spec.name, glass_note, r.plan.target->wd_mm, d_target,
      sys.spec.IsCurved() ? ", curved because of the port's field curvature" : " (beyond the chart)");
  f.body = fmt::format(
      "set size ratio -1\nset xlabel \"z (mm, housing frame: toward the scene)\"\nset ylabel \"x (mm)\"\n"
      "set xrange [{}:{}]\nset yrange [{}:{}]\nset key outside below center horizontal maxcols 2 samplen 2.5\nset bmargin 7\n"
      "set style fill transparent solid 0.35 noborder\nset style textbox opaque noborder margins 1,1\n{}"
      "plot data index 2 using 1:2 with filledcurves closed lc rgb \"#a9c6de\" title \"glass\", \\\n"
      "     data index 0 using 1:2 with lines ls 6 title \"outer surface\", \\\n"
      "     data index 1 using 1:2 with lines ls 7 title \"inner surface\", \\\n"
      "     data index 3 using 1:2 with lines ls 1 lw 1.2 title \"chief rays\", \\\n"
      "     data index 5 using 1:2 with lines ls 5 title \"air rays, extended\", \\\n"
      "     data index 4 using 1:2 with lines ls 3 lw 2.5 title \"image of the object plane\", \\\n"
      "     data index 6 using 4:5:($1-$4):($2-$5) with vectors nohead lc rgb \"#888888\" lw 0.8 notitle, \\\n"
      "     data index 6 using 1:2 with points pt 7 ps 1 lc rgb \"#222222\" notitle, \\\n"
      "     data index 6 using 4:5:($6 == 0 ? stringcolumn(3) : \"\") with labels left offset 0.3,0 notitle, \\\n"
      "     data index 6 using 4:5:($6 == 1 ? stringcolumn(3) : \"\") with labels right offset -0.3,0 notitle\n",
      N(zmin), N(zmax), N(ep.x() - half), N(ep.x() + half), off_chart);
  return f;
}

// Ticks a reader can use on a logarithmic axis in mm: 1-2-5 steps between lo and hi.
std::string LogTics(const std::string& axis, double lo, double hi) {
  std::string t;
  // 1-2-5 over up to two decades; wider ranges get one labelled tick per decade.
  const std::vector<double> steps = hi / lo > 150 ? std::vector<double>{1.0} : hi / lo > 40 ? std::vector<double>{1.0, 2.0, 5.0} : std::vector<double>{1.0, 2.0, 3.0, 5.0};
  for (double decade = 1; decade <= 1e7; decade *= 10) {
    for (double m : steps) {
      const double v = m * decade;
      if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) t += (t.empty() ? "" : ", ") + fmt::format("\"{:g}\" {:g}", v, v);
    }
  }
  return fmt::format("set {}tics ({})\nset m{}tics 10\n", axis, t, axis);
}

// The WD the lens cannot reach without a close-up lens, shaded on a plot whose x axis is WD.
std::string UnreachableWd(const planning::Plan& p, double x0, double label_y = 0.94) {
  if (!(p.min_wd_mm > x0)) return "";
  const double x1 = std::isfinite(p.min_wd_mm) ? p.min_wd_mm : 1e12;
  return fmt::format(
      "set object 1 rect from {0},graph 0 to {1},graph 1 fc rgb \"#e9e9e9\" fillstyle solid 1.0 noborder behind\n"
      "{2}", N(x0), N(x1),
      label_y > 0 ? fmt::format("set label 1 \"lens cannot focus\" at {},graph {} left offset 1.2,0 textcolor rgb "
                                "\"#777777\"\n", N(x0), N(label_y))
                  : "");
}

Figure VirtualImage(const Results& r) {
  Figure f{"virtual-image", "focus", "Virtual image and focus scale against working distance", "", 960, 720, "", ""};
  const VirtualRow& inf = r.infinity.focused;
  std::string& d = f.data;
  d += Block(0, "dense curve (pupil where the lens puts it when focused on each image)",
             "wd_mm d_s2ep_mm vwd_mm d_s2ep_real_mm focus_scale_fd_mm (NaN: closer than the lens focuses)");
  for (const auto& v : r.curve) {
    d += fmt::format("{} {} {} {} {}\n", N(v.wd_mm), N(v.d_s2ep_mm), N(v.vwd_mm), N(v.d_s2ep_real_mm),
                     N(v.fd_mm.value_or(NAN)));
  }
  d += Block(1, "the paper's Table 5 working distances", "wd_mm d_s2ep_mm vwd_mm focus_scale_fd_mm");
  for (const auto& v : r.table) {
    if (std::isfinite(v.wd_mm)) {
      d += fmt::format("{} {} {} {}\n", N(v.wd_mm), N(v.d_s2ep_mm), N(v.vwd_mm), N(v.fd_mm.value_or(NAN)));
    }
  }
  d += Block(2, "WD = infinity (the asymptotes; the table's last row)", "d_s2ep_mm vwd_mm focus_scale_fd_mm");
  d += fmt::format("{} {} {}\n", N(inf.d_s2ep_mm), N(inf.vwd_mm), N(inf.fd_mm.value_or(NAN)));
  const bool curved = r.plan.system.spec.IsCurved();
  f.caption = fmt::format(
      "Top: where the port puts the virtual image of an object at working distance WD — from the "
      "entrance pupil (D_S2EP, with the pupil where the lens puts it when focused on that image) and from "
      "the port's outer surface (VWD), paraxial and by real rays at f/{:g}; the points are the paper's "
      "Table 5 distances, the dashed lines WD = ∞. Bottom: the focus-scale distance FD to set on the lens "
      "(Eq. 2); missing where the lens cannot focus that close (shaded).{}",
      r.in->f_number,
      curved && std::isfinite(inf.d_s2ep_mm)
          ? fmt::format(" Behind this {} the whole water, out to infinity, is imaged within {:.1f} mm of "
                        "the pupil (VWD {:.1f} mm).", r.plan.system.spec.KindName(), inf.d_s2ep_mm, inf.vwd_mm)
          : "");
  std::string asymptotes;
  if (std::isfinite(inf.d_s2ep_mm)) {
    asymptotes = fmt::format(
        "set arrow 2 from graph 0, first {0} to graph 1, first {0} nohead ls 5 lc rgb \"#1f5fa8\"\n"
        "set arrow 3 from graph 0, first {1} to graph 1, first {1} nohead ls 5 lc rgb \"#2a9d5c\"\n"
        "set label 2 \"WD = ∞: {0:.1f} mm\" at graph 0.96, first {0} right offset 0,0.7 textcolor rgb \"#1f5fa8\"\n"
        "set label 3 \"WD = ∞: {1:.1f} mm\" at graph 0.96, first {1} right offset 0,0.7 textcolor rgb \"#2a9d5c\"\n",
        inf.d_s2ep_mm, inf.vwd_mm);
  }
  std::string fd_inf;
  double fd_min = INFINITY;
  for (const auto& v : r.curve) {
    if (v.fd_mm && std::isfinite(*v.fd_mm)) fd_min = std::min(fd_min, *v.fd_mm);
  }
  if (inf.fd_mm && std::isfinite(*inf.fd_mm)) {
    fd_inf = fmt::format(
        "set arrow 2 from graph 0, first {0} to graph 1, first {0} nohead ls 5 lc rgb \"#8e44ad\"\n"
        "set label 2 \"WD = ∞: {0:.1f} mm\" at graph 0.96, first {0} right offset 0,0.7 textcolor rgb \"#8e44ad\"\n"
        "set yrange [*:{1}]\n",
        *inf.fd_mm, N(*inf.fd_mm + 0.15 * (*inf.fd_mm - fd_min)));
  }
  f.body = fmt::format(
      "set multiplot layout 2,1\nset logscale x\n{0}set xrange [50:100000]\n"
      "set xlabel \"WD (mm, object to the port's outer surface)\"\nset key outside right top vertical Left reverse\n"
      "set lmargin 10\nset rmargin 27\n{1}{2}set ylabel \"distance (mm)\"\n"
      "plot data index 0 using 1:2 with lines ls 1 title \"D_{{S2EP}} (to the pupil)\", \\\n"
      "     data index 0 using 1:4 with lines ls 5 title \"D_{{S2EP}}, real rays\", \\\n"
      "     data index 0 using 1:3 with lines ls 3 title \"VWD (to the port)\", \\\n"
      "     data index 1 using 1:2 with points pt 7 lc rgb \"#1f5fa8\" title \"Table 5 distances\", \\\n"
      "     data index 1 using 1:3 with points pt 7 lc rgb \"#2a9d5c\" notitle\n"
      "unset arrow\nunset label 2\nunset label 3\nset yrange [*:*]\n{4}{5}{3}"
      "set ylabel \"focus scale FD (mm)\"\n"
      "plot data index 0 using 1:5 with lines ls 4 title \"focus scale to set\", \\\n"
      "     data index 1 using 1:4 with points pt 7 lc rgb \"#8e44ad\" notitle\n",
      LogTics("x", 50, 100000), UnreachableWd(r.plan, 50, 0), curved ? asymptotes + fmt::format("set yrange [0:{}]\n", N(1.14 * inf.d_s2ep_mm)) : "set logscale y\n" + LogTics("y", 10, 1e6), fd_inf,
      // FD: linear behind a curved port (it spans tens of mm), logarithmic behind a flat port.
      curved ? "unset logscale y\nset ytics autofreq\nset mytics default\n" : LogTics("y", 100, 1e7),
      UnreachableWd(r.plan, 50, 0.5));
  return f;
}

Figure MinWd(const Results& r) {
  const planning::Plan& p = r.plan;
  Figure f{"min-wd", "focus", "Minimum working distance of the lens (Fig. 12)", "", 960, 680, "", ""};
  const double xmax = std::isfinite(p.min_wd_mm) ? std::max(3000.0, 1.5 * p.min_wd_mm) : 3000;
  std::string& d = f.data;
  d += Block(0, "virtual image against WD (pupil where the lens puts it when focused on each image)",
             "wd_mm d_s2ep_mm vwd_mm");
  for (const auto& v : r.curve) {
    if (v.wd_mm <= xmax * 1.3) d += fmt::format("{} {} {}\n", N(v.wd_mm), N(v.d_s2ep_mm), N(v.vwd_mm));
  }
  d += Block(1, "close-up lenses: the WD range each brings within reach, cut at the chart's edge",
             "dioptre min_wd_mm max_wd_drawn_mm far_end_label");
  for (const auto& c : p.closeup) {
    d += fmt::format("{:g} {} {} \"{}\"\n", c.dioptre, N(c.min_wd_mm), N(std::min(c.max_wd_mm, xmax)),
                     std::isfinite(c.max_wd_mm) ? fmt::format("{:.0f} mm", c.max_wd_mm) : "to ∞");
  }
  const double d_inf = r.infinity.focused.d_s2ep_mm;
  const double ymax = std::isfinite(d_inf) ? d_inf * 1.12 : 2 * p.closest_d_s2ep_mm;
  f.caption = fmt::format(
      "The lens focuses no closer than {:.1f} mm from its entrance pupil (Eq. 2 at its {:g} mm minimum "
      "focus): the grey line. Objects whose virtual image (blue) is closer cannot be sharp, so the "
      "minimum working distance is {} mm (the paper's Fig. 12 and Section 4); closer is shaded. Below: "
      "the WD ranges that close-up lenses bring within reach.",
      p.closest_d_s2ep_mm, r.in->setup.lens.min_focus_mm,
      std::isfinite(p.min_wd_mm) ? fmt::format("{:.0f}", p.min_wd_mm) : "infinite");
  std::string min_line;
  if (std::isfinite(p.min_wd_mm)) {
    min_line = fmt::format(
        "set arrow 5 from {0},graph 0 to {0},graph 1 nohead ls 5 lc rgb \"#c8322d\"\n"
        "set label 5 \"minimum WD {0:.0f} mm\" at {0},graph 0.85 left offset 0.5,0 textcolor rgb \"#c8322d\" front\n",
        p.min_wd_mm);
  }
  std::string dpt_tics;
  for (const auto& c : p.closeup) dpt_tics += (dpt_tics.empty() ? "" : ", ") + fmt::format("\"+{0:g} dpt\" {0:g}", c.dioptre);
  const double dmax = p.closeup.empty() ? 1 : p.closeup.back().dioptre;
  f.body = fmt::format(
      "set multiplot\nset lmargin at screen 0.13\nset rmargin at screen 0.74\n"
      "set size 1,0.68\nset origin 0,0.32\nset bmargin 3\n"
      "set xrange [0:{0}]\nset yrange [0:{1}]\nset xlabel \"WD (mm, object to the port's outer surface)\"\n"
      "set ylabel \"distance (mm)\"\nset key at screen 0.76, graph 1 left top vertical Left reverse samplen 2\n{2}{4}"
      "set arrow 6 from graph 0,first {3} to graph 1,first {3} nohead lw 2 lc rgb \"#777777\"\n"
      "set label 6 \"closest focus of the lens, {3:.1f} mm\" at graph 0.99,first {3} right offset 0,-0.8 "
      "textcolor rgb \"#555555\" front\n"
      "plot data index 0 using 1:2 with lines ls 1 title \"D_{{S2EP}}\", \\\n"
      "     data index 0 using 1:3 with lines ls 3 title \"VWD\", \\\n"
      "     NaN with lines lw 2 lc rgb \"#777777\" title \"closest focus\"\n"
      "unset arrow\nunset label\nunset object\nset size 1,0.32\nset origin 0,0\nset tmargin 0.5\n"
      "set xlabel \"WD (mm) that the close-up lens brings within reach\"\nunset ylabel\n"
      "set yrange [{5}:{6}]\nset ytics ({7})\nunset key\nset grid xtics\n"
      "plot data index 1 using (($2+$3)/2):1:(($3-$2)/2):(0.18) with boxxyerror fs solid 1.0 noborder "
      "lc rgb \"#8e44ad\" notitle, \\\n"
      "     data index 1 using 3:1:4 with labels left offset 0.8,0 notitle\n",
      N(xmax), N(ymax), min_line, p.closest_d_s2ep_mm, UnreachableWd(p, 0), N(0.4), N(dmax + 0.6), dpt_tics);
  return f;
}

Figure DepthOfField(const Results& r) {
  Figure f{"dof", "dof", "Depth of field under water and in air", "", 960, 640, "", ""};
  std::string& d = f.data;
  const double x0 = r.dof.front().subject_mm * 0.9, x1 = r.dof.back().subject_mm * 1.05;
  const double y0 = x0 * 0.8, y1 = r.dof.back().subject_mm * 4;
  d += Block(0, "thin-lens limits against the subject's distance from the entrance pupil",
             "subject_mm air_near_mm air_far_mm water_near_mm water_far_mm (NaN: infinite) "
             "air_far_clipped_mm water_far_clipped_mm (infinite drawn at the top of the chart)");
  for (const auto& row : r.dof) {
    d += fmt::format("{} {} {} {} {} {} {}\n", N(row.subject_mm), N(row.air.near_mm), N(row.air.far_mm),
                     N(row.water.near_mm), N(row.water.far_mm), N(std::min(row.air.far_mm, 10 * y1)),
                     N(std::min(row.water.far_mm, 10 * y1)));
  }
  const auto& t = *r.plan.target;
  const bool shade = r.min_subject_mm > x0;
  f.caption = fmt::format(
      "Near and far limits of sharpness at f/{:g} with a {:.1f} µm circle of confusion ({}), for a "
      "subject at each distance from the entrance pupil: in air (red, hatched) and under water (blue: the "
      "thin-lens limits applied to the virtual image and mapped back through the port). At {:.0f} mm the "
      "depth of field is {:.0f} mm in air and {:.0f} mm under water, {:.2f} times more (Section 4).{}",
      r.plan.f_number, 1000 * r.plan.coc_mm, r.plan.coc_source, t.subject_distance_mm, t.air.total_mm,
      t.water.total_mm, t.dof_ratio_water_to_air,
      shade ? fmt::format(" Shaded: under water the lens cannot focus on subjects closer than {:.0f} mm from the "
                          "pupil (the minimum WD, {:.0f} mm).", r.min_subject_mm, r.plan.min_wd_mm)
            : "");
  std::string unreachable;
  if (shade) {
    unreachable = fmt::format(
        "set object 1 rect from {0},{1} to {2},{3} fc rgb \"#e9e9e9\" fillstyle solid 1.0 noborder behind\n"
        "set label 1 \"under water the lens\\ncannot focus this close\" at {4},{5} center textcolor rgb \"#666666\"\n",
        N(x0), N(y0), N(std::min(r.min_subject_mm, x1)), N(y1), N(std::sqrt(x0 * std::min(r.min_subject_mm, x1))),
        N(std::sqrt(y0 * y1) * 3));
  }
  f.body = fmt::format(
      "set logscale xy\n{0}{1}set xrange [{2}:{3}]\nset yrange [{4}:{5}]\n"
      "set xlabel \"subject distance from the entrance pupil (mm)\"\nset ylabel \"sharp from … to (mm)\"\n"
      "set key outside top center horizontal\n{6}"
      "set arrow 2 from {7},{4} to {7},{5} nohead ls 5\n"
      "set label 2 \"target {8:.0f} mm\" at {7},{5} right offset -0.5,-1 textcolor rgb \"#555555\"\n"
      "plot data index 0 using 1:4:7 with filledcurves fs transparent solid 0.3 noborder lc rgb \"#1f5fa8\" "
      "title \"under water\", \\\n"
      "     data index 0 using 1:2:6 with filledcurves fs transparent pattern 5 noborder fc rgb \"#c8322d\" "
      "title \"in air\", \\\n"
      "     data index 0 using 1:2 with lines ls 2 notitle, data index 0 using 1:3 with lines ls 2 notitle, \\\n"
      "     data index 0 using 1:4 with lines ls 1 notitle, data index 0 using 1:5 with lines ls 1 notitle, \\\n"
      "     x with lines ls 5 title \"in focus (subject)\"\n",
      LogTics("x", x0, x1), LogTics("y", y0, y1), N(x0), N(x1), N(y0), N(y1), unreachable,
      N(t.subject_distance_mm), t.subject_distance_mm);
  return f;
}

Figure FieldCurvature(const Results& r) {
  Figure f{"field-curvature", "dof", "Field curvature across the frame", "", 960, 560, "", ""};
  const auto& t = *r.plan.target;
  std::string& d = f.data;
  d += Block(0, "along the sensor diagonal, centre to corner",
             "image_height_mm field_angle_deg object_height_mm d_s2ep_mm sag_mm blur_px spread_px");
  if (t.field) {
    for (const auto& row : t.field->rows) {
      d += fmt::format("{} {} {} {} {} {} {}\n", N(row.image_height_mm), N(row.field_angle_deg),
                       N(row.object_height_mm), N(row.d_s2ep_mm), N(row.sag_mm), N(row.blur_px),
                       N(row.spread_px));
    }
  }
  const double coc_px = r.plan.coc_mm / r.in->setup.camera.sensor.pixel_pitch_mm;
  // The two axes scaled apart so that sag and blur (nearly proportional) stay two curves.
  double sag_max = 0, blur_max = 0;
  if (t.field) {
    for (const auto& row : t.field->rows) {
      if (std::isfinite(row.sag_mm)) sag_max = std::max(sag_max, row.sag_mm);
      if (std::isfinite(row.blur_px)) blur_max = std::max({blur_max, row.blur_px, row.spread_px});
    }
  }
  if (!(sag_max > 0)) sag_max = 1;
  f.caption = t.field ? fmt::format(
      "A flat object plane at WD {:.0f} mm is imaged by the port onto a curved surface (Fig. 6): the "
      "virtual image of an off-axis point lies nearer the camera (sag, left axis). With the lens focused "
      "on the centre, the corners blur (right axis; the dashed line is the {:.1f} px circle of "
      "confusion): {:.1f} px at f/{:g}, within the circle of confusion from f/{:.1f}.",
      t.wd_mm, coc_px, t.field->corner_blur_px, r.plan.f_number, t.field->f_number_for_sharp_corners)
                        : std::string("The real rays failed: no field curvature for this system.");
  f.body = fmt::format(
      "set xlabel \"image height along the diagonal (mm)\"\nset ylabel \"sag of the virtual image (mm)\"\n"
      "set y2label \"defocus blur (px)\"\nset ytics nomirror\nset y2tics\nset key outside below center horizontal\n"
      "set bmargin 6\nset yrange [0:{1}]\nset y2range [0:{2}]\nset arrow from graph 0, second {0} to graph 1, second {0} nohead ls 5\n"
      "set label \"circle of confusion, {0:.1f} px\" at graph 0.02, second {0} left offset 0,0.7 textcolor rgb \"#555555\"\n"
      "plot data index 0 using 1:5 with linespoints ls 3 pt 7 title \"sag toward the camera\", \\\n"
      "     data index 0 using 1:6 axes x1y2 with linespoints ls 2 pt 5 title \"defocus blur\", \\\n"
      "     data index 0 using 1:7 axes x1y2 with linespoints ls 4 pt 9 title \"bundle spread\"\n",
      coc_px, N(1.08 * sag_max), N(1.45 * std::max(blur_max, coc_px)));
  return f;
}

// The principal distance under water over the one in air, whichever model was fitted.
double CRatio(const simulate::Prediction& p) { return p.water_view().c_mm() / p.air_view().c_mm(); }

Figure DomeVsFlat(const Results& r) {
  const auto& main = r.plan.system;
  const auto& other = r.other_plan.system;
  Figure f{"dome-vs-flat", "ports", "Dome against flat port for the same lens", "", 960, 520, "", ""};
  std::string& d = f.data;
  d += Block(0, "chief-ray angle in the water against the angle in air (x-z plane)",
             fmt::format("theta_air_deg theta_water_{}_deg theta_water_{}_deg", main.spec.name, other.spec.name));
  for (const auto& a : r.angles) {
    d += fmt::format("{} {} {}\n", N(a.theta_air_deg), N(a.theta_main_deg), N(a.theta_other_deg));
  }
  d += Block(1, "port-induced radial distortion: radial profile of the water fit minus the air fit",
             fmt::format("r_mm change_{}_um change_{}_um", main.spec.name, other.spec.name));
  for (double rad : Radii(r.prediction.camera.sensor)) {
    auto change = [rad](const simulate::Prediction& p) {
      return Um(p.water_view().RadialProfileMm(rad) - p.air_view().RadialProfileMm(rad));
    };
    d += fmt::format("{} {} {}\n", N(rad), N(change(r.prediction)), N(change(r.other_prediction)));
  }
  f.caption = fmt::format(
      "Left: the angle at which a chief ray leaves into the water against its angle in air — a dome "
      "centred on the pupil keeps it (the diagonal), a flat port narrows it by Snell's law. Diagonal field "
      "of view in water: {} {:.1f}°, {} {:.1f}° (air {:.1f}°). Right: the radial distortion the port adds "
      "(δr of the simulated underwater calibration minus the one in air; negative = pincushion); "
      "principal distance ×{:.4f} behind {} and ×{:.4f} behind {}.",
      main.spec.name, r.plan.fov.water.diagonal_deg, other.spec.name, r.other_plan.fov.water.diagonal_deg,
      r.plan.fov.air.diagonal_deg, CRatio(r.prediction), main.spec.name, CRatio(r.other_prediction), other.spec.name);
  f.body = fmt::format(
      "set multiplot layout 1,2\nset key outside below center vertical\nset bmargin 8\n"
      "set xlabel \"chief-ray angle in air (deg)\"\nset ylabel \"angle in water (deg)\"\n"
      "plot x with lines ls 5 title \"no port (air)\", \\\n"
      "     data index 0 using 1:2 with lines ls 1 title {0}, \\\n"
      "     data index 0 using 1:3 with lines ls 3 title {1}\n"
      "set xlabel \"radial distance r (mm, image)\"\nset ylabel \"δr change, water − air (µm)\"\n"
      "plot data index 1 using 1:2 with lines ls 1 title {0}, \\\n"
      "     data index 1 using 1:3 with lines ls 3 title {1}\n",
      GpText(main.spec.name), GpText(other.spec.name));  // names from port files: escaped
  return f;
}

// A fisheye lens: the fitted model (Kannala–Brandt) has no decentring terms; its radial profile is
// measured against the lens's own projection at the fitted focal length (simulate::FitView).
Figure PredictedFisheye(const Results& r) {
  const simulate::Prediction& p = r.prediction;
  const simulate::FitView water = p.water_view(), air = p.air_view();
  Figure f{"predicted", "simulate", "Predicted underwater calibration: distortion curves", "", 960, 480, "", ""};
  const std::string_view projection = camera::ProjectionName(p.lens_projection);
  f.data = Block(0, fmt::format("radial profile of the fitted {} model against the {} projection at its focal "
                                "length: dr(r) = ideal - fitted radius",
                                water.model_name(), projection),
                 "r_mm dr_air_fit_um dr_water_fit_um");
  for (double rad : Radii(p.camera.sensor)) {
    f.data += fmt::format("{} {} {}\n", N(rad), N(Um(air.RadialProfileMm(rad))), N(Um(water.RadialProfileMm(rad))));
  }
  f.caption = fmt::format(
      "The {0} fisheye model fitted to rays traced through the port, as a self-calibration would find it, with "
      "air (red) and water (blue) outside the port (docs/simulate.md). The lens is an ideal {1} fisheye, so the "
      "curves are the port's own distortion: the radial distance a point's image must move to lie where the {1} "
      "projection at the fitted focal length puts it (µm; {0} has no decentring terms). Focal length ×{2:.4f} "
      "in water.",
      water.model_name(), projection, water.c_mm() / air.c_mm());
  f.body =
      "set key outside right top vertical Left reverse samplen 2\nset xlabel \"r (mm)\"\n"
      "set title \"radial distortion against the lens's projection\"\nset ylabel \"δr (µm)\"\n"
      "plot data index 0 using 1:2 with lines ls 2 title \"air (fit)\", \\\n"
      "     data index 0 using 1:3 with lines ls 1 title \"water (fit)\"\n";
  return f;
}

Figure Predicted(const Results& r) {
  const simulate::Prediction& p = r.prediction;
  if (p.water_fisheye) return PredictedFisheye(r);
  const bool calib = p.predicted_water.has_value();
  Figure f{"predicted", "simulate", "Predicted underwater calibration: distortion curves", "", 960, 820, "", ""};
  std::string& d = f.data;
  d += Block(0, "radial profile dr(r) = K1 r^3 + K2 r^5 + K3 r^7 and decentring P(r) = sqrt(P1^2+P2^2) r^2",
             "r_mm dr_air_fit_um dr_water_fit_um dr_air_calibration_um dr_water_predicted_um "
             "P_air_fit_um P_water_fit_um P_air_calibration_um P_water_predicted_um");
  for (double rad : Radii(p.camera.sensor)) {
    const double ac = calib ? Um(camera::RadialProfileMm(p.camera.lens, rad)) : NAN;
    const double pw = calib ? Um(camera::RadialProfileMm(*p.predicted_water, rad)) : NAN;
    const double pac = calib ? Um(camera::DecentringProfileMm(p.camera.lens, rad)) : NAN;
    const double ppw = calib ? Um(camera::DecentringProfileMm(*p.predicted_water, rad)) : NAN;
    d += fmt::format("{} {} {} {} {} {} {} {} {}\n", N(rad), N(Um(camera::RadialProfileMm(p.air.params, rad))),
                     N(Um(camera::RadialProfileMm(p.water.params, rad))), N(ac), N(pw),
                     N(Um(camera::DecentringProfileMm(p.air.params, rad))),
                     N(Um(camera::DecentringProfileMm(p.water.params, rad))), N(pac), N(ppw));
  }
  f.caption = fmt::format(
      "The central Brown model fitted to rays traced through the port, as a self-calibration would find "
      "it, with air (red) and water (blue) outside the port (docs/simulate.md). {}(a) radial profile, "
      "(b) decentring profile, µm against the radial distance in the image.",
      calib ? "Dashed: your in-air calibration and the underwater calibration predicted from it "
              "(in-air calibration + water fit − air fit). "
            : "The lens is an ideal pinhole, so the curves are the port's own distortion. ");
  std::string extra_a, extra_b;
  if (calib) {
    extra_a = ", \\\n     data index 0 using 1:4 with lines ls 2 dt 2 title \"in-air calibration\", \\\n"
              "     data index 0 using 1:5 with lines ls 1 dt 2 title \"water, predicted\"";
    extra_b = ", \\\n     data index 0 using 1:8 with lines ls 2 dt 2 title \"in-air calibration\", \\\n"
              "     data index 0 using 1:9 with lines ls 1 dt 2 title \"water, predicted\"";
  }
  f.body = fmt::format(
      "set multiplot layout 2,1 margins 0.12,0.68,0.09,0.94 spacing 0,0.17\n"
      "set key at screen 0.71, graph 1 left top vertical Left reverse samplen 2\nset xlabel \"r (mm)\"\n"
      "set title \"(a) radial distortion\"\nset ylabel \"δr (µm)\"\n"
      "plot data index 0 using 1:2 with lines ls 2 title \"air (fit)\", \\\n"
      "     data index 0 using 1:3 with lines ls 1 title \"water (fit)\"{}\n"
      "set title \"(b) decentring distortion\"\nset ylabel \"P(r) (µm)\"\n"
      "plot data index 0 using 1:6 with lines ls 2 title \"air (fit)\", \\\n"
      "     data index 0 using 1:7 with lines ls 1 title \"water (fit)\"{}\n",
      extra_a, extra_b);
  return f;
}

Figure Tolerance(const Results& r) {
  Figure f{"tolerance", "simulate", "Tolerance to the entrance pupil's position", "", 960, 1060, "", ""};
  const camera::Sensor& s = r.prediction.camera.sensor;
  const double corner = Radii(s).back();
  auto dr = [](const simulate::SweepRow& row, double rad) {
    return Um(row.water_view().RadialProfileMm(rad) - row.air_view().RadialProfileMm(rad));
  };
  std::string& d = f.data;
  for (int k = 0; k < 2; ++k) {
    const auto& rows = k == 0 ? r.sweep_z : r.sweep_x;
    d += Block(k, k == 0 ? "pupil moved along z (toward the glass)" : "pupil moved along x",
               "offset_mm dc_mm c_ratio_water_air dr_change_5mm_um dr_change_10mm_um dr_change_corner_um");
    for (const auto& row : rows) {
      const double cw = row.water_view().c_mm(), ca = row.air_view().c_mm();
      d += fmt::format("{} {} {} {} {} {}\n", N(row.offset_mm), N(cw - ca), N(cw / ca), N(dr(row, 5)), N(dr(row, 10)),
                       N(dr(row, corner)));
    }
  }
  d += Block(2, "radial profile change (water - air) for each z offset (one sub-block each)",
             "r_mm dr_change_um offset_z_mm");
  for (const auto& row : r.sweep_z) {
    for (double rad : Radii(s, 30)) d += fmt::format("{} {} {}\n", N(rad), N(dr(row, rad)), N(row.offset_mm));
    d += "\n";
  }
  f.caption = fmt::format(
      "How the underwater calibration changes when the entrance pupil is not where the lens puts it "
      "(docs/simulate.md): (a) the change of principal distance Δc = c_water − c_air against the pupil "
      "offset along z (toward the glass) and x; (b) the change of the radial profile at r = 5 mm, 10 mm "
      "and the corner ({:.1f} mm) against the z offset; (c) the whole profile change for each z offset.",
      corner);
  f.body = fmt::format(
      "set multiplot layout 3,1 margins 0.13,0.70,0.07,0.95 spacing 0,0.135\n"
      "set key at screen 0.72, graph 1 left top vertical Left reverse samplen 2\n"
      "set xlabel \"pupil offset (mm)\"\n"
      "set title \"(a) principal distance\"\nset ylabel \"Δc (mm)\"\n"
      "plot data index 0 using 1:2 with linespoints ls 1 pt 7 title \"along z\", \\\n"
      "     data index 1 using 1:2 with linespoints ls 3 pt 5 title \"along x\"\n"
      "set title \"(b) radial profile change\"\nset ylabel \"δr water − air (µm)\"\nset xlabel \"pupil offset along z (mm)\"\n"
      "plot data index 0 using 1:4 with linespoints ls 3 pt 7 title \"r = 5 mm\", \\\n"
      "     data index 0 using 1:5 with linespoints ls 1 pt 5 title \"r = 10 mm\", \\\n"
      "     data index 0 using 1:6 with linespoints ls 2 pt 9 title \"corner, {:.1f} mm\"\n"
      "set title \"(c) profile against z offset\"\nset xlabel \"r (mm)\"\nset cblabel \"z offset (mm)\"\n"
      "set palette defined (0 \"#c8322d\", 1 \"#dddddd\", 2 \"#1f5fa8\")\nunset key\n"
      "plot data index 2 using 1:2:3 with lines lw 2 lc palette notitle\n",
      corner);
  return f;
}

// The simulation's grid, row and column indices from the positions (row-major from the top left).
std::vector<MapSample> SimMapSamples(const std::vector<simulate::MapPoint>& map) {
  std::vector<MapSample> out;
  int row = -1, col = 0;
  double last_y = NAN;
  for (const auto& m : map) {
    if (m.y_mm != last_y) ++row, col = 0;
    last_y = m.y_mm;
    out.push_back({m.x_mm, m.y_mm, row, col++, {m.water_um, m.air_um, m.difference_um}});
  }
  return out;
}

Figure Maps(const Results& r) {
  Figure f{"maps", "simulate", "Predicted distortion maps", "", 960, 700, "", ""};
  double vmax = 0, scale = 0;
  f.data = MapData(SimMapSamples(r.map), {"water", "air", "difference"}, &vmax, &scale);
  f.caption = fmt::format(
      "The {} correction vector over the image (the paper's Fig. 15{}), from the simulated calibrations: "
      "(a) under water, (b) in air, (c) their difference, water − air. Colour: its length, on one scale for "
      "the three panels (0–{:.1f} µm); arrows: its direction, to one scale (the longest is {:.1f} µm).",
      r.prediction.water_view().model_name(),
      r.prediction.water_fisheye
          ? fmt::format("; against the lens's {} projection at the fitted focal length",
                        camera::ProjectionName(r.prediction.lens_projection))
          : "",
      vmax, vmax);
  const camera::Sensor& sn = r.prediction.camera.sensor;
  f.body = MapPanels({"(a) under water", "(b) in air", "(c) difference, water − air"}, vmax,
                     0.5 * sn.width_px * sn.pixel_pitch_mm, 0.5 * sn.height_px * sn.pixel_pitch_mm);
  return f;
}

Figure ResidualMap(const Results& r) {
  Figure f{"residual-map", "simulate", "What no central model absorbs", "", 960, 560, "", ""};
  std::string& d = f.data;
  d += Block(0, "on the simulation's fit grid (rows separated by a blank line)", "x_mm y_mm residual_um");
  double last_y = NAN, vmax = 0;
  for (const auto& m : r.map) {
    if (std::isfinite(last_y) && m.y_mm != last_y) d += "\n";
    last_y = m.y_mm;
    d += fmt::format("{} {} {}\n", N(m.x_mm), N(m.y_mm), N(m.residual_um));
    if (std::isfinite(m.residual_um)) vmax = std::max(vmax, m.residual_um);
  }
  f.caption = fmt::format(
      "The water fit's residual over the image (RMS over the object distances, µm; largest {:.2f} µm): what "
      "the port does that no central {} model absorbs. Its own colour scale: it is far smaller than the "
      "distortion above.", vmax, r.prediction.water_view().model_name());
  f.body = std::string(kMapSetup) + "set cblabel \"residual (µm)\"\nset rmargin 12\n" +
           fmt::format("set cbrange [0:*]\nset cbtics {}\n", N(NiceStep(vmax, 4))) +
           "plot data index 0 using 1:2:3 with image notitle\n";
  return f;
}

Figure CompareCurves(const Results& r) {
  const calib::CompareResult& c = *r.compare;
  const calib::CalibrationRecord& air = *r.in->air_calibration;
  const calib::CalibrationRecord& water = *r.in->water_calibration;
  Figure f{"compare-curves", "compare", "Your calibrations: distortion curves (Fig. 14)", "", 960, 820, "", ""};
  const auto& pw = r.prediction.predicted_water;
  std::string& d = f.data;
  d += Block(0, "radial and decentring profiles of the two calibrations and of the prediction, with the 1-sigma "
             "of each calibration's profile from its covariance (J Sigma J^T; NaN: no covariance)",
             "r_mm dr_air_um dr_water_um P_air_um P_water_um dr_water_predicted_um P_water_predicted_um "
             "sigma_dr_air_um sigma_dr_water_um sigma_P_air_um sigma_P_water_um");
  for (const auto& p : c.curves) {
    const ProfileSigma sa = ProfileSigmaUm(air, p.r_mm), sw = ProfileSigmaUm(water, p.r_mm);
    d += fmt::format("{} {} {} {} {} {} {} {} {} {} {}\n", N(p.r_mm), N(p.radial_a_um), N(p.radial_b_um),
                     N(p.decentring_a_um), N(p.decentring_b_um), N(pw ? Um(camera::RadialProfileMm(*pw, p.r_mm)) : NAN),
                     N(pw ? Um(camera::DecentringProfileMm(*pw, p.r_mm)) : NAN), N(sa.radial_um), N(sw.radial_um),
                     N(sa.decentring_um), N(sw.decentring_um));
  }
  std::string corner_note;
  if (!c.curves.empty() && (air.has_covariance || water.has_covariance)) {
    const double rc = c.curves.back().r_mm;
    const ProfileSigma sa = ProfileSigmaUm(air, rc), sw = ProfileSigmaUm(water, rc);
    corner_note = fmt::format(" At the corner (r = {:.1f} mm) the radial σ is {} µm in air and {} µm under water.", rc,
                              std::isfinite(sa.radial_um) ? fmt::format("{:.2f}", sa.radial_um) : "–",
                              std::isfinite(sw.radial_um) ? fmt::format("{:.2f}", sw.radial_um) : "–");
  }
  auto band_note = [](const calib::CalibrationRecord& rec, const std::string& what) {
    if (!rec.has_covariance) return fmt::format("the {} calibration has no covariance, so it has no band", what);
    if (rec.camera.model != camera::CameraModelId::kBrown) {
      return fmt::format("the {} calibration is not of the Brown model, so it has no band", what);
    }
    if (!rec.covariance_note.empty()) {
      return fmt::format("the {} band uses σ only ({}: correlations unknown)", what, rec.covariance_note);
    }
    return fmt::format("the {} band uses its full covariance", what);
  };
  f.caption = fmt::format(
      "Your in-air (red) and underwater (blue) calibrations as the paper's Fig. 14: (a) radial, (b) decentring "
      "distortion, µm against the radial distance in the image; dashed: the underwater calibration porthole "
      "predicted from the in-air one. Bands: ±1σ of each profile, the calibration's covariance propagated "
      "to the curve (J·Σ·Jᵀ); {}; {}.{}",
      band_note(air, "in-air"), band_note(water, "underwater"), corner_note);
  auto bands = [&](int value_a, int sigma_a, int value_w, int sigma_w) {
    std::string b;
    if (air.has_covariance) {
      b += fmt::format("data index 0 using 1:(${0}-${1}):(${0}+${1}) with filledcurves fs transparent solid 0.22 "
                       "noborder lc rgb \"#c8322d\" title \"air ±1σ\", \\\n     ", value_a, sigma_a);
    }
    if (water.has_covariance) {
      b += fmt::format("data index 0 using 1:(${0}-${1}):(${0}+${1}) with filledcurves fs transparent solid 0.22 "
                       "noborder lc rgb \"#1f5fa8\" title \"water ±1σ\", \\\n     ", value_w, sigma_w);
    }
    return b;
  };
  f.body = fmt::format(
      "set multiplot layout 2,1 margins 0.12,0.68,0.09,0.94 spacing 0,0.17\n"
      "set key at screen 0.71, graph 1 left top vertical Left reverse samplen 2\n"
      "set xlabel \"r (mm)\"\n"
      "set title \"(a) radial distortion\"\nset ylabel \"δr (µm)\"\n"
      "plot {}data index 0 using 1:2 with lines ls 2 title \"air\", \\\n"
      "     data index 0 using 1:3 with lines ls 1 title \"water\", \\\n"
      "     data index 0 using 1:6 with lines ls 1 dt 2 title \"water, predicted\"\n"
      "set title \"(b) decentring distortion\"\nset ylabel \"P(r) (µm)\"\n"
      "plot {}data index 0 using 1:4 with lines ls 2 title \"air\", \\\n"
      "     data index 0 using 1:5 with lines ls 1 title \"water\", \\\n"
      "     data index 0 using 1:7 with lines ls 1 dt 2 title \"water, predicted\"\n",
      bands(2, 8, 3, 9), bands(4, 10, 5, 11));
  return f;
}

Figure CompareMaps(const Results& r) {
  const calib::CompareResult& c = *r.compare;
  Figure f{"compare-maps", "compare", "Your calibrations: distortion maps (Fig. 15)", "", 960, 700, "", ""};
  std::vector<MapSample> samples;
  int row = -1, col = 0;
  double last_v = NAN;
  for (const auto& p : c.map) {
    if (p.v_px != last_v) ++row, col = 0;
    last_v = p.v_px;
    samples.push_back({p.x_mm, p.y_mm, row, col++, {p.a_um, p.b_um, -p.diff_um}});  // diff_um is air − water
  }
  double vmax = 0, scale = 0;
  f.data = MapData(samples, {"air", "water", "water_minus_air"}, &vmax, &scale);
  f.caption = fmt::format(
      "The correction vector over the image, as the paper's Fig. 15: (a) in air, (b) under water, (c) their "
      "difference, water − air. Colour: its length on one scale for the three panels; arrows: its direction. "
      "Largest: {:.1f}, {:.1f} and {:.1f} µm.",
      c.max_a_um, c.max_b_um, c.max_diff_um);
  const camera::Sensor& sn = r.in->air_calibration->camera.sensor;
  f.body = MapPanels({"(a) in air", "(b) under water", "(c) difference, water − air"}, vmax,
                     0.5 * sn.width_px * sn.pixel_pitch_mm, 0.5 * sn.height_px * sn.pixel_pitch_mm);
  return f;
}

Figure RigPlanFigure(const Results& r) {
  const measure::RigPlan& p = *r.rig_plan;
  Figure f{"rig-plan", "rig", "Your rig: the σ of a length and a central model's error against range", "", 960, 820,
           "", ""};
  f.data = Block(0, fmt::format("a {:g} mm length over the common field, image sigma {:g} px ({}); the central "
                                "model's |error| (measured - true); the common field's extent",
                                p.length_mm, p.sigma_px, OneLine(p.calibration_sigma)),
                 "range_m sigma_median_mm sigma_p90_mm sigma_max_mm central_abs_median_mm central_abs_max_mm "
                 "common_width_m common_height_m n_lengths");
  bool any_central = false;
  for (const auto& row : p.rows) {
    // A log axis shows no 0: a length the central model measures exactly plots at the axis's floor.
    const auto pos = [](double v) { return std::isfinite(v) && v > 0 ? v : NAN; };
    any_central = any_central || std::isfinite(pos(row.central_abs_max_mm));
    f.data += fmt::format("{} {} {} {} {} {} {} {} {}\n", N(row.range_mm / 1000), N(pos(row.sigma_median_mm)),
                          N(pos(row.sigma_p90_mm)), N(pos(row.sigma_max_mm)), N(pos(row.central_abs_median_mm)),
                          N(pos(row.central_abs_max_mm)), N(row.common_width_mm / 1000), N(row.common_height_mm / 1000),
                          row.n_lengths);
  }
  f.caption = fmt::format(
      "(a) The σ a {:g} mm length will be measured with (median and 90th percentile over positions and {} directions "
      "in the field every camera sees), for image points of σ = {:g} px; {}. {}(b) The width and height of that "
      "common field.",
      p.length_mm, p.orientations, p.sigma_px, p.calibration_sigma,
      p.central ? fmt::format("Red: the error of a central model (each lens without refraction, calibrated with the "
                              "rig at {:.0f} mm), median and largest |error|: systematic, it does not average out. ",
                              p.central_fit_range_mm)
                : std::string());
  f.body = fmt::format(
      "set multiplot layout 2,1 margins 0.12,0.70,0.09,0.94 spacing 0,0.17\n"
      "set key at screen 0.72, graph 1 left top vertical Left reverse samplen 2\n"
      "set xlabel \"range (m)\"\n"
      "set title \"(a) a {0:g} mm length\"\nset ylabel \"mm\"\nset logscale y\n"
      "plot data index 0 using 1:2 with linespoints ls 1 pt 7 title \"σ, median\", \\\n"
      "     data index 0 using 1:3 with linespoints ls 1 dt 2 pt 6 title \"σ, 90 %\"{1}\n"
      "unset logscale y\n"
      "set title \"(b) the field every camera sees\"\nset ylabel \"m\"\n"
      "plot data index 0 using 1:7 with linespoints ls 3 pt 7 title \"width\", \\\n"
      "     data index 0 using 1:8 with linespoints ls 4 pt 5 title \"height\"\n",
      p.length_mm,
      any_central ? ", \\\n     data index 0 using 1:5 with linespoints ls 2 pt 7 title \"central, median |error|\", \\\n"
                    "     data index 0 using 1:6 with linespoints ls 2 dt 2 pt 6 title \"central, largest |error|\""
                  : "");
  return f;
}

Figure ScaleBarFigure(const Results& r) {
  const measure::ScaleBarCheck& c = *r.in->scale_bar;
  Figure f{"scale-bar", "scale-bar", "Scale bar: the length error against range and position", "", 960, 820, "", ""};
  f.data = Block(0, "each frame: the bar's range, its error (measured - true) with its sigma, its centre in the image",
                 "range_m error_mm sigma_mm u_px v_px");
  double umax = 1, vmax = 1, emax = 0;
  for (const auto& row : c.rows) {
    f.data += fmt::format("{} {} {} {} {}\n", N(row.range_mm / 1000), N(row.error_mm), N(row.sigma_mm),
                          N(row.image_px.x()), N(row.image_px.y()));
    if (std::isfinite(row.image_px.x())) umax = std::max(umax, row.image_px.x());
    if (std::isfinite(row.image_px.y())) vmax = std::max(vmax, row.image_px.y());
    emax = std::max(emax, std::abs(row.error_mm));
  }
  f.data += "\n\n" + Block(1, "500 mm range bins: mean error and RMS sigma", "range_m mean_error_mm rms_sigma_mm n");
  for (const auto& b : c.by_range) {
    f.data += fmt::format("{} {} {} {}\n", N((b.range_min_mm + b.range_max_mm) / 2000), N(b.mean_error_mm),
                          N(b.rms_sigma_mm), b.n);
  }
  if (!(emax > 0)) emax = 1;
  if (r.in->rig) {  // the frame of the rig's first camera (the image the centres are in)
    const camera::Sensor& sn = r.in->rig->rig.cameras.front().camera.sensor;
    umax = sn.width_px / 1.05, vmax = sn.height_px / 1.05;
  }
  f.caption = fmt::format(
      "(a) Each frame's error of the {:g} mm bar (points {} and {}) against its range, with ±2σ; red: the mean of each "
      "500 mm bin. Mean error {:+.3f} mm ± {:.3f} mm (z = {}): {}. (b) Where the bar's centre was in the first "
      "camera's image, coloured by its error (mm): a pattern over the frame points at the calibration.",
      c.bar.length_mm, c.bar.id_a, c.bar.id_b, c.mean_error_mm, c.sigma_mean_mm,
      std::isfinite(c.z) ? fmt::format("{:.2f}", c.z) : std::string("unknown: no sigma"), c.verdict);
  f.body = fmt::format(
      "set multiplot layout 2,1 margins 0.12,0.78,0.09,0.94 spacing 0,0.17\n"
      "set key top left vertical Left reverse samplen 2 box opaque\n"
      "set title \"(a) error against range\"\nset xlabel \"range (m)\"\nset ylabel \"error (mm)\"\n"
      "set xzeroaxis ls 5\n"
      "plot data index 0 using 1:2:(2*$3) with yerrorbars ls 1 pt 7 ps 0.6 title \"frames, ±2σ\", \\\n"
      "     data index 1 using 1:2 with linespoints ls 2 pt 5 title \"bin mean\"\n"
      "set title \"(b) error over the image\"\nset xlabel \"u (px)\"\nset ylabel \"v (px)\"\n"
      "set xrange [0:{}]\nset yrange [{}:0]\nset size ratio -1\nunset xzeroaxis\nunset key\nset xtics {}\nset ytics {}\n"
      "set palette defined (-1 \"#1f5fa8\", 0 \"#f2f2f2\", 1 \"#c8322d\")\nset cbrange [{}:{}]\n"
      "set cblabel \"error (mm)\"\n"
      "plot data index 0 using 4:5:2 with points pt 7 ps 1.2 lc palette notitle\n",
      N(umax * 1.05), N(vmax * 1.05), N(NiceStep(umax * 1.05, 4)), N(NiceStep(vmax * 1.05, 4)), N(-emax), N(emax));
  return f;
}

}  // namespace

std::vector<Figure> MakeFigures(const Results& r) {
  std::vector<Figure> out = {PortRays(r), VirtualImage(r), MinWd(r), DepthOfField(r), FieldCurvature(r),
                             DomeVsFlat(r), Predicted(r), Tolerance(r), Maps(r), ResidualMap(r)};
  if (r.compare) {
    out.push_back(CompareCurves(r));
    out.push_back(CompareMaps(r));
  }
  if (r.rig_plan) out.push_back(RigPlanFigure(r));
  if (r.in->scale_bar) out.push_back(ScaleBarFigure(r));
  return out;
}

std::string FigureScript(const Figure& f) {
  const std::string script = fmt::format(
      "# {title}\n# {caption}\n"
      "# Data: {id}.dat (blocks and columns described in its header). Run `gnuplot {id}.gp` in this\n"
      "# directory to remake {id}.png and {id}.svg; edit the style lines or the commands to restyle.\n"
      "data = \"{id}.dat\"\n"
      "do for [fmt in \"png svg\"] {{\n"
      "if (fmt eq \"png\") {{\n"
      "  set terminal pngcairo size {w},{h} enhanced font \"DejaVu Sans,16\" linewidth 1.2\n"
      "}} else {{\n"
      "  set terminal svg size {w},{h} dynamic enhanced font \"DejaVu Sans,16\" linewidth 1.2 background \"#ffffff\"\n"
      "}}\n"
      "set output \"{id}.\".fmt\n"
      "reset\n"
      "# Style: water blue and air red as in the paper's Fig. 14.\n"
      "set style line 1 lc rgb \"#1f5fa8\" lw 2          # water, this port\n"
      "set style line 2 lc rgb \"#c8322d\" lw 2          # air\n"
      "set style line 3 lc rgb \"#2a9d5c\" lw 2          # second quantity, the other port\n"
      "set style line 4 lc rgb \"#8e44ad\" lw 2          # focus, spread\n"
      "set style line 5 lc rgb \"#666666\" lw 1 dt 2     # guides\n"
      "set style line 6 lc rgb \"#5b8db8\" lw 3          # outer glass surface\n"
      "set style line 7 lc rgb \"#a9c6de\" lw 3          # inner glass surface\n"
      "set grid lc rgb \"#e4e4e4\" lw 1 dt 1\n"
      "set border lc rgb \"#444444\"\n"
      "set tics textcolor rgb \"#333333\"\n"
      "{body}"
      "unset multiplot\n"
      "set output\n"
      "}}\n",
      fmt::arg("title", OneLine(f.title)), fmt::arg("caption", OneLine(f.caption)), fmt::arg("id", f.id),
      fmt::arg("w", f.width_px), fmt::arg("h", f.height_px), fmt::arg("body", f.body));
  CheckGnuplotScript(script, f.id);
  return script;
}

std::string InlineSvg(const std::string& svg, const std::string& id) {
  std::string s = svg;
  if (s.rfind("<?xml", 0) == 0) s.erase(0, s.find("?>") + 2);
  const std::string prefix = id + "-";
  auto replace_all = [&s](const std::string& from, const std::string& to) {
    for (std::size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos + to.size())) {
      s.replace(pos, from.size(), to);
    }
  };
  replace_all("id='", "id='" + prefix);
  replace_all("id=\"", "id=\"" + prefix);
  replace_all("href='#", "href='#" + prefix);
  replace_all("href=\"#", "href=\"#" + prefix);
  replace_all("url(#", "url(#" + prefix);
  const std::size_t start = s.find("<svg");
  return start == std::string::npos ? s : s.substr(start);
}

}  // namespace porthole::report
