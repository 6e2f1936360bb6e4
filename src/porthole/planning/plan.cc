#include "porthole/planning/plan.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include "porthole/core/error.h"
#include "porthole/camera/projection.h"
#include "porthole/housing/plausible.h"
#include "porthole/planning/thin_lens.h"

namespace porthole::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = 180.0 / M_PI;

double VirtualD(const ports::PortSystem& sys, double wd_mm) {
  return ports::ParaxialVirtualImage(sys, wd_mm).d_s2ep_mm;
}

// The real subject distance (from the pupil) of a virtual-image distance.
double RealFromVirtual(const ports::PortSystem& sys, double d_virtual, double* wd_out) {
  const double wd = WdForVirtualImage(sys, d_virtual);
  if (wd_out) *wd_out = wd;
  return wd + PupilToOuterMm(sys);
}

// The full angle between two rays on either side of the axis, measured through the axis: the
// angle between them, or its reflex when together they lie more than 180° from the axis (a
// fisheye's opposite edges beyond 90°). NaN when a ray is missing.
double AngleDeg(const std::optional<Vec3>& a, const std::optional<Vec3>& b) {
  if (!a || !b) return std::nan("");
  const double between = std::acos(std::clamp(a->dot(*b), -1.0, 1.0)) * kDeg;
  const double from_axis = (std::acos(std::clamp(a->z(), -1.0, 1.0)) + std::acos(std::clamp(b->z(), -1.0, 1.0))) * kDeg;
  return from_axis > 180 ? 360 - between : between;
}

// The chief ray to image point (x, y) in the water, nullopt when it does not pass the port.
std::optional<Vec3> WaterRay(const ports::PortSystem& sys, const lens::LensSpec& lens, double c_mm, double x,
                             double y) {
  const auto air = housing::ChiefRay(lens, c_mm, x, y);
  if (!air) return std::nullopt;
  return WaterDirection(sys, *air);
}

