#include "porthole/planning/flat.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "porthole/core/error.h"
#include "porthole/camera/projection.h"
#include "porthole/materials/materials.h"
#include "porthole/housing/plausible.h"
#include "porthole/planning/thin_lens.h"

namespace porthole::planning {
namespace {

constexpr double kDeg = 180.0 / M_PI;

// The water index at `lambda_nm`: the environment's model there; a forced constant index keeps
// the model's dispersion, shifted to pass through the forced value at the design wavelength.
double WaterIndexAt(const ports::Environment& env, double lambda_nm) {
  materials::Conditions c = env.conditions;
  c.lambda_nm = lambda_nm;
  const double model = materials::Index(env.water, c);
  if (!env.water_index) return model;
  return *env.water_index + model - materials::Index(env.water, env.conditions);
}

// Image radius (mm) of an object at infinity in water direction `u` when the water index is n_w.
double ImageRadiusMm(ports::PortSystem sys, double n_w, const Vec3& u, const lens::LensSpec& lens, double c_mm) {
  sys.n_water = n_w;
  optics::Ray out;
  const optics::Ray in{sys.ep_in_housing_mm + 1e6 * u, -u};
  if (optics::TraceSequence<double>(sys.Inward(), in, &out) != optics::RayStatus::kOk) return std::nan("");
  const Vec3 d = -out.dir.normalized();
  return lens::ImageRadiusMm(lens, c_mm, std::atan2(std::hypot(d.x(), d.y()), d.z()));
}

}  // namespace

double FlatDistortionFactor(double theta_air_rad, double n_water) {
  const double s2 = std::sin(theta_air_rad) * std::sin(theta_air_rad);
  return std::sqrt((n_water * n_water - s2) / (1 - s2));
}

double TracedDistortionFactor(const ports::PortSystem& sys, double theta_air_rad) {
  if (theta_air_rad == 0) theta_air_rad = 1e-7;  // the paraxial limit (0/0 on the axis itself)
  const auto w = WaterDirection(sys, Vec3(std::sin(theta_air_rad), 0, std::cos(theta_air_rad)));
  if (!w) return std::nan("");
  return std::tan(theta_air_rad) / (std::hypot(w->x(), w->y()) / w->z());
}

FlatAnalysis AnalyseFlat(const Setup& setup, const FlatOptions& o) {
  housing::Validate(setup);
  if (!setup.port.IsFlat()) {
    throw InvalidInput("port", "'" + setup.port.name + "' is a " + std::string(setup.port.KindName()) + "; give a flat port");
  }
  if (std::isnan(o.wd_mm) || !(o.wd_mm > 0)) throw InvalidInput("wd_mm", "must be > 0 mm (or inf)");
  RequirePositive("step_deg", o.step_deg);
  RequirePositive("lambda_blue_nm", o.lambda_blue_nm);
  RequirePositive("lambda_red_nm", o.lambda_red_nm);
  const lens::Mount& mount = housing::MountOf(setup);
  const double f = setup.lens.focal_length_mm, pitch = setup.camera.sensor.pixel_pitch_mm;
  const Solved sol = SolveFocus(setup, mount, [&](const ports::PortSystem& sys) {
    return ports::ParaxialVirtualImage(sys, o.wd_mm).d_s2ep_mm;
  });
  const ports::PortSystem& sys = sol.sys;
  FlatAnalysis a;
  a.system = sys;
  a.n_water = sys.n_water;
  a.n_glass = sys.n_glass;
  a.principal_distance_mm = lens::PrincipalDistanceMm(f, sol.d_s2ep_mm);
  const double c = a.principal_distance_mm;
  a.apparent_focal_length_mm = a.n_water * c;
  a.focal_length_increase_pct = (a.n_water - 1) * 100;

  const FovPair traced = FieldOfView(sys, setup.camera, setup.lens, c);
  a.air = traced.air;
  a.water_traced = traced.water;
  auto thin = [&](double full_air_deg) {
    return 2 * std::asin(std::sin(0.5 * full_air_deg / kDeg) / a.n_water) * kDeg;
  };
  a.water_thin = {thin(a.air.horizontal_deg), thin(a.air.vertical_deg), thin(a.air.diagonal_deg)};
  a.critical_angle_deg = std::asin(1 / a.n_water) * kDeg;
  a.max_fov_deg = 2 * a.critical_angle_deg;

  // Coverage at WD along the horizontal edge rays: thin port with the pupil at the glass, and the
  // traced rays from the real outer surface to the object plane.
  a.wd_mm = o.wd_mm;
  const double half_w = 0.5 * setup.camera.SensorWidthMm();
  a.coverage_thin_mm = 2 * o.wd_mm * std::tan(0.5 * a.water_thin.horizontal_deg / kDeg);
  optics::Ray out;
  const optics::Ray edge{sys.ep_in_housing_mm, housing::ChiefRay(setup.lens, c, half_w, 0).value_or(Vec3(1, 0, 0))};
  if (std::isinf(o.wd_mm)) {
    a.coverage_traced_mm = o.wd_mm;
  } else if (optics::TraceSequence<double>(sys.Outward(), edge, &out) == optics::RayStatus::kOk) {
    const double z = sys.OuterVertexZ() + o.wd_mm;
    const Vec3 p = out.origin + ((z - out.origin.z()) / out.dir.z()) * out.dir;
    a.coverage_traced_mm = 2 * (p.x() - sys.ep_in_housing_mm.x());
  } else {
    a.coverage_traced_mm = std::nan("");
  }

  // Lateral colour: an object at infinity seen at θ_a at the design wavelength, imaged at the blue
  // and the red wavelengths.
  a.n_water_blue = WaterIndexAt(setup.env, o.lambda_blue_nm);
  a.n_water_red = WaterIndexAt(setup.env, o.lambda_red_nm);
  auto colour_px = [&](const Vec3& air_dir) {
    const auto u = WaterDirection(sys, air_dir);
    if (!u) return std::nan("");
    return (ImageRadiusMm(sys, a.n_water_blue, *u, setup.lens, c) -
            ImageRadiusMm(sys, a.n_water_red, *u, setup.lens, c)) / pitch;
  };
  const double half_h = 0.5 * setup.camera.SensorHeightMm();
  const auto corner_ray = housing::ChiefRay(setup.lens, c, half_w, half_h);
  a.lateral_colour_corner_px = corner_ray ? colour_px(*corner_ray) : std::nan("");

  // Rows to the frame corner, or to 90° off axis for a fisheye that sees further (no ray beyond
  // meets a flat port).
  const double corner_deg =
      std::min(89.9, lens::FieldAngleRad(setup.lens, c, std::hypot(half_w, half_h)).value_or(M_PI / 2) * kDeg);
  for (double t = 0;; t = std::min(t + o.step_deg, corner_deg)) {
    FlatRow r;
    const double ta = t / kDeg;
    r.theta_air_deg = t;
    r.distortion_factor = FlatDistortionFactor(ta, a.n_water);
    r.distortion_factor_traced = TracedDistortionFactor(sys, ta);
    r.theta_water_deg = std::asin(std::sin(ta) / a.n_water) * kDeg;
    // The image radius against the same projection with the apparent focal length n_w c in water
    // (for a rectilinear lens: c tan θ_a against n_w c tan θ_w).
    r.image_radius_mm = lens::ImageRadiusMm(setup.lens, c, ta);
    r.distortion_px =
        (r.image_radius_mm - lens::ImageRadiusMm(setup.lens, a.apparent_focal_length_mm, r.theta_water_deg / kDeg)) /
        pitch;
    r.lateral_colour_px = colour_px(Vec3(std::sin(ta), 0, std::cos(ta)));
    a.rows.push_back(r);
    if (t >= corner_deg) break;
  }

  // The aperture the corner rays need: where they leave the outer face, from the pupil's axis.
  a.corner_outer_radius_mm = 0;
  for (const auto& [sx, sy] : std::array<std::pair<double, double>, 4>{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}}) {
    const auto dir = housing::ChiefRay(setup.lens, c, sx * half_w, sy * half_h);
    const double r = dir && optics::TraceSequence<double>(sys.Outward(), {sys.ep_in_housing_mm, *dir}, &out) ==
                                optics::RayStatus::kOk
                         ? (out.origin - sys.ep_in_housing_mm).head<2>().norm()
                         : std::nan("");
    a.corner_outer_radius_mm = std::isnan(r) ? r : std::max(a.corner_outer_radius_mm, r);
    if (std::isnan(r)) break;
  }
  a.clear_aperture_needed_mm = 2 * a.corner_outer_radius_mm;

