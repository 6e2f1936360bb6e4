// The report's figures: for each, a data file (blocks separated by two blank lines, gnuplot's
// `index`; a header names the columns and their units) and the gnuplot commands that plot it.
// The numbers are the gathered library results; nothing is computed here beyond picking points.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

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

// The unit of a map's colour box and a panel.
std::string MapPanel(const std::string& title, int index, int column, const std::string& extra = "") {
  return fmt::format("set title \"{}\"\nplot data index {} using 1:2:{} with image notitle{}\n", title, index,
                     column, extra);
}

const char* kMapSetup =
    "set size ratio -1\nset xlabel \"x (mm, image)\"\nset ylabel \"y (mm, image, up)\"\n"
    "set cblabel \"|Δ| (µm)\" offset 1.5,0\nset palette defined (0 \"#30123b\", 1 \"#4662d7\", 2 \"#36aaf9\", "
    "3 \"#1ae4b6\", 4 \"#72fe5e\", 5 \"#c8ef34\", 6 \"#faba39\", 7 \"#f66b19\", 8 \"#ca2a04\")\n"
    "set autoscale fix\nunset grid\n";

Figure PortRays(const Results& r) {
  const ports::PortSystem& sys = r.plan.system;
  const ports::Vec3 ep = sys.ep_in_housing_mm;
  Figure f{"port-rays", "port", "The port and its rays", "", 960, 620, "", ""};
  std::string& d = f.data;
  double half = 100;
  if (sys.IsDome()) {
    const auto& dome = sys.dome();
    half = 1.15 * dome.outer.radius_mm;
    const double rim_z = dome.outer.center_mm.z();  // a hemisphere: glass ahead of the centre plane
    for (int index = 0; index < 2; ++index) {
      const ports::SphereSpec* s = index == 0 ? &dome.outer : &dome.inner;
      d += Block(index, index == 0 ? "outer sphere" : "inner sphere", "z_mm x_mm (housing frame)");
      for (int k = -90; k <= 90; ++k) {
        const double a = k / kDeg;
        const double z = s->center_mm.z() + s->radius_mm * std::cos(a);
        const double x = s->center_mm.x() + s->radius_mm * std::sin(a);
        if (z >= rim_z - 1e-9) d += fmt::format("{} {}\n", N(z), N(x));
      }
    }
  } else {
    const double zi = sys.InnerVertexZ(), zo = sys.OuterVertexZ();
    d += Block(0, "outer plane", "z_mm x_mm") + fmt::format("{} {}\n{} {}\n", N(zo), -half, N(zo), half);
    d += Block(1, "inner plane", "z_mm x_mm") + fmt::format("{} {}\n{} {}\n", N(zi), -half, N(zi), half);
  }
  d += Block(2, "chief rays from the entrance pupil to the edges of the frame (one sub-block per ray)",
             "z_mm x_mm");
  for (const auto& path : r.fan) {
    for (const auto& p : path.points) d += fmt::format("{} {}\n", N(p.z()), N(p.x()));
    d += "\n";
  }
  // The camera sees each object point along its air ray, at the distance of its virtual image.
  const auto& field = r.plan.target->field;
  d += Block(3, "virtual image of the flat object plane at the target WD (real rays; image diagonal)",
             "z_mm x_mm");
  if (field) {
    std::vector<std::pair<double, double>> pts;
    for (const auto& row : field->rows) {
      const double t = std::tan(row.field_angle_deg / kDeg);
      pts.emplace_back(ep.z() + row.d_s2ep_mm, ep.x() + row.d_s2ep_mm * t);
    }
    for (auto it = pts.rbegin(); it != pts.rend(); ++it) d += fmt::format("{} {}\n", N(it->first), N(2 * ep.x() - it->second));
    for (const auto& p : pts) d += fmt::format("{} {}\n", N(p.first), N(p.second));
  }
  const double d_target = r.plan.target->virtual_image.d_s2ep_mm;
  d += Block(4, "the air rays extended (dashed) to the virtual image's distance", "z_mm x_mm");
  for (double a : r.fan_angles_deg) {
    d += fmt::format("{} {}\n{} {}\n\n", N(ep.z()), N(ep.x()), N(ep.z() + d_target),
                     N(ep.x() + d_target * std::tan(a / kDeg)));
  }
  // Labels sit beside their points (label_z, label_x), staggered so that the pupil and the two
  // centres, a few mm apart, stay legible.
  d += Block(5, "marked points", "z_mm x_mm label label_z_mm label_x_mm");
  auto mark = [&d](double z, double x, const std::string& label, double lz, double lx) {
    d += fmt::format("{} {} \"{}\" {} {}\n", N(z), N(x), label, N(lz), N(lx));
  };
  mark(ep.z(), ep.x(), "entrance pupil", ep.z() + 6, ep.x() - 0.1 * half);
  if (sys.IsDome()) {
    const ports::Vec3 oc = sys.dome().outer.center_mm, ic = sys.dome().inner.center_mm;
    mark(oc.z(), oc.x(), "outer centre", oc.z() - 3, oc.x() + 0.1 * half);
    mark(ic.z(), ic.x(), "inner centre", ic.z() - 3, ic.x() + 0.2 * half);
  }
  mark(ep.z() + d_target, ep.x(), fmt::format("virtual image (WD {:.0f} mm)", r.plan.target->wd_mm),
       ep.z() + d_target + 3, ep.x() - 0.1 * half);
  if (std::isfinite(r.plan.d_s2ep_infinity_mm)) {
    mark(ep.z() + r.plan.d_s2ep_infinity_mm, ep.x(), "image of infinity", ep.z() + r.plan.d_s2ep_infinity_mm + 3,
         ep.x() + 0.06 * half);
  }
  const double zmax = std::isfinite(r.plan.d_s2ep_infinity_mm)
                          ? ep.z() + std::max(r.plan.d_s2ep_infinity_mm, d_target) + 40
                          : ep.z() + 1.1 * d_target + 20;
  const double zmin = std::min(0.0, ep.z() - 30);
  f.caption = fmt::format(
      "Cross-section (x–z plane of the housing frame, origin at the lens-mount flange) of {} with the "
      "chief rays to the frame's left and right edges traced from the entrance pupil through the glass "
      "into the water (like the paper's Figs. 5–6). The camera sees the object plane at WD {:.0f} mm "
      "(off the chart to the right) as the green virtual image {:.1f} mm ahead of the pupil, curved "
      "because of the port's field curvature.",
      sys.spec.name, r.plan.target->wd_mm, d_target);
  f.body = fmt::format(
      "set size ratio -1\nset xlabel \"z (mm, housing frame: toward the scene)\"\nset ylabel \"x (mm)\"\n"
      "set xrange [{}:{}]\nset yrange [{}:{}]\nset key bottom right box opaque\n"
      "plot data index 0 using 1:2 with lines ls 6 lw 3 title \"outer surface\", \\\n"
      "     data index 1 using 1:2 with lines ls 7 lw 3 title \"inner surface\", \\\n"
      "     data index 2 using 1:2 with lines ls 1 lw 1.2 title \"chief rays\", \\\n"
      "     data index 4 using 1:2 with lines ls 5 title \"as the camera sees them\", \\\n"
      "     data index 3 using 1:2 with lines ls 3 lw 2.5 title \"virtual image of the object plane\", \\\n"
      "     data index 5 using 1:2 with points pt 7 ps 1.2 lc rgb \"#222222\" notitle, \\\n"
      "     data index 5 using 4:5:3 with labels left font \",9\" notitle\n",
      N(zmin), N(zmax), N(-half), N(half));
  return f;
}

