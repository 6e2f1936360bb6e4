#include "porthole/planning/json.h"

#include "porthole/camera/projection.h"
#include "porthole/core/json_length.h"
#include "porthole/ports/describe.h"

#include <algorithm>
#include <cmath>

namespace porthole::planning {
namespace {

// A length (core/json_length.h); null for nullopt.
Json L(double v) { return JsonLength<Json>(v); }
Json L(const std::optional<double>& v) { return v ? L(*v) : Json(nullptr); }

Json FovJson(const Fov& f) {
  return {{"horizontal_deg", L(f.horizontal_deg)}, {"vertical_deg", L(f.vertical_deg)},
          {"diagonal_deg", L(f.diagonal_deg)}};
}

Json FieldCutJson(const FieldCut& c) {
  return {{"what", c.what}, {"blocked_fraction", c.blocked_fraction}, {"clear_radius_mm", L(c.clear_radius_mm)},
          {"clear_angle_deg", L(c.clear_angle_deg)}, {"clear_water_angle_deg", L(c.clear_water_angle_deg)}};
}

}  // namespace

Json SetupToJson(const Setup& s, const ports::PortSystem& sys) {
  const auto& cam = s.camera;
  const auto& ln = s.lens;
  // found_in: which source answered the name ("preset", "file", "lensfun"; catalogue::FindCamera); source:
  // where its values come from, null when the preset or file states none.
  const auto source = [](const std::string& v) { return v.empty() ? Json(nullptr) : Json(v); };
  return {{"camera", {{"name", cam.name}, {"found_in", cam.lookup}, {"source", source(cam.source)}, {"mount", cam.mount},
                      {"width_px", cam.sensor.width_px}, {"height_px", cam.sensor.height_px},
                      {"pixel_pitch_mm", cam.sensor.pixel_pitch_mm}}},
          {"lens", {{"name", ln.name}, {"found_in", ln.lookup}, {"source", source(ln.source)},
                    {"fixed_focus", ln.fixed_focus},
                    {"focal_length_mm", ln.focal_length_mm}, {"f_number_min", ln.f_number_min},
                    {"f_number_max", ln.f_number_max}, {"min_focus_mm", ln.min_focus_mm},
                    {"min_focus_assumed", ln.min_focus_assumed}, {"pupil_estimated", ln.pupil_estimated},
                    {"projection", camera::ProjectionName(ln.projection)},
                    {"projection_estimated", ln.projection_estimated}}},
          {"port", ports::PortJson(sys)},  // the one port JSON (ports/describe.h)
          {"water", {{"index", sys.n_water}, {"lambda_nm", s.env.conditions.lambda_nm}}},
          {"ep_in_housing_mm", {sys.ep_in_housing_mm.x(), sys.ep_in_housing_mm.y(), sys.ep_in_housing_mm.z()}}};
}

Json PlanToJson(const Setup& s, const Plan& p) {
  Json out = SetupToJson(s, p.system);
  out["f_number"] = p.f_number;
  out["coc_mm"] = p.coc_mm;
  out["coc_source"] = p.coc_source;
  out["d_s2ep_infinity_mm"] = L(p.d_s2ep_infinity_mm);
  out["d_s2ep_infinity_assumes"] = "the lens focused on the virtual image of infinity";
  out["infinity_image_focus_distance_mm"] =
      p.infinity_image_focus_distance_mm ? L(*p.infinity_image_focus_distance_mm) : Json(nullptr);
  out["closest_d_s2ep_mm"] = L(p.closest_d_s2ep_mm);
  out["min_wd_mm"] = L(p.min_wd_mm);
  out["min_wd_set_by"] = p.lens_covers_virtual_range ? "glass" : "lens";
  out["d_s2ep_touching_mm"] = L(p.d_s2ep_touching_mm);
  out["pupil_to_outer_mm"] = L(p.pupil_to_outer_mm);
  Json cu = Json::array();
  for (const CloseupRow& r : p.closeup) {
    cu.push_back({{"dioptre", r.dioptre}, {"min_wd_mm", L(r.min_wd_mm)}, {"max_wd_mm", L(r.max_wd_mm)},
                  {"needed", r.needed}});
  }
  out["closeup"] = cu;
  const InfinityFocus& i = p.infinity;
  out["infinity_focus"] = {
      {"air", {{"hyperfocal_mm", L(i.air_focus_mm)}, {"near_mm", L(i.air_near_mm)},
               {"focus_distance_mm", L(i.air_focus_distance_mm)}}},
      {"water", {{"virtual_focus_mm", L(i.water_virtual_focus_mm)}, {"virtual_near_mm", L(i.water_virtual_near_mm)},
                 {"near_mm", L(i.water_near_mm)}, {"near_wd_mm", L(i.water_near_wd_mm)},
                 {"focus_distance_mm", L(i.water_focus_distance_mm)}}}};
  out["principal_distance_mm"] = p.principal_distance_mm;
  out["fov"] = {{"air", FovJson(p.fov.air)}, {"water", FovJson(p.fov.water)}};
  if (p.centring) {
    const PupilCentring& c = *p.centring;
    out["pupil_centring"] = {{"axial_offset_mm", c.axial_offset_mm},
                             {"lateral_offset_mm", c.lateral_offset_mm},
                             {"focus_distance_mm", L(c.focus_distance_mm)},
                             {"extension_mm", c.extension_mm},
                             {"focus_distance_after_mm", L(c.focus_distance_after_mm)},
                             {"residual_mm", L(c.residual_mm)}};
  } else {
    out["pupil_centring"] = nullptr;
  }
  out["field_cut"] = FieldCutJson(p.field_cut);
  if (p.target) {
    const TargetPlan& t = *p.target;
    out["wd_mm"] = L(t.wd_mm);
    out["subject_distance_mm"] = L(t.subject_distance_mm);
    out["virtual_image"] = {{"d_s2ep_mm", L(t.virtual_image.d_s2ep_mm)}, {"vwd_mm", L(t.virtual_image.vwd_mm)},
                            {"magnification", t.virtual_image.magnification},
                            {"d_s2ep_real_mm", L(t.d_s2ep_real_mm)}};
    out["focus"] = {{"d_s2ep_mm", L(t.focus.d_s2ep_mm)}, {"focus_distance_mm", L(t.focus.focus_distance_mm)},
                    {"reachable", t.focus.focus_distance_mm.has_value()},
                    {"ep_to_flange_mm", t.focus.ep_to_flange_mm}, {"closeup_dioptre", t.focus.closeup_dioptre}};
    const DofWater& w = t.water;
    out["dof"] = {
        {"air", {{"focus_mm", L(t.air.focus_mm)}, {"near_mm", L(t.air.near_mm)}, {"far_mm", L(t.air.far_mm)},
                 {"total_mm", L(t.air.total_mm)}, {"focus_distance_mm", L(t.air.focus_distance_mm)}}},
        {"water", {{"virtual_focus_mm", L(w.virtual_focus_mm)}, {"virtual_near_mm", L(w.virtual_near_mm)},
                   {"virtual_far_mm", L(w.virtual_far_mm)}, {"virtual_total_mm", L(w.virtual_total_mm)},
                   {"focus_mm", L(w.focus_mm)}, {"near_mm", L(w.near_mm)}, {"far_mm", L(w.far_mm)},
                   {"total_mm", L(w.total_mm)}, {"near_wd_mm", L(w.near_wd_mm)}, {"far_wd_mm", L(w.far_wd_mm)}}},
        // null: not applicable, when either total is unlimited (ratio_note says which).
        {"ratio_water_to_air", L(t.dof_ratio_water_to_air)}};
    if (!std::isfinite(t.dof_ratio_water_to_air)) {
      out["dof"]["ratio_note"] = std::isinf(t.air.total_mm) ? "not applicable: the depth of field in air is unlimited"
                                                            : "not applicable: the depth of field in water is unlimited";
    }
    out["gsd"] = {{"water_mm_per_px", t.gsd_water_mm}, {"air_mm_per_px", t.gsd_air_mm}};
    if (t.field) {
      Json rows = Json::array();
      for (const FieldRow& r : t.field->rows) {
        // A row beyond the port's rim has no image: its values are null and beyond_rim says why.
        rows.push_back({{"image_height_mm", r.image_height_mm}, {"field_angle_deg", L(r.field_angle_deg)},
                        {"object_height_mm", L(r.object_height_mm)}, {"d_s2ep_mm", L(r.d_s2ep_mm)},
                        {"sag_mm", L(r.sag_mm)}, {"blur_px", L(r.blur_px)}, {"spread_px", L(r.spread_px)},
                        {"beyond_rim", std::isnan(r.d_s2ep_mm)}});
      }
      // The smallest f-number that keeps the corners within the circle of confusion, no wider than
      // the lens opens (a corner blur of 0 gave f/0: sharp at every f-number of the lens).
      out["field_curvature"] = {
          {"aperture_height_mm", t.field->aperture_height_mm},
          {"corner_blur_px", t.field->corner_blur_px},
          {"f_number_for_sharp_corners", std::max(t.field->f_number_for_sharp_corners, s.lens.f_number_min)},
          {"sharp_corners_within_lens_range", t.field->f_number_for_sharp_corners <= s.lens.f_number_max},
          {"rows", rows}};
    } else {
      out["field_curvature"] = nullptr;
    }
  }
  out["warnings"] = p.warnings;
  return out;
}

Json FlatToJson(const Setup& s, const FlatAnalysis& a) {
  Json out = SetupToJson(s, a.system);
  out["principal_distance_mm"] = a.principal_distance_mm;
  out["apparent_focal_length_mm"] = a.apparent_focal_length_mm;
  out["focal_length_increase_pct"] = a.focal_length_increase_pct;
  out["fov"] = {{"air", FovJson(a.air)}, {"water_thin", FovJson(a.water_thin)},
                {"water_traced", FovJson(a.water_traced)}};
  out["field_cut"] = FieldCutJson(a.field_cut);
  out["critical_angle_deg"] = a.critical_angle_deg;
  out["max_fov_deg"] = a.max_fov_deg;
  out["corner_outer_radius_mm"] = L(a.corner_outer_radius_mm);
  out["clear_aperture_needed_mm"] = L(a.clear_aperture_needed_mm);
  out["wd_mm"] = L(a.wd_mm);
  out["coverage"] = {{"thin_mm", L(a.coverage_thin_mm)}, {"traced_mm", L(a.coverage_traced_mm)}};
  out["lateral_colour"] = {{"n_water_blue", a.n_water_blue}, {"n_water_red", a.n_water_red},
                           {"corner_px", L(a.lateral_colour_corner_px)}};
  Json rows = Json::array();
  for (const FlatRow& r : a.rows) {
    rows.push_back({{"theta_air_deg", r.theta_air_deg}, {"theta_water_deg", r.theta_water_deg},
                    {"distortion_factor", r.distortion_factor},
                    {"distortion_factor_traced", L(r.distortion_factor_traced)},
                    {"image_radius_mm", r.image_radius_mm}, {"distortion_px", r.distortion_px},
                    {"lateral_colour_px", L(r.lateral_colour_px)}});
  }
  out["rows"] = rows;
  out["warnings"] = a.warnings;
  return out;
}

}  // namespace porthole::planning
