// `porthole plan`: where to focus behind a dome or flat port, whether the lens gets there, the
// minimum working distance and close-up lenses, depth of field under water and in air, the focus
// that keeps infinity sharp, field of view, ground sample distance and the corners' blur from the
// port's field curvature (issue 3; docs/planning.md).
#include <fmt/format.h>

#include <cmath>

#include "commands.h"
#include "common.h"
#include "camera_options.h"
#include "porthole/camera/projection.h"
#include "porthole/measure/plan_rig.h"
#include "porthole/planning/json.h"

namespace porthole::cli {

namespace {

// A distance for the text: fixed decimals, "infinity" for an infinite one (an object or focus at
// infinity), "n/a" (not applicable) where none exists. Never "inf", "nan" or "-".
std::string Dist(double v, int decimals) {
  if (std::isinf(v)) return v > 0 ? "infinity" : "-infinity";
  if (std::isnan(v)) return "n/a";
  return Fixed(v, decimals);
}
// A distance with its unit: "1234 mm", or "infinity" (no unit) for one at infinity.
std::string Mm(double v, int decimals) { return std::isinf(v) ? Dist(v, decimals) : Dist(v, decimals) + " mm"; }
// "focus scale 1234 mm", or what stands for it when the lens cannot reach that focus.
std::string FocusScale(const std::optional<double>& fd) {
  return fd ? (std::isinf(*fd) ? std::string("focus scale at infinity") : "focus scale " + Dist(*fd, 0) + " mm")
            : "beyond the lens's focus range";
}
// A depth-of-field total: "unlimited" when the far limit is at infinity.
std::string Total(double v, int decimals) { return std::isinf(v) && v > 0 ? "unlimited" : Dist(v, decimals); }

// Planning's advice about setting the focus (the focus scale, pre-focusing in air): none of it
// applies to a fixed-focus lens.
bool IsFocusAdvice(const std::string& w) {
  return w.find("focus scale") != std::string::npos || w.find("pre-focus") != std::string::npos;
}

std::string PlanText(const planning::Setup& s, const planning::Plan& p) {
  const auto& sys = p.system;
  const std::string projection =
      s.lens.projection == camera::Projection::kRectilinear
          ? ""
          : fmt::format(", {} fisheye{}", camera::ProjectionName(s.lens.projection),
                        s.lens.projection_estimated ? " (estimated)" : "");
  std::string t = fmt::format("{} + {} (f = {:g} mm{}) behind {} ({}), water n = {:.4f}; f/{:g}, circle of "
                              "confusion {:.4f} mm ({})\n\n",
                              s.camera.name, s.lens.name, s.lens.focal_length_mm, projection, sys.spec.name,
                              sys.spec.KindName(), sys.n_water, p.f_number, p.coc_mm, p.coc_source);
  t.insert(t.size() - 1, catalogue::DescribeCameraAndLens(s.camera, s.lens));
  t += std::isfinite(p.d_s2ep_infinity_mm)
           ? fmt::format("virtual image of infinity      {:>9} mm from the entrance pupil (lens focused on it)\n",
                         Dist(p.d_s2ep_infinity_mm, 1))
           : std::string("virtual image of infinity      at infinity (the port has no power)\n");
  const bool fixed_focus = s.lens.fixed_focus;  // nothing to set: no focus advice
  t += fixed_focus
           ? fmt::format("lens's closest sharp subject   {:>9} mm (fixed focus, sharp from {:g} mm{}, Eq. 2)\n",
                         Dist(p.closest_d_s2ep_mm, 1), s.lens.min_focus_mm, s.lens.min_focus_assumed ? ", assumed" : "")
           : fmt::format("lens's closest subject         {:>9} mm (minimum focus {:g} mm{}, Eq. 2)\n",
                         Dist(p.closest_d_s2ep_mm, 1), s.lens.min_focus_mm, s.lens.min_focus_assumed ? ", assumed" : "");
  if (p.lens_covers_virtual_range) {
    t += fmt::format("minimum working distance       {:>9} mm: the glass (the lens focuses on the whole virtual-image "
                     "range, {:.1f} mm to {})\n",
                     Dist(p.min_wd_mm, 0), p.d_s2ep_touching_mm, Mm(p.d_s2ep_infinity_mm, 1));
    t += s.lens.min_focus_assumed ? "  close-up lens                  not needed (with the assumed minimum focus)\n"
                                  : "  close-up lens                  not needed\n";
  } else {
    t += std::isfinite(p.min_wd_mm)
             ? fmt::format("minimum working distance       {:>9} mm (set by the lens's minimum focus{})\n",
                           Dist(p.min_wd_mm, 0), s.lens.min_focus_assumed ? ", assumed" : "")
             : "minimum working distance             none: the lens cannot focus on anything behind this port\n";
    for (const auto& r : p.closeup) {
      t += fmt::format("  with a +{:g} dioptre close-up  WD {} to {}\n", r.dioptre, Mm(r.min_wd_mm, 0),
                       Mm(r.max_wd_mm, 0));
    }
  }
  const auto& i = p.infinity;
  if (fixed_focus) {
    // A fixed-focus lens renders sharp what lies between its closest sharp subject and infinity:
    // under water, every object whose virtual image lies there.
    t += std::isfinite(p.min_wd_mm)
             ? fmt::format("sharp under water              fixed focus, nothing to set: WD {} to {}\n",
                           Mm(p.min_wd_mm, 0), std::isinf(p.d_s2ep_infinity_mm) ? "infinity"
                           : fmt::format("infinity (its virtual image at {})", Mm(p.d_s2ep_infinity_mm, 1)))
             : std::string("sharp under water              nothing: the virtual images lie closer than the lens "
                           "renders sharp\n");
    t += fmt::format("sharp in air                   fixed focus, nothing to set: {} to infinity\n",
                     Mm(p.closest_d_s2ep_mm, 0));
  } else {
    t += fmt::format("infinity sharp, under water    focus on {} ({}): sharp from WD {}\n",
                     Mm(i.water_virtual_focus_mm, 1), FocusScale(i.water_focus_distance_mm),
                     Mm(i.water_near_wd_mm, 0));
    t += fmt::format("infinity sharp, in air         hyperfocal {} ({}): sharp from {}\n",
                     Mm(i.air_focus_mm, 0), FocusScale(i.air_focus_distance_mm), Mm(i.air_near_mm, 0));
  }
  t += fmt::format("field of view (c = {:.2f} mm)   air {}/{}/{} deg, water {}/{}/{} deg (h/v/diagonal)\n",
                   p.principal_distance_mm, Fixed(p.fov.air.horizontal_deg, 1), Fixed(p.fov.air.vertical_deg, 1),
                   Fixed(p.fov.air.diagonal_deg, 1), Fixed(p.fov.water.horizontal_deg, 1),
                   Fixed(p.fov.water.vertical_deg, 1), Fixed(p.fov.water.diagonal_deg, 1));
  if (p.centring) {
    const auto& c = *p.centring;
    const std::string where = std::abs(c.axial_offset_mm) < 0.05
                                  ? std::string("at the dome's centre along the axis")
                                  : fmt::format("{:.1f} mm {} the dome's centre", std::abs(c.axial_offset_mm),
                                                c.axial_offset_mm > 0 ? "ahead of" : "behind");
    t += fmt::format("entrance pupil                 {}, {:.1f} mm off its axis ({})\n", where,
                     c.lateral_offset_mm, FocusScale(c.focus_distance_mm));
    if (std::abs(c.extension_mm) >= 0.05 && s.lens.mount != "fixed") {  // no ring fits a built-in lens
      t += fmt::format("  to centre it                 {} (then {}){}\n",
                       c.extension_mm > 0 ? fmt::format("add a {:.1f} mm extension ring", c.extension_mm)
                                          : fmt::format("shorten the extension by {:.1f} mm", -c.extension_mm),
                       FocusScale(c.focus_distance_after_mm),
                       c.lateral_offset_mm >= 0.05 ? "; no ring corrects the lateral offset" : "");
      if (s.lens.pupil_estimated) t += "  (the entrance pupil is assumed, not measured: so is this ring)\n";
    }
  }
  // A curved port (ports::PortSpec::IsCurved) cuts the field at its rim.
  const std::string rim = sys.spec.IsCurved() ? fmt::format("{}'s rim", sys.spec.KindName()) : "port";
  t += p.field_cut.blocked_fraction > 0
           ? fmt::format("cut off by the {}{:>6} {} ({:.1f} % of the frame): beyond {:.1f} deg off axis in air "
                         "({:.1f} deg in water), {:.2f} mm from the image centre\n",
                         rim, "", p.field_cut.what, 100 * p.field_cut.blocked_fraction,
                         p.field_cut.clear_angle_deg, p.field_cut.clear_water_angle_deg, p.field_cut.clear_radius_mm)
           : fmt::format("cut off by the {}{:>6} nothing\n", rim, "");
  if (p.target) {
    const auto& g = *p.target;
    t += fmt::format("\ntarget: WD {} mm, {} mm from the entrance pupil\n", Dist(g.wd_mm, 1),
                     Dist(g.subject_distance_mm, 1));
    t += fmt::format("virtual image                  {:>9} mm from the pupil (real rays at f/{:g}: {})\n",
                     Dist(g.virtual_image.d_s2ep_mm, 1), p.f_number,
                     std::isfinite(g.d_s2ep_real_mm) ? Dist(g.d_s2ep_real_mm, 1) + " mm" : "not traced");
    if (fixed_focus) {
      t += g.focus.focus_distance_mm
               ? fmt::format("fixed focus                    nothing to set: the virtual image is within the "
                             "lens's sharp range ({} to infinity)\n", Mm(p.closest_d_s2ep_mm, 1))
               : fmt::format("NOT SHARP: the virtual image is closer than the lens renders sharp ({}); move back "
                             "to WD >= {} or add a close-up of at least +{:.2f} dioptres\n",
                             Mm(p.closest_d_s2ep_mm, 1), Mm(p.min_wd_mm, 0), g.focus.closeup_dioptre);
    } else {
      t += g.focus.focus_distance_mm
               ? fmt::format("set the focus scale to         {:>9} mm\n", Dist(*g.focus.focus_distance_mm, 0))
               : fmt::format("NOT REACHABLE: needs a close-up of at least +{:.2f} dioptres\n", g.focus.closeup_dioptre);
    }
    // A fixed-focus lens's depth of field is its sharp range above; the table is for a lens focused
    // on the target.
    if (!fixed_focus) {
    t += fmt::format("\n{:<22} {:>9} {:>9} {:>9} {:>9}\n", "depth of field, mm", "focus", "near", "far", "total");
    t += fmt::format("{:<22} {:>9} {:>9} {:>9} {:>9}\n", "in air", Dist(g.air.focus_mm, 0), Dist(g.air.near_mm, 0),
                     Dist(g.air.far_mm, 0), Total(g.air.total_mm, 0));
    t += fmt::format("{:<22} {:>9} {:>9} {:>9} {:>9}\n", "water, virtual image", Dist(g.water.virtual_focus_mm, 1),
                     Dist(g.water.virtual_near_mm, 1), Dist(g.water.virtual_far_mm, 1),
                     Total(g.water.virtual_total_mm, 1));
    // The ratio of two totals exists only when both are finite (an unlimited in-air depth of field
    // made it "x0.00", or "x-" when both were unlimited).
    const double ratio = g.dof_ratio_water_to_air;
    t += fmt::format("{:<22} {:>9} {:>9} {:>9} {:>9}   ({})\n", "water, real objects", Dist(g.water.focus_mm, 0),
                     Dist(g.water.near_mm, 0), Dist(g.water.far_mm, 0), Total(g.water.total_mm, 0),
                     std::isfinite(ratio) ? fmt::format("x{:.2f} of air", ratio)
                     : std::isinf(g.air.total_mm) ? "ratio to air not applicable: unlimited in air"
                                                  : "ratio to air not applicable");
    }
    t += fmt::format("\nground sample distance         {:.3f} mm/px under water ({:.3f} in air at the same distance)\n",
                     g.gsd_water_mm, g.gsd_air_mm);
    if (g.field) {
      t += camera::IsFisheye(s.lens.projection)
               ? fmt::format("\nfield curvature (fisheye: object sphere {:g} mm from the pupil, distances along the "
                             "chief ray; real rays at {:.2f} mm pupil radius)\n",
                             g.subject_distance_mm, g.field->aperture_height_mm)
               : fmt::format("\nfield curvature (flat object plane at WD {:g} mm; real rays at {:.2f} mm pupil "
                             "radius)\n",
                             g.wd_mm, g.field->aperture_height_mm);
      t += fmt::format("{:>10} {:>9} {:>11} {:>10} {:>8} {:>8} {:>10}\n", "image mm", "angle", "object mm", "D_S2EP",
                       "sag mm", "blur px", "spread px");
      for (const auto& r : g.field->rows) {
        t += std::isnan(r.d_s2ep_mm)  // the port's rim hides this part of the field
                 ? fmt::format("{:>10} {:>9}   beyond the port's rim\n", Fixed(r.image_height_mm, 2),
                               std::isfinite(r.field_angle_deg) ? Fixed(r.field_angle_deg, 1) : "n/a")
                 : fmt::format("{:>10} {:>9} {:>11} {:>10} {:>8} {:>8} {:>10}\n", Fixed(r.image_height_mm, 2),
                               std::isfinite(r.field_angle_deg) ? Fixed(r.field_angle_deg, 1) : "n/a",
                               Dist(r.object_height_mm, 0), Dist(r.d_s2ep_mm, 2), Dist(r.sag_mm, 2),
                               Dist(r.blur_px, 1), Dist(r.spread_px, 1));
      }
      // The f-number that brings the corners within the circle of confusion, within the lens's range.
      const double nf = g.field->f_number_for_sharp_corners;
      t += fmt::format("corner blur {:.1f} px at f/{:g}; {}\n", g.field->corner_blur_px, p.f_number,
                       nf <= s.lens.f_number_min
                           ? fmt::format("within the circle of confusion at every f-number of the lens (from "
                                         "f/{:g})", s.lens.f_number_min)
                       : nf <= s.lens.f_number_max
                           ? fmt::format("within the circle of confusion from f/{:.1f}", nf)
                           : fmt::format("not within the circle of confusion at any f-number of the lens (it would "
                                         "take f/{:.1f}; the lens stops at f/{:g})", nf, s.lens.f_number_max));
    }
  }
  // The plausibility warnings (core/plausible.h) went to stderr in the CLI's words; the advice here.
  std::string advice;
  for (const auto& w : p.warnings) {
    if (w.find(kImplausiblePhrase) != std::string::npos) continue;
    // A fixed-focus lens has no focus scale: planning's focus advice does not apply to it.
    if (fixed_focus && IsFocusAdvice(w)) continue;
    advice += "! " + w + "\n";
  }
  if (!advice.empty()) t += "\n" + advice;
  return t;
}

}  // namespace

std::string RigPlanText(const measure::RigPlan& p, const std::string& what) {
  std::string t = fmt::format("rig plan: {}; a {:g} mm length in {} orientations, image sigma {:g} px; sigma holds: {}\n",
                              what, p.length_mm, p.orientations, p.sigma_px, p.calibration_sigma);
  if (p.central) {
    std::string models;
    for (const auto& m : p.central_models) models += (models.empty() ? "" : ", ") + m;
    t += fmt::format("central model: {} without refraction, calibrated with the rig under water at {:g} mm "
                     "(fit RMS {:.3f} px); its error = its length - the true length\n",
                     models, p.central_fit_range_mm, p.central_fit_rms_px);
  }
  t += fmt::format("\n{:>9} {:>19} {:>8} {:>10} {:>10} {:>8}", "range_mm", "common field mm", "lengths", "sigma_mm",
                   "p90_mm", "sigma_%");
  if (p.central) t += fmt::format(" {:>12} {:>12} {:>10}", "central_|e|", "central_max", "central_%");
  t += "\n";
  for (const auto& r : p.rows) {
    if (r.n_lengths == 0) {
      t += fmt::format("{:>9.0f} {:>19}  no {:g} mm length fits in the common field\n", r.range_mm,
                       r.common_width_mm > 0 ? fmt::format("{:.0f} x {:.0f}", r.common_width_mm, r.common_height_mm)
                                             : "none",
                       p.length_mm);
      continue;
    }
    t += fmt::format("{:>9.0f} {:>19} {:>8} {:>10.3f} {:>10.3f} {:>8.3f}", r.range_mm,
                     fmt::format("{:.0f} x {:.0f}", r.common_width_mm, r.common_height_mm), r.n_lengths,
                     r.sigma_median_mm, r.sigma_p90_mm, r.sigma_median_percent);
    if (p.central) {
      t += fmt::format(" {:>12.3f} {:>12.3f} {:>10.3f}", r.central_abs_median_mm, r.central_abs_max_mm,
                       r.central_abs_max_percent);
    }
    t += "\n";
  }
  t += "(sigma: median and 90th percentile over the field and orientations; central: median and largest |error|)\n";
  for (const auto& n : p.notes) t += "! " + n + "\n";
  return t;
}

template <typename O>
void RunRigPlan(const O& o, const std::string& rig_file, const std::optional<double>& baseline_mm,
                double convergence_deg, const std::vector<std::string>& ranges, measure::RigPlanOptions options,
                bool json) {
  WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"sigma_px", "--sigma-px"}, {"length_mm", "--length"},
                  {"ranges_mm", "--ranges"}, {"baseline_mm", "--baseline"}, {"convergence_deg", "--convergence"}},
                 [&] {
    if (!ranges.empty()) options.ranges_mm = ParseLengthList(ranges, "ranges_mm");
    if (!(options.central_fit_range_mm >= 0) || !std::isfinite(options.central_fit_range_mm)) {
      throw InvalidInput("--central-range", "must be >= 0 mm (0: no comparison)");
    }
    measure::Rig rig;
    std::string what;
    if (!rig_file.empty()) {
      rig = measure::LoadRig(rig_file, "--rig");
      what = fmt::format("{} cameras ({})", rig.cameras.size(), rig_file);
    } else {
      const planning::Setup setup = o.camera.ToHoused(o.port, o.water);
      rig = measure::DescribedRig(setup, *baseline_mm, convergence_deg,
                                  options.central_fit_range_mm > 0 ? options.central_fit_range_mm : 1500,
                                  o.aperture.value_or(lens::DefaultFNumber(setup.lens)), &what);
    }
    const measure::RigPlan p = measure::PlanRig(rig, options);
    if (json) {
      return fmt::print("{}\n", measure::RigPlanToJson(p, what).dump(2));
    }
    fmt::print("{}", RigPlanText(p, what));
  });
}