Figure VirtualImage(const Results& r) {
  Figure f{"virtual-image", "focus", "Virtual image and focus scale against working distance", "", 960, 640, "", ""};
  std::string& d = f.data;
  d += Block(0, "dense curve (pupil at the lens's position for each focus)",
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
  const bool dome = r.plan.system.IsDome();
  f.caption = fmt::format(
      "Top: where the port puts the virtual image of an object at working distance WD — from the "
      "entrance pupil (D_S2EP) and from the port's outer surface (VWD), paraxial and by real rays at "
      "f/{:g}; the points are the paper's Table 5 distances. Bottom: the focus-scale distance FD to set "
      "on the lens (Eq. 2), with the pupil where that focus puts it; missing where the lens cannot focus "
      "that close.{}",
      r.in->f_number,
      dome ? fmt::format(" Behind this dome the whole water, out to infinity, is imaged within {:.1f} mm of "
                         "the pupil.", r.plan.d_s2ep_infinity_mm)
           : "");
  f.body = fmt::format(
      "set multiplot layout 2,1\nset logscale x\nset format x \"%g\"\nset xrange [50:100000]\n"
      "set xlabel \"WD (mm, object to the port's outer surface)\"\nset key top left box opaque\n"
      "{}set ylabel \"distance (mm)\"\n"
      "plot data index 0 using 1:2 with lines ls 1 title \"D_{{S2EP}} (virtual image to pupil)\", \\\n"
      "     data index 0 using 1:4 with lines ls 5 title \"D_{{S2EP}}, real rays\", \\\n"
      "     data index 0 using 1:3 with lines ls 3 title \"VWD (virtual image to port)\", \\\n"
      "     data index 1 using 1:2 with points pt 7 lc rgb \"#1f5fa8\" notitle, \\\n"
      "     data index 1 using 1:3 with points pt 7 lc rgb \"#2a9d5c\" notitle\n"
      "unset logscale y\nset ylabel \"focus scale FD (mm)\"\nset key bottom right\n"
      "plot data index 0 using 1:5 with lines ls 4 title \"focus scale to set\", \\\n"
      "     data index 1 using 1:4 with points pt 7 lc rgb \"#8e44ad\" notitle\n",
      dome ? "" : "set logscale y\n");
  return f;
}

Figure MinWd(const Results& r) {
  const planning::Plan& p = r.plan;
  Figure f{"min-wd", "focus", "Minimum working distance of the lens (Fig. 12)", "", 960, 560, "", ""};
  const double xmax = std::isfinite(p.min_wd_mm) ? std::max(3000.0, 1.5 * p.min_wd_mm) : 3000;
  std::string& d = f.data;
  d += Block(0, "virtual image against WD", "wd_mm d_s2ep_mm vwd_mm");
  for (const auto& v : r.curve) {
    if (v.wd_mm <= xmax) d += fmt::format("{} {} {}\n", N(v.wd_mm), N(v.d_s2ep_mm), N(v.vwd_mm));
  }
  d += Block(1, "close-up lenses: the WD range each brings within reach (one sub-block each)",
             "wd_mm row dioptre");
  const double ymax = std::isfinite(p.d_s2ep_infinity_mm) ? p.d_s2ep_infinity_mm * 1.15 : 2 * p.closest_d_s2ep_mm;
  for (std::size_t k = 0; k < p.closeup.size(); ++k) {
    const auto& c = p.closeup[k];
    const double y = ymax * (0.06 + 0.06 * k);
    d += fmt::format("{} {} {:g}\n{} {} {:g}\n\n", N(c.min_wd_mm), N(y), c.dioptre,
                     N(std::min(c.max_wd_mm, xmax)), N(y), c.dioptre);
  }
  f.caption = fmt::format(
      "The lens focuses no closer than {:.1f} mm from its entrance pupil (Eq. 2 at its {:g} mm minimum "
      "focus): the grey line. Objects whose virtual image (blue) is closer cannot be sharp, so the "
      "minimum working distance is {} mm (the paper's Fig. 12 and Section 4). The bars show the WD "
      "ranges that +1…+4 dioptre close-up lenses bring within reach.",
      p.closest_d_s2ep_mm, r.in->setup.lens.min_focus_mm,
      std::isfinite(p.min_wd_mm) ? fmt::format("{:.0f}", p.min_wd_mm) : "infinite");
  std::string min_line;
  if (std::isfinite(p.min_wd_mm)) {
    min_line = fmt::format(
        "set arrow from {0},0 to {0},{1} nohead ls 5 lc rgb \"#c8322d\"\n"
        "set label \"minimum WD {0:.0f} mm\" at {0},{2} left offset 0.5,0 textcolor rgb \"#c8322d\"\n",
        p.min_wd_mm, N(ymax), N(ymax * 0.92));
  }
  f.body = fmt::format(
      "set xrange [0:{0}]\nset yrange [0:{1}]\nset xlabel \"WD (mm, object to the port's outer surface)\"\n"
      "set ylabel \"distance (mm)\"\nset key center right box opaque\n{2}"
      "set arrow from 0,{3} to {0},{3} nohead lw 2 lc rgb \"#777777\"\n"
      "set label \"closest focus of the lens, {3:.1f} mm\" at {0},{3} right offset -1,0.7 textcolor rgb \"#555555\"\n"
      "plot data index 0 using 1:2 with lines ls 1 title \"D_{{S2EP}}\", \\\n"
      "     data index 0 using 1:3 with lines ls 3 title \"VWD\", \\\n"
      "     data index 1 using 1:2 with lines lw 6 lc rgb \"#8e44ad\" title \"close-up lens range\", \\\n"
      "     data index 1 every 2 using 1:2:(sprintf(\"+%g dpt\", $3)) with labels right offset -0.5,0 "
      "font \",9\" notitle\n",
      N(xmax), N(ymax), min_line, p.closest_d_s2ep_mm);
  return f;
}

Figure DepthOfField(const Results& r) {
  Figure f{"dof", "dof", "Depth of field under water and in air", "", 960, 560, "", ""};
  std::string& d = f.data;
  d += Block(0, "thin-lens limits against the subject's distance from the entrance pupil",
             "subject_mm air_near_mm air_far_mm water_near_mm water_far_mm (NaN: infinite)");
  for (const auto& row : r.dof) {
    d += fmt::format("{} {} {} {} {}\n", N(row.subject_mm), N(row.air.near_mm), N(row.air.far_mm),
                     N(row.water.near_mm), N(row.water.far_mm));
  }
  const auto& t = *r.plan.target;
  f.caption = fmt::format(
      "Near and far limits of sharpness at f/{:g} with a {:.1f} µm circle of confusion ({}), for a "
      "subject at each distance from the entrance pupil: in air (red) and under water (blue: the thin-lens "
      "limits applied to the virtual image and mapped back through the port). At {:.0f} mm the depth of "
      "field is {:.0f} mm in air and {:.0f} mm under water, {:.2f} times more (Section 4).",
      r.plan.f_number, 1000 * r.plan.coc_mm, r.plan.coc_source, t.subject_distance_mm, t.air.total_mm,
      t.water.total_mm, t.dof_ratio_water_to_air);
  f.body = fmt::format(
      "set logscale xy\nset format x \"%g\"\nset format y \"%g\"\nset xrange [{0}:{1}]\nset yrange [{0}:{2}]\n"
      "set xlabel \"subject distance from the entrance pupil (mm)\"\nset ylabel \"sharp from / to (mm)\"\n"
      "set key top left box opaque\nset style fill transparent solid 0.25 noborder\n"
      "set arrow from {3},{0} to {3},{2} nohead ls 5\n"
      "plot data index 0 using 1:2:3 with filledcurves lc rgb \"#c8322d\" title \"in air\", \\\n"
      "     data index 0 using 1:4:5 with filledcurves lc rgb \"#1f5fa8\" title \"under water\", \\\n"
      "     data index 0 using 1:2 with lines ls 2 notitle, data index 0 using 1:3 with lines ls 2 notitle, \\\n"
      "     data index 0 using 1:4 with lines ls 1 notitle, data index 0 using 1:5 with lines ls 1 notitle, \\\n"
      "     x with lines ls 5 title \"in focus\"\n",
      N(r.dof.front().subject_mm * 0.8), N(r.dof.back().subject_mm), N(r.dof.back().subject_mm * 4),
      N(t.subject_distance_mm));
  return f;
}

Figure FieldCurvature(const Results& r) {
  Figure f{"field-curvature", "dof", "Field curvature across the frame", "", 960, 520, "", ""};
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
  f.caption = t.field ? fmt::format(
      "A flat object plane at WD {:.0f} mm is imaged by the port onto a curved surface (Fig. 6): the "
      "virtual image of an off-axis point lies nearer the camera (sag, left axis). With the lens focused "
      "on the centre, the corners blur (right axis; the dashed line is the {:.1f} px circle of "
      "confusion): {:.1f} px at f/{:g}, within the circle of confusion from f/{:.1f}.",
      t.wd_mm, coc_px, t.field->corner_blur_px, r.plan.f_number, t.field->f_number_for_sharp_corners)
                        : std::string("The real rays failed: no field curvature for this system.");
  f.body = fmt::format(
      "set xlabel \"image height along the diagonal (mm)\"\nset ylabel \"sag of the virtual image (mm)\"\n"
      "set y2label \"defocus blur (px)\"\nset ytics nomirror\nset y2tics\nset key top left box opaque\n"
      "set y2range [0:*]\nset arrow from graph 0, second {0} to graph 1, second {0} nohead ls 5\n"
      "plot data index 0 using 1:5 with linespoints ls 3 pt 7 title \"sag toward the camera\", \\\n"
      "     data index 0 using 1:6 axes x1y2 with linespoints ls 2 pt 5 title \"defocus blur\", \\\n"
      "     data index 0 using 1:7 axes x1y2 with linespoints ls 4 pt 9 title \"bundle spread\"\n",
      N(coc_px));
  return f;
}

Figure DomeVsFlat(const Results& r) {
  const auto& main = r.plan.system;
  const auto& other = r.other_plan.system;
  Figure f{"dome-vs-flat", "ports", "Dome against flat port for the same lens", "", 1100, 500, "", ""};
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
      return Um(camera::RadialProfileMm(p.water.params, rad) - camera::RadialProfileMm(p.air.params, rad));
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
      r.plan.fov.air.diagonal_deg, r.prediction.water.params.c_mm / r.prediction.air.params.c_mm,
      main.spec.name, r.other_prediction.water.params.c_mm / r.other_prediction.air.params.c_mm, other.spec.name);
  f.body = fmt::format(
      "set multiplot layout 1,2\nset key top left box opaque\n"
      "set xlabel \"chief-ray angle in air (deg)\"\nset ylabel \"angle in water (deg)\"\n"
      "plot x with lines ls 5 title \"no port (air)\", \\\n"
      "     data index 0 using 1:2 with lines ls 1 title {0}, \\\n"
      "     data index 0 using 1:3 with lines ls 3 title {1}\n"
      "set xlabel \"radial distance r (mm, image)\"\nset ylabel \"δr change, water − air (µm)\"\n"
      "set key bottom left\n"
      "plot data index 1 using 1:2 with lines ls 1 title {0}, \\\n"
      "     data index 1 using 1:3 with lines ls 3 title {1}\n",
      GpText(main.spec.name), GpText(other.spec.name));  // names from port files: escaped

  return f;
}