  // Values outside what physical cameras and ports have (a unit typed wrong) come first.
  a.warnings = housing::PlausibilityWarnings(setup);
  // A fisheye sees beyond 90 deg: those rays never meet a flat port.
  a.field_cut = FieldCutByPort(sys, setup.camera, setup.lens, c);
  if (a.field_cut.blocked_fraction > 0) {
    a.warnings.push_back(fmt::format(
        "The flat port cuts off {} of the frame ({:.1f} % of its area): the {} sees beyond {:.1f} deg off axis, and no "
        "ray at 90 deg or more meets a flat port; the rest of the field reaches only {:.1f} deg into the water, the "
        "critical angle ({:.1f} deg) being the limit.",
        a.field_cut.what, 100 * a.field_cut.blocked_fraction, setup.lens.name, a.field_cut.clear_angle_deg,
        a.field_cut.clear_water_angle_deg, a.critical_angle_deg));
  }
  // What limits the field: not total reflection of the camera's rays (light going from air into
  // water is never totally reflected) but, for light coming in from the water, the critical angle
  // at the glass-air face, and the port's aperture.
  if (a.air.diagonal_deg > 0.9 * a.max_fov_deg) {
    a.warnings.push_back(fmt::format(
        "The lens sees {:.1f} deg across the diagonal in air; through a flat port it sees {:.1f} deg of the water. "
        "No flat port shows more than {:.1f} deg: water light steeper than the critical angle ({:.1f} deg to the "
        "port's normal) is totally reflected on its way into the housing, so the frame's edges are compressed "
        "(distortion factor {:.2f} at the corner against {:.3f} at the centre).{}",
        a.air.diagonal_deg, a.water_traced.diagonal_deg, a.max_fov_deg, a.critical_angle_deg,
        FlatDistortionFactor(std::min(0.5 * a.air.diagonal_deg, 89.9) / kDeg, a.n_water), a.n_water,
        camera::IsFisheye(setup.lens.projection) ? " The fisheye's field is cut at the critical angle: a dome keeps it." : ""));
  }
  if (!std::isnan(a.clear_aperture_needed_mm)) {
    a.warnings.push_back(fmt::format("The corner rays leave the port {:.1f} mm from the axis: its clear aperture must "
                                     "be at least {:.0f} mm across, or the corners see the port's rim.",
                                     a.corner_outer_radius_mm, a.clear_aperture_needed_mm));
  }
  a.warnings.push_back(fmt::format("Behind this flat port the lens behaves as a {:.1f} mm lens (x{:.3f}): the field "
                                   "of view narrows from {:.1f} to {:.1f} deg across the diagonal.",
                                   a.apparent_focal_length_mm, a.n_water, a.air.diagonal_deg,
                                   a.water_traced.diagonal_deg));
  if (std::abs(a.lateral_colour_corner_px) > 1) {
    a.warnings.push_back(fmt::format("Lateral colour: blue and red images of a corner point lie {:.1f} px apart; "
                                     "a dome port centred on the pupil avoids it.",
                                     std::abs(a.lateral_colour_corner_px)));
  }
  return a;
}

}  // namespace porthole::planning