void RegisterPlan(CLI::App& app) {
  struct Options {
    PortOptions port;
    WaterOptions water;
    CameraLensOptions camera;
    std::optional<double> wd_mm, subject_mm, coc_mm;
    std::optional<double> aperture;  // unset: f/8, or the nearest the lens has
    bool json = false;
    // A rig (issue 27): a calibrated rig file, or one described by its baseline and convergence.
    std::string rig;
    std::optional<double> baseline_mm;
    double convergence_deg = 0;
    measure::RigPlanOptions rig_plan;
    std::vector<std::string> ranges;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "plan", "Dive plan behind a port: where to focus, minimum working distance, close-up lens, depth of field "
              "under water and in air, infinity focus, field of view, GSD, corner blur from field curvature");
  o->camera.Add(cmd);
  o->port.Add(cmd);
  o->water.Add(cmd);
  auto* wd = cmd->add_option("--wd", o->wd_mm, "Working distance: object to the port's outer surface, mm");
  cmd->add_option("--subject-distance", o->subject_mm, "Or: object to the lens's entrance pupil, mm")->excludes(wd);
  cmd->add_option("--aperture", o->aperture,
                  "f-number N (default: f/8, or the nearest the lens has: a fixed-aperture lens its own)");
  cmd->add_option("--coc", o->coc_mm, "Circle of confusion, mm (default: 2 pixel pitches)");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  auto* rig = cmd->add_option("--rig", o->rig,
                              "Plan a rig: a rig calibration JSON (calibrate with one --images/--detections per "
                              "camera): the sigma of a length over the common field against range, and a central "
                              "model's error")
                  ->group("Rig");
  cmd->add_option("--baseline", o->baseline_mm,
                  "Or plan a rig of two of these cameras behind these ports, this far apart, mm")
      ->excludes(rig)
      ->group("Rig");
  cmd->add_option("--convergence", o->convergence_deg, "The second camera turned towards the first, deg")
      ->capture_default_str()
      ->group("Rig");
  cmd->add_option("--sigma-px", o->rig_plan.sigma_px, "Image-point sigma of the measured points, px")
      ->capture_default_str()
      ->group("Rig");
  cmd->add_option("--length", o->rig_plan.length_mm, "The length measured (a fish), mm")
      ->capture_default_str()
      ->group("Rig");
  cmd->add_option("--ranges", o->ranges, "Ranges along the first camera's axis, mm (default 500 … 8000)")
      ->delimiter(',')
      ->group("Rig");
  cmd->add_option("--central-range", o->rig_plan.central_fit_range_mm,
                  "Where the compared central model is calibrated, mm (0: no comparison)")
      ->capture_default_str()
      ->group("Rig");
  cmd->callback([o, cmd] {
    if (!o->rig.empty() || o->baseline_mm) {
      for (const char* only : {"--wd", "--subject-distance", "--coc"}) {
        if (cmd->count(only) > 0) throw InvalidInput(only, "plans one camera: not with --rig or --baseline");
      }
      return RunRigPlan(*o, o->rig, o->baseline_mm, o->convergence_deg, o->ranges, o->rig_plan, o->json);
    }
    for (const char* only : {"--convergence", "--sigma-px", "--length", "--ranges", "--central-range"}) {
      if (cmd->count(only) > 0) throw InvalidInput(only, "plans a rig: give --rig or --baseline");
    }
    WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"wd_mm", "--wd"}, {"subject_distance_mm", "--subject-distance"},
                    {"f_number", "--aperture"}, {"coc_mm", "--coc"}},
                   [&] {
                     const planning::Setup setup = o->camera.ToHoused(o->port, o->water);
                     planning::PlanOptions po;
                     po.wd_mm = o->wd_mm;
                     po.subject_distance_mm = o->subject_mm;
                     po.f_number = o->aperture.value_or(lens::DefaultFNumber(setup.lens));
                     po.coc_mm = o->coc_mm;
                     po.lambda_nm = setup.env.conditions.lambda_nm;
                     planning::Plan plan = planning::MakePlan(setup, po);
                     // The circle of confusion's plausibility is the plan's warning (the camera's and
                     // the port's were said as they were read): printed with --coc for coc_mm.
                     for (const std::string& w : plan.warnings) {
                       if (w.rfind("coc_mm: ", 0) == 0 && w.find(kImplausiblePhrase) != std::string::npos) {
                         fmt::print(stderr, "porthole: warning: --coc{}\n", w.substr(6));
                       }
                     }
                     for (std::string& w : plan.warnings) w = CliWords(w);  // `min_focus_mm` → --min-focus-mm
                     if (!o->json) {
                       fmt::print("{}", PlanText(setup, plan));
                       return;
                     }
                     fmt::print("{}\n", planning::PlanToJson(setup, plan).dump(2));
                   });
  });
}

}  // namespace porthole::cli
