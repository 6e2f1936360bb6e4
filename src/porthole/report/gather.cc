// Gathering the report's numbers: every value comes from a library function (planning, simulate,
// calib, ports); this file only chooses what to evaluate where.
#include <chrono>
#include <cmath>
#include <future>
#include <limits>

#include <fmt/format.h>

#include "porthole/core/error.h"
#include "porthole/housing/housed.h"
#include "porthole/catalogue/presets.h"
#include "porthole/planning/thin_lens.h"
#include "porthole/report/internal.h"

namespace porthole::report {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = 180.0 / M_PI;

// The paper's Table 5 working distances, mm.
const std::vector<double> kTable5Wd = {200, 300, 400, 500, 750, 1000, 3000, 5000, 10000, kInf};

planning::PlanOptions PlanFor(const ReportInputs& in, double subject_mm, int field_samples) {
  planning::PlanOptions po;
  po.subject_distance_mm = subject_mm;
  po.f_number = in.f_number;
  po.coc_mm = in.coc_mm;
  po.field_samples = field_samples;
  po.lambda_nm = in.setup.env.conditions.lambda_nm;
  return po;
}

// The virtual image of an object at wd_mm and the focus that makes it sharp, with the pupil moved
// to where that focus puts it.
VirtualRow VirtualAt(const planning::Setup& s, const lens::Mount& mount, double wd_mm,
                     double aperture_height_mm) {
  const auto solved = planning::SolveFocus(
      s, mount, [wd_mm](const ports::PortSystem& sys) { return ports::ParaxialVirtualImage(sys, wd_mm).d_s2ep_mm; });
  const ports::VirtualImage vi = ports::ParaxialVirtualImage(solved.sys, wd_mm);
  VirtualRow row;
  row.wd_mm = wd_mm;
  row.d_s2ep_mm = vi.d_s2ep_mm;
  row.vwd_mm = vi.vwd_mm;
  row.magnification = vi.magnification;
  if (const auto real = ports::RealRayVirtualImage(solved.sys, wd_mm, aperture_height_mm)) {
    row.d_s2ep_real_mm = real->d_s2ep_mm;
  }
  row.fd_mm = solved.fd_mm;
  row.ep_z_mm = solved.sys.ep_in_housing_mm.z();
  row.image_z_mm = row.ep_z_mm + row.d_s2ep_mm;
  if (!row.fd_mm && std::isfinite(row.d_s2ep_mm)) {
    row.closeup_dioptre = planning::CloseupDioptreNeeded(
        row.d_s2ep_mm, lens::SubjectToPupilMm(s.lens, mount, s.lens.min_focus_mm));
  }
  return row;
}

simulate::SystemSpec SimSpec(const ReportInputs& in, const ports::PortSpec& port) {
  simulate::SystemSpec spec;
  static_cast<housing::HousedCamera&>(spec) = in.setup;
  spec.port = port;
  spec.object_distance_mm = in.subject_distance_mm;
  if (in.air_calibration) {
    spec.air_calibration = camera::ToBrown(in.air_calibration->camera, "air_calibration");
  }
  return spec;
}

std::vector<double> Range(double from, double to, double step) {
  std::vector<double> v;
  for (double x = from; x <= to + 1e-9; x += step) v.push_back(x);
  return v;
}

}  // namespace

double Steps::Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void Steps::Done(const std::string& what, double t0) {
  const double dt = Now() - t0;
  seconds_.emplace_back(what, dt);
  if (dt > 1.0 && options_.progress) options_.progress(fmt::format("{}: {:.1f} s", what, dt));
}

std::string DefaultOtherPort(const ports::PortSpec& port) {
  return port.IsDome() ? "flat-acrylic-10mm" : "nimar-ni320-nominal";
}

OtherPortChoice ChooseOtherPort(const planning::Setup& setup, double subject_distance_mm) {
  if (setup.port.IsDome()) return {DefaultOtherPort(setup.port), ""};
  const std::vector<std::string> domes = {"nimar-ni320-nominal", "generic-dome-8in", "generic-dome-230mm-glass"};
  std::string refused;
  for (const std::string& name : domes) {
    planning::Setup other = setup;
    other.port = catalogue::LoadPort(name);
    try {
      housing::FocusOnSubject(other, subject_distance_mm);
    } catch (const InvalidInput&) {
      // The subject's virtual image with the lens at its closest focus (where the solver stopped).
      const ports::PortSystem sys = housing::SystemAtFocus(other, setup.lens.min_focus_mm);
      const double wd = subject_distance_mm - housing::PupilToOuterMm(sys);
      const double d = wd > 0 ? ports::ParaxialVirtualImage(sys, wd).d_s2ep_mm : 0.0;
      refused += fmt::format("{}{} ({:.1f} mm from the pupil)", refused.empty() ? "" : ", ", name, d);
      continue;
    }
    if (refused.empty()) return {name, ""};
    const lens::Mount& mount = housing::MountOf(setup);
    return {name, fmt::format("comparison port {}: the {} cannot focus on the virtual image of a subject {:g} mm away "
                              "behind {}: its closest is {:.1f} mm",
                              name, setup.lens.name, subject_distance_mm, refused,
                              lens::SubjectToPupilMm(setup.lens, mount, setup.lens.min_focus_mm))};
  }
  throw InvalidInput("compare_port", fmt::format("no comparison dome fits the {} at a subject {:g} mm away ({}); give "
                                                 "one that does",
                                                 setup.lens.name, subject_distance_mm, refused));
}