FieldCurvature TraceFieldCurvature(const ports::PortSystem& sys, const lens::CameraBody& cam,
                                   const lens::LensSpec& lens, double n, double coc_mm, double c_mm, double wd_mm,
                                   int samples) {
  const double f_mm = lens.focal_length_mm;
  const bool fisheye = camera::IsFisheye(lens.projection);
  FieldCurvature fc;
  fc.aperture_height_mm = f_mm / (2 * n);
  const Vec3& ep = sys.ep_in_housing_mm;
  const double z_object = sys.OuterVertexZ() + wd_mm;
  const double object_radius = z_object - ep.z();  // a fisheye's object sphere about the pupil
  const double pitch = cam.sensor.pixel_pitch_mm;
  const double half_w = 0.5 * cam.SensorWidthMm(), half_h = 0.5 * cam.SensorHeightMm();
  // The virtual image of the object point seen along the chief ray to image point (x, y) (image
  // mm, y up; camera Y is down); nullopt when a ray fails.
  auto image_of = [&](double x, double y, double* object_height) -> std::optional<ports::VirtualPoint> {
    const auto chief = housing::ChiefRay(lens, c_mm, x, y);
    if (!chief) return std::nullopt;
    optics::Ray out;
    const optics::Ray in{ep, *chief};
    if (optics::TraceSequence<double>(sys.Outward(), in, &out) != optics::RayStatus::kOk) return std::nullopt;
    Vec3 p;
    if (fisheye) {  // where the water ray meets the sphere |p − ep| = object_radius
      const Vec3 o = out.origin - ep, d = out.dir.normalized();
      const double b = o.dot(d), disc = b * b - (o.squaredNorm() - object_radius * object_radius);
      if (!(disc >= 0)) return std::nullopt;
      p = out.origin + (-b + std::sqrt(disc)) * d;
    } else {
      if (!(out.dir.z() > 0)) return std::nullopt;
      p = out.origin + ((z_object - out.origin.z()) / out.dir.z()) * out.dir;
    }
    if (object_height) *object_height = (p - Vec3(ep.x(), ep.y(), p.z())).norm();
    // The pupil faces the chief ray (a fisheye's pupil turns with the field); an ordinary lens's
    // is the plane normal to the axis.
    return ports::RealRayVirtualPoint(sys, ports::ObjectPoint::At(p), fc.aperture_height_mm,
                                      fisheye ? *chief : Vec3(0, 0, 1));
  };
  // The distance of a virtual point from the pupil: axial, or along the chief ray for a fisheye.
  auto distance = [&](const ports::VirtualPoint& v) {
    return fisheye ? (v.position_mm - ep).norm() : v.position_mm.z() - ep.z();
  };
  const auto centre = image_of(0, 0, nullptr);
  if (!centre) return fc;
  const double s = distance(*centre);  // the lens is focused on the axial image
  auto blur_px = [&](double d) { return BlurDiameterMm(s, d, f_mm, n) / pitch; };
  auto spread_px = [&](const ports::VirtualPoint& v, double d) { return 2 * v.rms_spread_mm * c_mm / d / pitch; };
  for (int k = 0; k < samples; ++k) {
    const double t = samples > 1 ? static_cast<double>(k) / (samples - 1) : 1.0;
    FieldRow row;
    const double x = t * half_w, y = t * half_h;
    row.image_height_mm = std::hypot(x, y);
    row.field_angle_deg = lens::FieldAngleRad(lens, c_mm, row.image_height_mm).value_or(std::nan("")) * kDeg;
    const auto v = image_of(x, y, &row.object_height_mm);
    if (!v) {  // beyond the port's rim (a fisheye's corners): the row says so with NaN
      if (k == 0) return fc;
      row.object_height_mm = row.d_s2ep_mm = row.sag_mm = row.blur_px = row.spread_px = std::nan("");
      fc.rows.push_back(row);
      continue;
    }
    row.d_s2ep_mm = distance(*v);
    row.sag_mm = s - row.d_s2ep_mm;
    row.blur_px = blur_px(row.d_s2ep_mm);
    row.spread_px = spread_px(*v, row.d_s2ep_mm);
    fc.rows.push_back(row);
  }
  // The four corners (a decentred port is not symmetric).
  for (const auto& [sx, sy] : std::array<std::pair<double, double>, 4>{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}}) {
    const auto v = image_of(sx * half_w, sy * half_h, nullptr);
    if (!v) continue;
    fc.corner_blur_px = std::max(fc.corner_blur_px, blur_px(distance(*v)));
  }
  // Defocus blur scales as 1/N (BlurDiameterMm).
  // When the port's rim hides the corners, the sharpest need is set by the last field row it passes.
  if (fc.corner_blur_px == 0) {
    for (const FieldRow& r : fc.rows) {
      if (!std::isnan(r.blur_px)) fc.corner_blur_px = std::max(fc.corner_blur_px, r.blur_px);
    }
  }
  fc.f_number_for_sharp_corners = n * fc.corner_blur_px * pitch / coc_mm;
  return fc;
}

// The sag of the outermost field row the port passes (NaN rows lie beyond its rim).
double LastClearSag(const FieldCurvature& fc) {
  for (auto it = fc.rows.rbegin(); it != fc.rows.rend(); ++it) {
    if (!std::isnan(it->sag_mm)) return it->sag_mm;
  }
  return std::nan("");
}

}  // namespace

FovPair FieldOfView(const ports::PortSystem& sys, const lens::CameraBody& cam, const lens::LensSpec& lens,
                    double c_mm) {
  const double hw = 0.5 * cam.SensorWidthMm(), hh = 0.5 * cam.SensorHeightMm();
  auto pair = [&](double x, double y) {
    return std::pair{AngleDeg(housing::ChiefRay(lens, c_mm, x, y), housing::ChiefRay(lens, c_mm, -x, -y)),
                     AngleDeg(WaterRay(sys, lens, c_mm, x, y), WaterRay(sys, lens, c_mm, -x, -y))};
  };
  const auto [ha, hw_] = pair(hw, 0);
  const auto [va, vw] = pair(0, hh);
  const auto [da, dw] = pair(hw, hh);
  return {{ha, va, da}, {hw_, vw, dw}};
}