Figure Predicted(const Results& r) {
  const simulate::Prediction& p = r.prediction;
  const bool calib = p.predicted_water.has_value();
  Figure f{"predicted", "simulate", "Predicted underwater calibration: distortion curves", "", 1100, 480, "", ""};
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
      "set multiplot layout 1,2\nset key bottom left box opaque\nset xlabel \"r (mm)\"\n"
      "set title \"(a) radial distortion\"\nset ylabel \"δr (µm)\"\n"
      "plot data index 0 using 1:2 with lines ls 2 title \"air (fit)\", \\\n"
      "     data index 0 using 1:3 with lines ls 1 title \"water (fit)\"{}\n"
      "set title \"(b) decentring distortion\"\nset ylabel \"P(r) (µm)\"\nset key top left\n"
      "plot data index 0 using 1:6 with lines ls 2 title \"air (fit)\", \\\n"
      "     data index 0 using 1:7 with lines ls 1 title \"water (fit)\"{}\n",
      extra_a, extra_b);
  return f;
}

Figure Tolerance(const Results& r) {
  Figure f{"tolerance", "simulate", "Tolerance to the entrance pupil's position", "", 1200, 450, "", ""};
  const camera::Sensor& s = r.prediction.camera.sensor;
  const double corner = Radii(s).back();
  auto dr = [](const simulate::SweepRow& row, double rad) {
    return Um(camera::RadialProfileMm(row.water.params, rad) - camera::RadialProfileMm(row.air.params, rad));
  };
  std::string& d = f.data;
  for (int k = 0; k < 2; ++k) {
    const auto& rows = k == 0 ? r.sweep_z : r.sweep_x;
    d += Block(k, k == 0 ? "pupil moved along z (toward the glass)" : "pupil moved along x",
               "offset_mm dc_mm c_ratio_water_air dr_change_5mm_um dr_change_10mm_um dr_change_corner_um");
    for (const auto& row : rows) {
      d += fmt::format("{} {} {} {} {} {}\n", N(row.offset_mm), N(row.water.params.c_mm - row.air.params.c_mm),
                       N(row.water.params.c_mm / row.air.params.c_mm), N(dr(row, 5)), N(dr(row, 10)),
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
      "set multiplot layout 1,3\nset key top left box opaque font \",9\"\nset xlabel \"pupil offset (mm)\"\n"
      "set title \"(a) principal distance\"\nset ylabel \"Δc (mm)\"\n"
      "plot data index 0 using 1:2 with linespoints ls 1 pt 7 title \"along z\", \\\n"
      "     data index 1 using 1:2 with linespoints ls 3 pt 5 title \"along x\"\n"
      "set title \"(b) radial profile change\"\nset ylabel \"δr water − air (µm)\"\nset xlabel \"pupil offset along z (mm)\"\n"
      "set key bottom left\n"
      "plot data index 0 using 1:4 with linespoints ls 3 pt 7 title \"r = 5 mm\", \\\n"
      "     data index 0 using 1:5 with linespoints ls 1 pt 5 title \"r = 10 mm\", \\\n"
      "     data index 0 using 1:6 with linespoints ls 2 pt 9 title \"corner, {:.1f} mm\"\n"
      "set title \"(c) profile against z offset\"\nset xlabel \"r (mm)\"\nset cblabel \"z offset (mm)\"\n"
      "set palette defined (0 \"#c8322d\", 1 \"#dddddd\", 2 \"#1f5fa8\")\nunset key\n"
      "plot data index 2 using 1:2:3 with lines lw 2 lc palette notitle\n",
      corner);
  return f;
}

Figure Maps(const Results& r) {
  Figure f{"maps", "simulate", "Predicted distortion maps", "", 1100, 820, "", ""};
  std::string& d = f.data;
  d += Block(0, "on the simulation's fit grid (rows separated by a blank line)",
             "x_mm y_mm water_um air_um difference_um residual_um (|correction vector|, µm)");
  double last_y = NAN;
  for (const auto& m : r.map) {
    if (std::isfinite(last_y) && m.y_mm != last_y) d += "\n";
    last_y = m.y_mm;
    d += fmt::format("{} {} {} {} {} {}\n", N(m.x_mm), N(m.y_mm), N(m.water_um.norm()), N(m.air_um.norm()),
                     N(m.difference_um.norm()), N(m.residual_um));
  }
  f.caption =
      "The length of the Brown correction vector over the image (the paper's Fig. 15), from the simulated "
      "calibrations: (a) under water, (b) in air, (c) their difference (water − air, vector), and (d) "
      "what no central model absorbs — the water fit's residual.";
  f.body = std::string(kMapSetup) + "set multiplot layout 2,2\n" +
           MapPanel("(a) under water", 0, 3) + MapPanel("(b) in air", 0, 4) +
           MapPanel("(c) difference water − air", 0, 5) + MapPanel("(d) residual of the water fit", 0, 6);
  return f;
}

Figure CompareCurves(const Results& r) {
  const calib::CompareResult& c = *r.compare;
  Figure f{"compare-curves", "compare", "Your calibrations: distortion curves (Fig. 14)", "", 1100, 480, "", ""};
  const auto& pw = r.prediction.predicted_water;
  std::string& d = f.data;
  d += Block(0, "radial and decentring profiles of the two calibrations and of the prediction",
             "r_mm dr_air_um dr_water_um P_air_um P_water_um dr_water_predicted_um P_water_predicted_um");
  for (const auto& p : c.curves) {
    d += fmt::format("{} {} {} {} {} {} {}\n", N(p.r_mm), N(p.radial_a_um), N(p.radial_b_um), N(p.decentring_a_um),
                     N(p.decentring_b_um), N(pw ? Um(camera::RadialProfileMm(*pw, p.r_mm)) : NAN),
                     N(pw ? Um(camera::DecentringProfileMm(*pw, p.r_mm)) : NAN));
  }
  f.caption =
      "Your in-air (red) and underwater (blue) calibrations as the paper's Fig. 14: (a) radial, "
      "(b) decentring distortion, µm against the radial distance in the image; dashed: the underwater "
      "calibration porthole predicted from the in-air one.";
  f.body =
      "set multiplot layout 1,2\nset key bottom left box opaque\nset xlabel \"r (mm)\"\n"
      "set title \"(a) radial distortion\"\nset ylabel \"δr (µm)\"\n"
      "plot data index 0 using 1:2 with lines ls 2 title \"air\", \\\n"
      "     data index 0 using 1:3 with lines ls 1 title \"water\", \\\n"
      "     data index 0 using 1:6 with lines ls 1 dt 2 title \"water, predicted\"\n"
      "set title \"(b) decentring distortion\"\nset ylabel \"P(r) (µm)\"\nset key top left\n"
      "plot data index 0 using 1:4 with lines ls 2 title \"air\", \\\n"
      "     data index 0 using 1:5 with lines ls 1 title \"water\", \\\n"
      "     data index 0 using 1:7 with lines ls 1 dt 2 title \"water, predicted\"\n";
  return f;
}

Figure CompareMaps(const Results& r) {
  const calib::CompareResult& c = *r.compare;
  Figure f{"compare-maps", "compare", "Your calibrations: distortion maps (Fig. 15)", "", 1200, 380, "", ""};
  std::string& d = f.data;
  d += Block(0, "over the frame (rows separated by a blank line)", "x_mm y_mm air_um water_um difference_um");
  double last_v = NAN;
  for (const auto& p : c.map) {
    if (std::isfinite(last_v) && p.v_px != last_v) d += "\n";
    last_v = p.v_px;
    d += fmt::format("{} {} {} {} {}\n", N(p.x_mm), N(p.y_mm), N(p.a_um.norm()), N(p.b_um.norm()),
                     N(p.diff_um.norm()));
  }
  f.caption = fmt::format(
      "The length of the correction vector over the image: (a) in air, (b) under water, (c) their "
      "difference (air − water, vector), as the paper's Fig. 15. Largest: {:.1f}, {:.1f} and {:.1f} µm.",
      c.max_a_um, c.max_b_um, c.max_diff_um);
  f.body = std::string(kMapSetup) + "set multiplot layout 1,3\n" + MapPanel("(a) in air", 0, 3) +
           MapPanel("(b) under water", 0, 4) + MapPanel("(c) difference", 0, 5);
  return f;
}

}  // namespace

std::vector<Figure> MakeFigures(const Results& r) {
  std::vector<Figure> out = {PortRays(r), VirtualImage(r), MinWd(r), DepthOfField(r), FieldCurvature(r),
                             DomeVsFlat(r), Predicted(r), Tolerance(r), Maps(r)};
  if (r.compare) {
    out.push_back(CompareCurves(r));
    out.push_back(CompareMaps(r));
  }
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
      "  set terminal pngcairo size {w},{h} enhanced font \"DejaVu Sans,10\" linewidth 1.2\n"
      "}} else {{\n"
      "  set terminal svg size {w},{h} dynamic enhanced font \"DejaVu Sans,10\" linewidth 1.2 background \"#ffffff\"\n"
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