Results Gather(const ReportInputs& in, Steps& steps) {
  if (!(in.subject_distance_mm > 0 && std::isfinite(in.subject_distance_mm))) {
    throw InvalidInput("subject_distance", "must be a finite distance > 0 mm");
  }
  if (in.water_calibration && !in.air_calibration) {
    throw InvalidInput("water_calibration", "needs `air_calibration` too (the comparison is air vs water)");
  }
  const camera::Sensor& cam = in.setup.camera.sensor;
  for (const auto* rec : {in.air_calibration ? &*in.air_calibration : nullptr,
                          in.water_calibration ? &*in.water_calibration : nullptr}) {
    if (rec && (rec->camera.sensor.width_px != cam.width_px ||
                rec->camera.sensor.height_px != cam.height_px ||
                std::abs(rec->camera.sensor.pixel_pitch_mm - cam.pixel_pitch_mm) > 1e-9)) {
      // A calibration run without the pixel pitch is in pixels (pitch 1 "mm"): say how to fix it.
      const bool in_pixels = rec->camera.sensor.width_px == cam.width_px &&
                             rec->camera.sensor.height_px == cam.height_px && rec->camera.sensor.pixel_pitch_mm == 1;
      throw InvalidInput(rec == &*in.air_calibration ? "air_calibration" : "water_calibration",
                         fmt::format("its sensor ({}x{} px, {:g} mm) is not the camera's ({}x{} px, {:g} mm){}",
                                     rec->camera.sensor.width_px, rec->camera.sensor.height_px,
                                     rec->camera.sensor.pixel_pitch_mm,
                                     cam.width_px, cam.height_px, cam.pixel_pitch_mm,
                                     in_pixels ? fmt::format(": it was calibrated in pixels; calibrate it again "
                                                             "with the pixel pitch, {:g} mm", cam.pixel_pitch_mm)
                                               : std::string()));
    }
  }

  Results r;
  r.in = &in;
  r.other_setup = in.setup;
  r.other_setup.port = in.other_port;
  const planning::Setup& other = r.other_setup;

  steps.Run("dive plan (focus, minimum WD, DOF, field curvature)", [&] {
    r.plan = planning::MakePlan(in.setup, PlanFor(in, in.subject_distance_mm, 11));
    r.other_plan = planning::MakePlan(other, PlanFor(in, in.subject_distance_mm, 2));
    if (in.setup.port.IsFlat()) r.flat = planning::AnalyseFlat(in.setup, {});
    if (in.other_port.IsFlat()) r.flat = planning::AnalyseFlat(other, {});
  });

  steps.Run("virtual image against working distance", [&] {
    const lens::Mount& mount = lens::MountByName(in.setup.camera.mount);
    const double h = in.setup.lens.focal_length_mm / (2 * in.f_number);
    for (double wd : kTable5Wd) r.table.push_back(VirtualAt(in.setup, mount, wd, h));
    // The virtual image of infinity, once: the table's last row (lens focused on it, as plan's
    // d_s2ep_infinity_mm), and the same point seen from the pupil at the focus-scale infinity (a
    // fixed pupil makes the two one number).
    PORTHOLE_CHECK(std::isinf(r.table.back().wd_mm));
    r.infinity.focused = r.table.back();
    const ports::PortSystem at_inf = planning::SystemAtFocus(in.setup, kInf);
    r.infinity.d_s2ep_at_infinity_focus_mm = ports::ParaxialVirtualImage(at_inf, kInf).d_s2ep_mm;
    r.infinity.ep_z_at_infinity_focus_mm = at_inf.ep_in_housing_mm.z();
    for (int k = 0; k <= 60; ++k) {  // 50 mm … 100 m, log-spaced
      r.curve.push_back(VirtualAt(in.setup, mount, 50 * std::pow(2000.0, k / 60.0), h));
    }
  });

  steps.Run("depth of field against subject distance", [&] {
    const double near = std::max(planning::PupilToOuterMm(r.plan.system) + 50, 250.0);
    for (int k = 0; k <= 16; ++k) {
      const double s = near * std::pow(5000 / near, k / 16.0);
      const planning::Plan p = planning::MakePlan(in.setup, PlanFor(in, s, 1));
      if (p.target) r.dof.push_back({s, p.target->air, p.target->water});
    }
    r.min_subject_mm = r.plan.min_wd_mm + planning::PupilToOuterMm(planning::SystemAtFocus(in.setup, in.setup.lens.min_focus_mm));
  });

  steps.Run("chief rays through both ports", [&] {
    const double c = r.plan.principal_distance_mm;
    const double half_diag = 0.5 * in.setup.camera.SensorDiagonalMm();
    // The lens's projection gives the corner's field angle (a fisheye's reaches 90 deg and more).
    const double corner_deg = std::min(179.0, lens::FieldAngleRad(in.setup.lens, c, half_diag).value_or(M_PI / 2) * kDeg);
    for (int k = 0; k <= 40; ++k) {
      AngleRow row;
      row.theta_air_deg = corner_deg * k / 40;
      const ports::Vec3 d(std::sin(row.theta_air_deg / kDeg), 0, std::cos(row.theta_air_deg / kDeg));
      if (const auto w = planning::WaterDirection(r.plan.system, d)) row.theta_main_deg = std::atan2(w->x(), w->z()) * kDeg;
      if (const auto w = planning::WaterDirection(r.other_plan.system, d)) {
        row.theta_other_deg = std::atan2(w->x(), w->z()) * kDeg;
      }
      r.angles.push_back(row);
    }
    // The fan of the cross-section: chief rays to the sensor's horizontal edges and between.
    const double half_h =
        lens::FieldAngleRad(in.setup.lens, c, 0.5 * in.setup.camera.SensorWidthMm()).value_or(M_PI / 2) * kDeg;
    const auto seq = r.plan.system.Outward();
    for (int k = 0; k <= 8; ++k) {
      const double a = (-half_h + 2 * half_h * k / 8) / kDeg;
      optics::Ray out;
      optics::RayPath path;
      const auto st = optics::TraceSequence<double>(
          seq, {r.plan.system.ep_in_housing_mm, ports::Vec3(std::sin(a), 0, std::cos(a))}, &out, &path);
      if (st == optics::RayStatus::kOk) path.points.push_back(out.origin + in.subject_distance_mm * out.dir);
      r.fan.push_back(path);
      r.fan_angles_deg.push_back(a * kDeg);
    }
  });

  // The simulation: the prediction for this port, the same lens behind the other port, and the
  // pupil-offset sweeps, in parallel (each is independent; Ceres and the tracer are re-entrant).
  steps.Run("predicted underwater calibration, tolerance sweeps", [&] {
    r.prediction = simulate::Predict(SimSpec(in, in.setup.port));
    r.map = simulate::DistortionMap(r.prediction);
    // Toward the glass the pupil may not reach a flat port's inner face: an action camera's window
    // is a few mm ahead of it (generic-flat-action-housing: 8 mm), so the sweep stops 1 mm short.
    double z_max = 10;
    if (r.plan.system.IsFlat()) {
      const ports::FlatPort& fp = r.plan.system.flat();
      const double gap = (fp.inner_point_mm - r.plan.system.ep_in_housing_mm).dot(fp.normal.normalized());
      z_max = std::min(z_max, 2 * std::floor((gap - 1) / 2));
    }
    r.offsets_z_mm = Range(-10, z_max, 2);
    r.offsets_x_mm = Range(-2, 2, 0.5);
    auto z = std::async(std::launch::async, [&] { return simulate::SweepPupilOffset(r.prediction, 2, r.offsets_z_mm); });
    auto x = std::async(std::launch::async, [&] { return simulate::SweepPupilOffset(r.prediction, 0, r.offsets_x_mm); });
    r.other_prediction = simulate::Predict(SimSpec(in, in.other_port));
    r.sweep_z = z.get();
    r.sweep_x = x.get();
  });

  if (in.air_calibration && in.water_calibration) {
    steps.Run("comparison of the calibrations", [&] {
      r.compare = calib::Compare(*in.air_calibration, *in.water_calibration);
    });
  }
  if (in.rig) {
    steps.Run("rig plan", [&] { r.rig_plan = measure::PlanRig(in.rig->rig, in.rig->plan); });
  }
  return r;
}

}  // namespace porthole::report