FieldCut FieldCutByPort(const ports::PortSystem& sys, const lens::CameraBody& cam, const lens::LensSpec& lens,
                        double c_mm) {
  const double hw = 0.5 * cam.SensorWidthMm(), hh = 0.5 * cam.SensorHeightMm();
  auto passes = [&](double x, double y) { return WaterRay(sys, lens, c_mm, x, y).has_value(); };
  FieldCut cut;
  constexpr int kCols = 64, kRows = 43;  // about the frame's 3:2
  int blocked = 0;
  for (int j = 0; j < kRows; ++j) {
    for (int i = 0; i < kCols; ++i) {
      // Cell centres, so that each stands for an equal area.
      blocked += !passes(hw * ((2 * i + 1.0) / kCols - 1), hh * ((2 * j + 1.0) / kRows - 1));
    }
  }
  cut.blocked_fraction = static_cast<double>(blocked) / (kCols * kRows);
  // Along each half diagonal: the last passing radius (bisection; the blocked part is outside).
  const double half_diag = std::hypot(hw, hh);
  cut.clear_radius_mm = half_diag;
  for (const auto& corner : std::array<std::pair<double, double>, 4>{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}}) {
    // (a structured binding cannot be captured by a lambda in clang 14, which builds `make fuzz`)
    const double sx = corner.first, sy = corner.second;
    auto at = [&](double r) { return passes(sx * hw * r / half_diag, sy * hh * r / half_diag); };
    if (at(half_diag)) continue;
    double lo = 0, hi = half_diag;
    for (int it = 0; it < 60; ++it) (at(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
    cut.clear_radius_mm = std::min(cut.clear_radius_mm, lo);
  }
  cut.clear_angle_deg = lens::FieldAngleRad(lens, c_mm, cut.clear_radius_mm).value_or(std::nan("")) * kDeg;
  double water = 0;
  for (const auto& [sx, sy] : std::array<std::pair<double, double>, 4>{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}}) {
    const double r = cut.clear_radius_mm / half_diag;
    const auto w = WaterRay(sys, lens, c_mm, sx * hw * r, sy * hh * r);
    if (w) water = std::max(water, std::acos(std::clamp(w->z(), -1.0, 1.0)) * kDeg);
  }
  cut.clear_water_angle_deg = water;
  if (cut.clear_radius_mm >= half_diag) {
    cut.what = "nothing";
  } else if (cut.clear_radius_mm >= hw) {
    cut.what = "the corners";
  } else if (cut.clear_radius_mm >= hh) {
    cut.what = "the corners and the left and right edges";
  } else {
    cut.what = "the whole frame edge";
  }
  return cut;
}

double WdForVirtualImage(const ports::PortSystem& sys, double d) {
  if (std::isnan(d)) return d;
  if (d >= VirtualD(sys, kInf)) return kInf;
  double lo = 1e-9, hi = 1.0;
  if (d <= VirtualD(sys, lo)) return 0;
  while (VirtualD(sys, hi) < d) hi *= 2;  // terminates: d is below the image of infinity
  for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (VirtualD(sys, mid) < d ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Plan MakePlan(const Setup& setup, const PlanOptions& o) {
  housing::Validate(setup);
  const lens::Mount& mount = housing::MountOf(setup);
  const lens::LensSpec& ln = setup.lens;
  const double f = ln.focal_length_mm;
  const double pitch = setup.camera.sensor.pixel_pitch_mm;
  if (o.wd_mm && o.subject_distance_mm) throw InvalidInput("wd_mm", "give wd_mm or subject_distance_mm, not both");
  RequireFinite("f_number", o.f_number);
  if (o.f_number < ln.f_number_min * (1 - 1e-9) || o.f_number > ln.f_number_max * (1 + 1e-9)) {
    throw InvalidInput("f_number", fmt::format("f/{:g} is outside the {} range f/{:g} to f/{:g}", o.f_number,
                                                 ln.name, ln.f_number_min, ln.f_number_max));
  }
  Plan plan;
  plan.f_number = o.f_number;
  if (o.coc_mm) {
    plan.coc_mm = RequirePositive("coc_mm", *o.coc_mm);
    plan.coc_source = "given";
  } else {
    plan.coc_mm = PlanOptions::kCocPixels * pitch;
    plan.coc_source = fmt::format("{:g} pixel pitches ({:g} um pixels)", PlanOptions::kCocPixels, pitch * 1000);
  }
  const double n = o.f_number, coc = plan.coc_mm;
  if (o.field_samples < 1) throw InvalidInput("field_samples", "must be >= 1");

  // The lens's reach: its closest subject (Eq. 2 at the minimum focus), the minimum WD.
  const ports::PortSystem at_min = SystemAtFocus(setup, ln.min_focus_mm);
  const ports::PortSystem at_inf = SystemAtFocus(setup, kInf);
  plan.closest_d_s2ep_mm = lens::SubjectToPupilMm(ln, mount, ln.min_focus_mm);
  // The virtual image of infinity with the lens focused on it (the pupil where that focus puts it):
  // one definition for plan, report and Python (the report's Table 5 row WD = inf solves the same).
  const Solved on_inf = SolveFocus(setup, mount, [](const ports::PortSystem& sys) { return VirtualD(sys, kInf); });
  plan.d_s2ep_infinity_mm = VirtualD(on_inf.sys, kInf);
  plan.infinity_image_focus_distance_mm = on_inf.fd_mm;
  plan.min_wd_mm = WdForVirtualImage(at_min, plan.closest_d_s2ep_mm);
  plan.d_s2ep_touching_mm = VirtualD(at_min, 1e-9);  // the limit WD → 0 (the paraxial trace needs WD > 0)
  plan.lens_covers_virtual_range = plan.closest_d_s2ep_mm <= plan.d_s2ep_touching_mm;
  plan.pupil_to_outer_mm = PupilToOuterMm(at_min);
  for (double p : o.closeup_dioptres) {
    const double lo = ApparentDistanceWithCloseupMm(plan.closest_d_s2ep_mm, -p);  // 1/d = 1/d' + P
    const double hi = p > 0 ? 1000.0 / p : kInf;
    plan.closeup.push_back(
        {p, WdForVirtualImage(at_min, lo), WdForVirtualImage(at_inf, hi), !plan.lens_covers_virtual_range});
  }

  // Infinity sharp: in air the hyperfocal distance; under water the focus whose far limit is the
  // virtual image of infinity.
  InfinityFocus& inf = plan.infinity;
  inf.air_focus_mm = FocusForFarLimitMm(kInf, f, n, coc);
  inf.air_near_mm = ThinLensDof(inf.air_focus_mm, f, n, coc).near_mm;
  inf.air_focus_distance_mm = lens::FocusForSubjectMm(ln, mount, inf.air_focus_mm);
  // The focus the plan is for: the target's virtual image, or else the infinity focus.
  std::function<double(const ports::PortSystem&)> plan_focus = [&](const ports::PortSystem& sys) {
    return FocusForFarLimitMm(VirtualD(sys, kInf), f, n, coc);
  };
  const Solved hyper = SolveFocus(setup, mount, plan_focus);
  inf.water_virtual_focus_mm = hyper.d_s2ep_mm;
  inf.water_virtual_near_mm = ThinLensDof(hyper.d_s2ep_mm, f, n, coc).near_mm;
  inf.water_near_mm = RealFromVirtual(hyper.sys, inf.water_virtual_near_mm, &inf.water_near_wd_mm);
  inf.water_focus_distance_mm = hyper.fd_mm;
  plan.system = hyper.sys;
  plan.principal_distance_mm = f;  // lens at infinity when there is no target

  if (o.wd_mm || o.subject_distance_mm) {
    if (o.wd_mm && !(RequireFinite("wd_mm", *o.wd_mm) > 0)) {
      throw InvalidInput("wd_mm", "must be > 0 mm: WD is measured from the port's outer surface, so this "
                                 "object would be inside the port");
    }
    if (o.subject_distance_mm) {
      RequireFinite("subject_distance_mm", *o.subject_distance_mm);
      if (!(*o.subject_distance_mm > PupilToOuterMm(at_inf) && *o.subject_distance_mm > PupilToOuterMm(at_min))) {
        throw InvalidInput("subject_distance_mm",
                           fmt::format("{:g} mm from the entrance pupil is inside the port (its outer surface "
                                       "is {:.1f} mm from the pupil)",
                                       *o.subject_distance_mm, PupilToOuterMm(at_inf)));
      }
    }
    auto wd_of = [&](const ports::PortSystem& sys) {
      return o.wd_mm ? *o.wd_mm : *o.subject_distance_mm - PupilToOuterMm(sys);
    };
    plan_focus = [&, wd_of](const ports::PortSystem& sys) { return VirtualD(sys, wd_of(sys)); };
    const housing::Focused sol = housing::SolveFocus(setup, plan_focus);
    TargetPlan t;
    const ports::PortSystem& sys = sol.sys;
    t.wd_mm = wd_of(sys);
    t.subject_distance_mm = t.wd_mm + PupilToOuterMm(sys);
    t.virtual_image = ports::ParaxialVirtualImage(sys, t.wd_mm);
    const auto real = ports::RealRayVirtualImage(sys, t.wd_mm, f / (2 * n));
    t.d_s2ep_real_mm = real ? real->d_s2ep_mm : std::nan("");
    const double dv = t.virtual_image.d_s2ep_mm;
    t.focus = sol.focus;
    t.focus.closeup_dioptre = CloseupDioptreNeeded(dv, plan.closest_d_s2ep_mm);
    t.principal_distance_mm = lens::PrincipalDistanceMm(f, dv);

    // In air: the same subject distance from the pupil.
    const DofLimits air = ThinLensDof(t.subject_distance_mm, f, n, coc);
    t.air = {t.subject_distance_mm, air.near_mm, air.far_mm, air.far_mm - air.near_mm,
             lens::FocusForSubjectMm(ln, mount, t.subject_distance_mm)};
    // Under water: the limits around the virtual image, mapped back through the port.
    const DofLimits wv = ThinLensDof(dv, f, n, coc);
    DofWater& w = t.water;
    w.virtual_focus_mm = dv;
    w.virtual_near_mm = wv.near_mm;
    w.virtual_far_mm = wv.far_mm;
    w.virtual_total_mm = wv.far_mm - wv.near_mm;
    w.focus_mm = t.subject_distance_mm;
    w.near_mm = RealFromVirtual(sys, wv.near_mm, &w.near_wd_mm);
    w.far_mm = RealFromVirtual(sys, wv.far_mm, &w.far_wd_mm);
    w.total_mm = w.far_mm - w.near_mm;
    // Not applicable (NaN) when either total is unlimited: inf/x gave 0, inf/inf NaN printed as "x-".
    t.dof_ratio_water_to_air =
        std::isfinite(w.total_mm) && std::isfinite(t.air.total_mm) ? w.total_mm / t.air.total_mm : NAN;

    // One pixel on the object: at the virtual image, divided by the port's lateral magnification.
    t.gsd_water_mm = pitch * dv / t.principal_distance_mm / t.virtual_image.magnification;
    t.gsd_air_mm = pitch * t.subject_distance_mm / lens::PrincipalDistanceMm(f, t.subject_distance_mm);
    const FieldCurvature fc = TraceFieldCurvature(sys, setup.camera, ln, n, coc, t.principal_distance_mm,
                                                  t.wd_mm, o.field_samples);
    if (!fc.rows.empty() && static_cast<int>(fc.rows.size()) == o.field_samples) t.field = fc;
    plan.system = sys;
    plan.principal_distance_mm = t.principal_distance_mm;
    plan.target = t;
  }
  plan.fov = FieldOfView(plan.system, setup.camera, ln, plan.principal_distance_mm);
  plan.field_cut = FieldCutByPort(plan.system, setup.camera, ln, plan.principal_distance_mm);
  plan.centring = CentrePupil(setup, mount, plan_focus);

  // Values outside what physical cameras and ports have (a unit typed wrong), then plain-language
  // warnings, the paper's advice (Sections 2.3, 3.1, 4 and 6).
  auto& warn = plan.warnings;
  warn = housing::PlausibilityWarnings(setup);
  if (o.coc_mm) housing::AddPlausibilityWarning(&warn, "coc_mm", *o.coc_mm, kCocRange);
  // A curved port (a dome; a cylinder across its axis: ports::PortSpec::IsCurved) images infinity
  // at a finite distance.
  const bool curved = plan.system.spec.IsCurved();
  const std::string kind(plan.system.spec.KindName());
  if (ln.min_focus_assumed) {
    warn.push_back(fmt::format("The minimum focus of the {} is assumed, {:g} mm (not known): the minimum working "
                               "distance and the close-up lens advice depend on it. Give the published value "
                               "(`min_focus_mm`).",
                               ln.name, ln.min_focus_mm));
  }
  if (ln.pupil_estimated) {
    warn.push_back(fmt::format("The entrance pupil of the {} is assumed (estimated, not measured: {}): distances from "
                               "the pupil and the extension ring advice may be off by 10 mm or more. Measure it as in "
                               "the paper's Section 3.1 and give it (`pupil_mm`).",
                               ln.name, ln.description));
  }
  if (ln.projection_estimated) {
    warn.push_back(fmt::format("The {} is taken as a {} fisheye, an estimate ({}): the field of view may differ.",
                               ln.name, camera::ProjectionName(ln.projection), ln.description));
  }
  if (plan.field_cut.blocked_fraction > 0) {
    warn.push_back(fmt::format("The {} cuts off {} of the frame ({:.1f} % of its area): chief rays beyond {:.1f} deg "
                               "off axis ({:.2f} mm from the image centre along the diagonal) do not reach the water, "
                               "so that part of the image is vignetted: it sees the {} whatever the distance.",
                               curved ? kind + "'s rim" : "port's edge", plan.field_cut.what,
                               100 * plan.field_cut.blocked_fraction, plan.field_cut.clear_angle_deg,
                               plan.field_cut.clear_radius_mm, curved ? "rim and the housing" : "housing"));
  }
  if (curved) {
    // Focus scale at infinity: its near limit against the image of infinity seen from that pupil.
    const double near_at_inf = ThinLensDof(kInf, f, n, coc).near_mm;
    std::string what = near_at_inf > VirtualD(at_inf, kInf)
                           ? "nothing in the water is then sharp"
                           : fmt::format("only objects beyond WD {:.0f} mm are then sharp",
                                         WdForVirtualImage(plan.system, near_at_inf));
    warn.push_back(fmt::format("Do not set the focus to infinity: behind this {} even infinity is imaged "
                               "{:.1f} mm from the entrance pupil; at f/{:g} {}.",
                               kind, plan.d_s2ep_infinity_mm, n, what));
  }
  if (plan.lens_covers_virtual_range) {
    warn.push_back(fmt::format("The {} focuses on the whole virtual-image range behind this port, from the image of "
                               "an object touching the glass ({:.1f} mm from the pupil) to that of infinity ({:.1f} "
                               "mm); its own closest subject is {:.1f} mm. The closest working distance is set by "
                               "the port, not the lens: the subject touching the glass (WD 0, {:.1f} mm from the "
                               "pupil). No close-up lens is needed.",
                               ln.name, plan.d_s2ep_touching_mm, plan.d_s2ep_infinity_mm, plan.closest_d_s2ep_mm,
                               plan.pupil_to_outer_mm));
  }
  if (plan.closest_d_s2ep_mm >= plan.d_s2ep_infinity_mm) {
    warn.push_back(fmt::format("The {} cannot focus on anything behind this port: its closest focus is {:.1f} "
                               "mm from the pupil, the virtual image of infinity {:.1f} mm. Add a close-up lens "
                               "of at least +{:.2f} dioptres.",
                               ln.name, plan.closest_d_s2ep_mm, plan.d_s2ep_infinity_mm,
                               CloseupDioptreNeeded(plan.d_s2ep_infinity_mm, plan.closest_d_s2ep_mm)));
  }
  if (plan.target) {
    const TargetPlan& t = *plan.target;
    if (!t.focus.focus_distance_mm) {
      warn.push_back(fmt::format("The {} cannot focus on the virtual image at {:.1f} mm (its closest is {:.1f} "
                                 "mm): {}add a close-up lens of at least +{:.2f} dioptres.",
                                 ln.name, t.focus.d_s2ep_mm, plan.closest_d_s2ep_mm,
                                 // No WD is in reach when even infinity is imaged too close.
                                 std::isfinite(plan.min_wd_mm)
                                     ? fmt::format("move back to WD >= {:.0f} mm or ", plan.min_wd_mm)
                                     : std::string(),
                                 t.focus.closeup_dioptre));
    } else if (t.air.focus_distance_mm) {
      warn.push_back(fmt::format("Do not pre-focus in air: on a subject {:.0f} mm away the focus scale would be "
                                 "set to {:.0f} mm; under water it must be {:.0f} mm.",
                                 t.subject_distance_mm, *t.air.focus_distance_mm, *t.focus.focus_distance_mm));
    }
    if (t.field && t.field->corner_blur_px * pitch > coc) {
      const double nf = t.field->f_number_for_sharp_corners;
      warn.push_back(fmt::format("The corners are soft: the port's field curvature puts their image {:.1f} mm "
                                 "nearer, a {:.1f} px blur at f/{:g}; {}.",
                                 LastClearSag(*t.field), t.field->corner_blur_px, n,
                                 nf <= ln.f_number_max ? fmt::format("f/{:.1f} brings them within the circle of "
                                                                     "confusion", nf)
                                                       : fmt::format("even f/{:g} does not fix it", ln.f_number_max)));
    }
  }
  const double airy_mm = 2.44 * o.lambda_nm * 1e-6 * n;
  if (airy_mm > coc) {
    warn.push_back(fmt::format("At f/{:g} diffraction alone blurs a point over {:.1f} um (Airy disc 2.44 lambda N), "
                               "more than the {:.1f} um circle of confusion: stopping down for depth of field "
                               "now costs sharpness.",
                               n, airy_mm * 1000, coc * 1000));
  }
  if (!curved) {
    warn.push_back("A flat port narrows the field of view and adds pincushion distortion and lateral colour: "
                   "see 'porthole flat'.");
  }
  // A fixed-focus lens has no focus to set: planning's advice about the focus scale or pre-focusing
  // in air does not apply to it (the CLI and Python both get the plan without it).
  if (ln.fixed_focus) {
    std::erase_if(plan.warnings, [](const std::string& w) {
      return w.find("focus scale") != std::string::npos || w.find("pre-focus") != std::string::npos;
    });
  }
  return plan;
}

}  // namespace porthole::planning
