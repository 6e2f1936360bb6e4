// The report's JSON (every number, through the libraries' serialisers) and its HTML page (plain
// HTML and CSS, figures inline as SVG, no script).
#include <cmath>

#include <fmt/format.h>

#include "porthole/camera/json.h"
#include "porthole/camera/profile.h"
#include "porthole/planning/json.h"
#include "porthole/simulate/report.h"
#include "porthole/core/json_length.h"
#include "porthole/report/internal.h"

namespace porthole::report {
namespace {

Json L(double v) { return JsonLength<Json>(v); }  // core/json_length.h

Json VirtualRowJson(const VirtualRow& v) {
  return {{"wd_mm", L(v.wd_mm)}, {"d_s2ep_mm", L(v.d_s2ep_mm)}, {"vwd_mm", L(v.vwd_mm)},
          {"d_s2ep_real_mm", L(v.d_s2ep_real_mm)}, {"magnification", v.magnification},
          {"focus_scale_fd_mm", v.fd_mm ? L(*v.fd_mm) : Json(nullptr)},
          {"closeup_dioptre_needed", v.closeup_dioptre}, {"ep_z_in_housing_mm", v.ep_z_mm}};
}

// Numbers for the page: fixed decimals, "∞", or "–".
std::string F(double v, int decimals) {
  if (std::isnan(v)) return "–";
  if (std::isinf(v)) return v > 0 ? "∞" : "−∞";
  return fmt::format("{:.{}f}", v, decimals);
}
std::string G(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : F(v, 0); }
std::string E(double v) { return std::isfinite(v) ? fmt::format("{:.4e}", v) : F(v, 0); }

std::string Row(const std::vector<std::string>& cells, bool head = false) {
  std::string s = "<tr>";
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const char* tag = head || k == 0 ? "th" : "td";
    s += fmt::format("<{0}{1}>{2}</{0}>", tag, head || k > 0 ? "" : " scope=\"row\"", cells[k]);
  }
  return s + "</tr>\n";
}

std::string Table(const std::string& caption, const std::vector<std::string>& head,
                  const std::vector<std::vector<std::string>>& rows) {
  // A two-column table of descriptions reads left-aligned; tables of numbers right-aligned.
  const bool text = head.size() == 2;
  std::string s = fmt::format("<table{}>\n", text ? " class=\"text\"" : "");
  s += fmt::format("<caption>{}</caption>\n<thead>{}</thead>\n<tbody>\n", caption, Row(head, true));
  for (const auto& r : rows) s += Row(r);
  return s + "</tbody>\n</table>\n";
}

std::string Card(const std::string& label, const std::string& value, const std::string& note) {
  return fmt::format("<div class=\"card\"><div class=\"label\">{}</div><div class=\"value\">{}</div>"
                     "<div class=\"note\">{}</div></div>\n", label, value, note);
}

// One Brown parameter in a table: values of the size of K2 need exponents.
std::string Param(int index, double v) { return index <= camera::kBrownY0 ? F(v, 4) : E(v); }

std::string BrownTable(const std::string& caption, const std::vector<std::pair<std::string, camera::BrownParams>>& cols,
                       const std::vector<std::pair<std::string, double>>& extra_row = {}) {
  std::vector<std::string> head = {"parameter"};
  for (const auto& c : cols) head.push_back(c.first);
  std::vector<std::vector<std::string>> rows;
  for (int i = camera::kBrownC; i <= camera::kBrownP2; ++i) {
    const auto& info = camera::kBrownParamInfo[i];
    std::vector<std::string> row = {fmt::format("{} <span class=\"unit\">{}</span>", info.name, info.unit)};
    for (const auto& c : cols) row.push_back(Param(i, c.second.ToArray()[i]));
    rows.push_back(row);
  }
  if (!extra_row.empty()) {
    std::vector<std::string> row = {extra_row.front().first};
    for (const auto& e : extra_row) row.push_back(std::isfinite(e.second) ? F(e.second, 3) : "");
    rows.push_back(row);
  }
  return Table(caption, head, rows);
}

const char* kCss = R"(
:root { --ink:#1d2733; --muted:#5b6774; --line:#dfe5ec; --paper:#ffffff; --bg:#f3f6f9; --accent:#1f5fa8; --air:#c8322d; }
* { box-sizing: border-box; }
body { margin:0; background:var(--bg); color:var(--ink); font:16px/1.55 "DejaVu Sans", "Segoe UI", Helvetica, Arial, sans-serif; }
header { background:linear-gradient(120deg,#0b3a63,#1f5fa8 60%,#2a9d8f); color:#fff; padding:2.2rem 1rem 2rem; }
header .wrap, main, footer { max-width:1180px; margin:0 auto; }
header h1 { margin:0 0 .3rem; font-size:1.9rem; font-weight:600; letter-spacing:.01em; }
header p { margin:.2rem 0; opacity:.92; }
main { padding:1.2rem 1rem 2rem; }
nav.toc { display:flex; flex-wrap:wrap; gap:.4rem .6rem; margin:0 0 1.2rem; }
nav.toc a { background:#fff; border:1px solid var(--line); border-radius:999px; padding:.2rem .8rem; color:var(--accent); text-decoration:none; font-size:.9rem; }
section { background:var(--paper); border:1px solid var(--line); border-radius:10px; padding:1.2rem 1.5rem 1.4rem; margin:0 0 1.4rem; box-shadow:0 1px 2px rgba(0,0,0,.04); }
h2 { margin:.1rem 0 .6rem; font-size:1.35rem; color:#0b3a63; }
h3 { margin:1rem 0 .4rem; font-size:1.08rem; }
p.lead { color:var(--muted); margin-top:0; }
.cards { display:grid; grid-template-columns:repeat(auto-fill,minmax(210px,1fr)); gap:.8rem; }
.card { border:1px solid var(--line); border-left:4px solid var(--accent); border-radius:8px; padding:.6rem .8rem; background:#fbfcfe; }
.card .label { font-size:.82rem; color:var(--muted); text-transform:uppercase; letter-spacing:.04em; }
.card .value { font-size:1.35rem; font-weight:600; font-variant-numeric:tabular-nums; }
.card .note { font-size:.85rem; color:var(--muted); }
ul.warnings { padding-left:1.2rem; } ul.warnings li { margin:.25rem 0; }
ul.warnings li::marker { content:"⚠  "; color:#c77c02; }
table { border-collapse:collapse; margin:.6rem 0 1rem; font-size:.92rem; font-variant-numeric:tabular-nums; }
caption { text-align:left; font-weight:600; padding:.2rem 0 .4rem; color:var(--ink); }
th, td { border-bottom:1px solid var(--line); padding:.28rem .7rem; text-align:right; white-space:nowrap; }
thead th { background:#eef3f8; color:#0b3a63; font-weight:600; }
tbody th { text-align:left; font-weight:500; }
tbody tr:nth-child(even) { background:#f8fafc; }
.unit { color:var(--muted); font-weight:400; font-size:.85em; }
.scroll { overflow-x:auto; }
figure { margin:1rem 0 1.4rem; }
figure .plot { border:1px solid var(--line); border-radius:8px; background:#fff; padding:.3rem; }
figure svg { display:block; width:100%; max-width:960px; height:auto; margin:0 auto; }
figcaption { color:var(--muted); font-size:.92rem; margin-top:.45rem; }
figcaption .files a { color:var(--accent); margin-right:.6rem; font-size:.85rem; }
dl.inputs { display:grid; grid-template-columns:max-content 1fr; gap:.2rem 1.2rem; margin:.4rem 0; }
dl.inputs dt { color:var(--muted); } dl.inputs dd { margin:0; font-family:"DejaVu Sans Mono", monospace; font-size:.9rem; }
footer { color:var(--muted); font-size:.85rem; padding:0 1rem 2rem; }
code { font-family:"DejaVu Sans Mono", monospace; font-size:.9em; background:#eef3f8; padding:0 .25rem; border-radius:3px; }
header code { background:rgba(255,255,255,.18); color:#fff; }
table.text td, table.text th { text-align:left; white-space:normal; }
dl.inputs dd, .card .note { overflow-wrap:anywhere; }
figcaption .files a { display:inline-block; }
@media (max-width: 760px) {
  body { font-size:15px; }
  header { padding:1.2rem .8rem 1rem; }
  header h1 { font-size:1.35rem; }
  main { padding:.8rem .4rem 1.2rem; }
  section { padding:.8rem .7rem 1rem; border-radius:6px; }
  .cards { grid-template-columns:1fr 1fr; gap:.5rem; }
  .card .value { font-size:1.15rem; }
  dl.inputs { grid-template-columns:1fr; gap:0; }
  dl.inputs dd { margin-bottom:.35rem; }
  figure .plot { padding:0; }
  table { font-size:.86rem; }
}
)";

}  // namespace

std::string Html(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

Json ReportJson(const Results& r, const std::vector<Figure>& figures) {
  const ReportInputs& in = *r.in;
  Json j;
  j["porthole_report"] = 1;  // format version; also marks a directory as a porthole report
  Json echo = Json::object();
  for (const auto& [k, v] : in.echo) echo[k] = v;
  j["inputs"] = {{"options", echo}, {"subject_distance_mm", in.subject_distance_mm}, {"f_number", in.f_number}};
  j["system"] = planning::SetupToJson(in.setup, r.plan.system);
  j["plan"] = planning::PlanToJson(in.setup, r.plan);
  Json table = Json::array(), curve = Json::array();
  for (const auto& v : r.table) table.push_back(VirtualRowJson(v));
  for (const auto& v : r.curve) curve.push_back(VirtualRowJson(v));
  j["virtual_image"] = {{"rows", table}, {"curve", curve}};
  // Quantities the report shows in several places, each defined once, with the focus it assumes.
  const InfinityImage& inf = r.infinity;
  j["virtual_image_of_infinity"] = {
      {"assumes", "the lens focused on the image of infinity (the pupil where that focus puts it); the last row "
                  "of virtual_image.rows, and `porthole plan`'s d_s2ep_infinity_mm"},
      {"d_s2ep_mm", L(inf.focused.d_s2ep_mm)}, {"vwd_mm", L(inf.focused.vwd_mm)},
      {"focus_scale_fd_mm", inf.focused.fd_mm ? L(*inf.focused.fd_mm) : Json(nullptr)},
      {"ep_z_in_housing_mm", inf.focused.ep_z_mm}, {"image_z_in_housing_mm", L(inf.focused.image_z_mm)},
      {"with_focus_scale_at_infinity",
       {{"assumes", "the lens's focus scale at infinity (the pupil there); the same point in the housing"},
        {"d_s2ep_mm", L(inf.d_s2ep_at_infinity_focus_mm)}, {"ep_z_in_housing_mm", inf.ep_z_at_infinity_focus_mm}}}};
  j["field_of_view"] = {{"assumes", "the lens focused on the target's virtual image at the subject distance "
                                    "(without a target plan assumes infinity focus, c = f)"},
                        {"principal_distance_mm", r.plan.principal_distance_mm},
                        {"air", {{"horizontal_deg", L(r.plan.fov.air.horizontal_deg)}, {"vertical_deg", L(r.plan.fov.air.vertical_deg)},
                                 {"diagonal_deg", L(r.plan.fov.air.diagonal_deg)}}},
                        {"water", {{"horizontal_deg", L(r.plan.fov.water.horizontal_deg)}, {"vertical_deg", L(r.plan.fov.water.vertical_deg)},
                                   {"diagonal_deg", L(r.plan.fov.water.diagonal_deg)}}}};
  Json dof = Json::array();
  for (const auto& d : r.dof) {
    dof.push_back({{"subject_mm", d.subject_mm},
                   {"air", {{"near_mm", L(d.air.near_mm)}, {"far_mm", L(d.air.far_mm)}, {"total_mm", L(d.air.total_mm)}}},
                   {"water", {{"near_mm", L(d.water.near_mm)}, {"far_mm", L(d.water.far_mm)},
                              {"total_mm", L(d.water.total_mm)}, {"virtual_near_mm", L(d.water.virtual_near_mm)},
                              {"virtual_far_mm", L(d.water.virtual_far_mm)}}}});
  }
  j["depth_of_field"] = dof;
  j["other_port"] = planning::PlanToJson(r.other_setup, r.other_plan);
  if (r.flat) j["flat_port"] = planning::FlatToJson(r.flat->system.spec.name == in.setup.port.name ? in.setup : r.other_setup, *r.flat);
  Json angles = Json::array();
  for (const auto& a : r.angles) {
    angles.push_back({{"theta_air_deg", a.theta_air_deg}, {"theta_water_deg", L(a.theta_main_deg)},
                      {"theta_water_other_port_deg", L(a.theta_other_deg)}});
  }
  j["chief_ray_angles"] = angles;
  j["simulation"] = simulate::PredictionJson(r.prediction);
  j["simulation_other_port"] = simulate::PredictionJson(r.other_prediction);
  const std::vector<double> radii = {5.0, 10.0, simulate::ProfileRadiiMm(r.prediction.camera.sensor).back()};
  j["sweeps"] = {{"z", simulate::SweepJson(r.sweep_z, 2, radii)}, {"x", simulate::SweepJson(r.sweep_x, 0, radii)}};
  j["distortion_map"] = simulate::MapJson(r.map);
  if (in.air_calibration) j["air_calibration"] = camera::BrownToJson(camera::ToBrown(in.air_calibration->camera));
  if (in.water_calibration) j["water_calibration"] = camera::BrownToJson(camera::ToBrown(in.water_calibration->camera));
  if (r.compare) j["comparison"] = calib::CompareToJson(*r.compare, "air", "water", /*with_map=*/false);
  if (r.rig_plan) j["rig_plan"] = measure::RigPlanToJson(*r.rig_plan, in.rig->what)["rig_plan"];
  if (in.scale_bar) {
    j["scale_bar"] = measure::ScaleBarToJson(*in.scale_bar);
    j["scale_bar"]["source"] = in.scale_bar_source;
  }
  Json figs = Json::array();
  for (const auto& f : figures) {
    figs.push_back({{"id", f.id}, {"section", f.section}, {"title", f.title}, {"caption", f.caption},
                    {"png", "figures/" + f.id + ".png"}, {"svg", "figures/" + f.id + ".svg"},
                    {"data", "figures/" + f.id + ".dat"}, {"script", "figures/" + f.id + ".gp"}});
  }
  j["figures"] = figs;
  return j;
}

std::string ReportHtml(const Results& r, const std::vector<Figure>& figures,
                       const std::map<std::string, std::string>& svgs) {
  const ReportInputs& in = *r.in;
  const planning::Setup& s = in.setup;
  const planning::Plan& p = r.plan;
  const planning::TargetPlan& t = *p.target;
  const simulate::Prediction& sim = r.prediction;
  const std::string port = s.port.name, other = in.other_port.name;

  auto figs_of = [&](const std::string& section) {
    std::string out;
    for (const auto& f : figures) {
      if (f.section != section) continue;
      const auto svg = svgs.find(f.id);
      out += fmt::format(
          "<figure id=\"fig-{0}\" class=\"fig\" data-figure=\"{0}\">\n<h3>{1}</h3>\n<div class=\"plot\">\n{2}\n</div>\n"
          "<figcaption>{3}<br><span class=\"files\"><a href=\"figures/{0}.png\">PNG</a><a href=\"figures/{0}.svg\">SVG</a>"
          "<a href=\"figures/{0}.dat\">data</a><a href=\"figures/{0}.gp\">gnuplot script</a></span></figcaption>\n"
          "</figure>\n",
          f.id, Html(f.title), svg == svgs.end() ? "" : svg->second, Html(f.caption));
    }
    return out;
  };

  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += fmt::format("<title>porthole report: {} + {} behind {}</title>\n", Html(s.camera.name), Html(s.lens.name), Html(port));
  h += fmt::format("<style>{}</style>\n</head>\n<body>\n", kCss);
  h += fmt::format(
      "<header><div class=\"wrap\"><h1>{} + {} behind {}</h1>\n"
      "<p>{} {} port · water n = {:.4f} at {:g} nm · glass n = {:.4f} · target {:.0f} mm from the entrance pupil "
      "(WD {:.0f} mm) at f/{:g}</p>\n"
      "<p>Made by <code>porthole report</code> after Menna et al. 2016, <i>Sensors</i> 16(1):48. Lengths in mm, "
      "angles in degrees, distortions in µm.</p></div></header>\n<main>\n",
      Html(s.camera.name), Html(s.lens.name), Html(port), p.system.spec.KindName(), Html(s.port.material()),
      p.system.n_water, s.env.conditions.lambda_nm, p.system.n_glass, t.subject_distance_mm, t.wd_mm, p.f_number);
  h += "<nav class=\"toc\"><a href=\"#summary\">Summary</a><a href=\"#inputs\">Inputs</a><a href=\"#port\">Port and rays</a>"
       "<a href=\"#focus\">Focus and minimum WD</a><a href=\"#dof\">Depth of field</a><a href=\"#ports\">Dome vs flat</a>"
       "<a href=\"#simulate\">Predicted calibration</a>";
  if (r.compare) h += "<a href=\"#compare\">Your calibrations</a>";
  if (r.rig_plan) h += "<a href=\"#rig\">Your rig</a>";
  if (r.in->scale_bar) h += "<a href=\"#scale-bar\">Scale bar</a>";
  h += "</nav>\n";

  // Summary.
  h += "<section id=\"summary\"><h2>Summary</h2>\n<div class=\"cards\">\n";
  // A fixed-focus lens has nothing to set: whether the target is in its sharp range instead.
  const bool fixed_focus = s.lens.fixed_focus;
  if (fixed_focus) {
    h += Card("Fixed focus", t.focus.focus_distance_mm ? "sharp" : "not sharp",
              fmt::format("nothing to set: virtual image {} mm from the pupil, the lens sharp from {} mm",
                          F(t.virtual_image.d_s2ep_mm, 1), F(p.closest_d_s2ep_mm, 1)));
  } else {
    h += Card("Set the focus scale to", t.focus.focus_distance_mm ? F(*t.focus.focus_distance_mm, 0) + " mm" : "out of reach",
              fmt::format("virtual image {} mm from the pupil", F(t.virtual_image.d_s2ep_mm, 1)));
  }
  h += Card("Minimum working distance", std::isfinite(p.min_wd_mm) ? F(p.min_wd_mm, 0) + " mm" : "none in reach",
            fmt::format("closest focus {} mm from the pupil", F(p.closest_d_s2ep_mm, 1)));
  const VirtualRow& inf = r.infinity.focused;
  h += Card("Virtual image of infinity", F(inf.d_s2ep_mm, 1) + " mm",
            fmt::format("from the entrance pupil{}; VWD {} mm",
                        fixed_focus ? std::string()
                                    : ", the lens focused on it" +
                                          (inf.fd_mm ? " (focus scale " + F(*inf.fd_mm, 0) + " mm)" : std::string()),
                        F(inf.vwd_mm, 1)));
  // An unlimited total is "unlimited", and a ratio of two totals exists only when both are finite.
  auto total = [](double v) { return std::isinf(v) ? std::string("unlimited") : F(v, 0) + " mm"; };
  h += Card("Depth of field under water", total(t.water.total_mm),
            std::isfinite(t.dof_ratio_water_to_air)
                ? fmt::format("{} in air: ×{}", total(t.air.total_mm), F(t.dof_ratio_water_to_air, 2))
                : fmt::format("{} in air", total(t.air.total_mm)));
  h += Card("Field of view in water", F(p.fov.water.horizontal_deg, 1) + "°",
            fmt::format("horizontal; {}° in air; focused on the target (c = {} mm)", F(p.fov.air.horizontal_deg, 1),
                        F(p.principal_distance_mm, 2)));
  if (t.field) {
    h += Card("Corner blur", F(t.field->corner_blur_px, 1) + " px",
              fmt::format("at f/{:g}; {}", p.f_number,
                          t.field->f_number_for_sharp_corners <= s.lens.f_number_min
                              ? std::string("sharp at every f-number of the lens")
                          : t.field->f_number_for_sharp_corners <= s.lens.f_number_max
                              ? "sharp from f/" + F(t.field->f_number_for_sharp_corners, 1)
                              : fmt::format("not sharp at any f-number of the lens (needs f/{})",
                                            F(t.field->f_number_for_sharp_corners, 1))));
  }
  const simulate::FitView sim_water = sim.water_view(), sim_air = sim.air_view();
  h += Card(sim.water_fisheye ? "Focal length under water" : "Principal distance under water",
            "×" + F(sim_water.c_mm() / sim_air.c_mm(), 4),
            fmt::format("{} → {} mm (simulated)", F(sim_air.c_mm(), 3), F(sim_water.c_mm(), 3)));
  if (r.compare) {
    h += Card("Your calibrations", r.compare->significant ? "differ" : "agree",
              fmt::format("χ² = {} with {} dof, p = {}", F(r.compare->chi2, 1), r.compare->dof, G(r.compare->p_value)));
  }
  h += "</div>\n";
  // Planning's focus advice does not apply to a fixed-focus lens (no focus scale to set or pre-set).
  std::vector<std::string> advice;
  for (const auto& w : p.warnings) {
    if (fixed_focus && (w.find("focus scale") != std::string::npos || w.find("pre-focus") != std::string::npos)) continue;
    advice.push_back(w);
  }
  if (!advice.empty()) {
    h += "<h3>Advice</h3>\n<ul class=\"warnings\">\n";
    for (const auto& w : advice) h += "<li>" + Html(w) + "</li>\n";
    h += "</ul>\n";
  }
  h += "</section>\n";

  // Inputs.
  h += "<section id=\"inputs\"><h2>Inputs</h2>\n<p class=\"lead\">As given on the command line, then as resolved "
       "by porthole.</p>\n<dl class=\"inputs\">\n";
  for (const auto& [k, v] : in.echo) h += fmt::format("<dt>{}</dt><dd>{}</dd>\n", Html(k), Html(v));
  h += "</dl>\n<div class=\"scroll\">";
  const auto& ep = p.system.ep_in_housing_mm;
  h += Table("The system", {"item", "value"},
             {{"camera", Html(fmt::format("{} ({}): {} × {} px, {:g} mm pixels ({:.1f} × {:.1f} mm)", s.camera.name,
                                          s.camera.lookup.empty() ? "built in" : s.camera.lookup,
                                          s.camera.sensor.width_px, s.camera.sensor.height_px, s.camera.sensor.pixel_pitch_mm,
                                          s.camera.SensorWidthMm(), s.camera.SensorHeightMm()))},
              {"lens", Html(fmt::format("{} ({}): f = {:g} mm, f/{:g}–f/{:g}, closest focus {:g} mm{}{}", s.lens.name,
                                        s.lens.lookup.empty() ? "built in" : s.lens.lookup,
                                        s.lens.focal_length_mm, s.lens.f_number_min, s.lens.f_number_max,
                                        s.lens.min_focus_mm, s.lens.min_focus_assumed ? " (assumed)" : "",
                                        s.lens.pupil_estimated ? " (pupil assumed)" : ""))},
              {"port", Html(fmt::format("{} — {}", port, s.port.description))},
              {"compared with", Html(fmt::format("{} — {}", other, in.other_port.description))},
              {"water", Html(fmt::format("{}: n = {:.5f} ({:g} °C, {:g} ‰, {:g} dbar, {:g} nm)",
                                         s.env.water_index ? "fixed index" : s.env.water, p.system.n_water,
                                         s.env.conditions.temperature_c, s.env.conditions.salinity_psu,
                                         s.env.conditions.pressure_dbar, s.env.conditions.lambda_nm))},
              {"entrance pupil", fmt::format("({:.2f}, {:.2f}, {:.2f}) mm in the housing frame at the target's focus",
                                             ep.x(), ep.y(), ep.z())},
              {"aperture, circle of confusion", Html(fmt::format("f/{:g}, {:.4f} mm ({})", p.f_number, p.coc_mm, p.coc_source))}});
  h += "</div></section>\n";

  // The port.
  h += "<section id=\"port\"><h2>The port and its rays</h2>\n<p class=\"lead\">A dome is a diverging lens: the camera "
       "focuses not on the subject but on its virtual image, close in front of the glass.</p>\n" + figs_of("port") +
       "</section>\n";

  // Focus.
  std::vector<std::vector<std::string>> rows;
  for (const auto& v : r.table) {
    rows.push_back({F(v.wd_mm, 0), F(v.d_s2ep_mm, 1), F(v.vwd_mm, 1), F(v.d_s2ep_real_mm, 2), F(v.magnification, 4),
                    v.fd_mm ? F(*v.fd_mm, 1) : fmt::format("closer than the lens (+{:.2f} dpt)", v.closeup_dioptre)});
  }
  h += "<section id=\"focus\"><h2>Where to focus, and how close</h2>\n<div class=\"scroll\">";
  h += Table("Virtual image against working distance (the paper's Table 5 distances); D<sub>S2EP</sub> from the "
             "entrance pupil with the lens focused on that image",
             {"WD <span class=\"unit\">mm</span>", "D<sub>S2EP</sub> <span class=\"unit\">mm</span>",
              "VWD <span class=\"unit\">mm</span>", fmt::format("real rays f/{:g} <span class=\"unit\">mm</span>", p.f_number),
              "magnification", "focus scale FD <span class=\"unit\">mm</span>"},
             rows);
  rows.clear();
  for (const auto& c : p.closeup) rows.push_back({fmt::format("+{:g}", c.dioptre), F(c.min_wd_mm, 0), F(c.max_wd_mm, 0)});
  h += Table("Close-up lenses", {"dioptres", "WD from <span class=\"unit\">mm</span>", "WD to <span class=\"unit\">mm</span>"}, rows);
  h += "</div>\n" + figs_of("focus") + "</section>\n";

  // Depth of field.
  h += "<section id=\"dof\"><h2>Depth of field and field curvature</h2>\n<div class=\"scroll\">";
  h += Table(fmt::format("Focused {:.0f} mm from the entrance pupil, f/{:g}", t.subject_distance_mm, p.f_number),
             {"", "focus <span class=\"unit\">mm</span>", "near <span class=\"unit\">mm</span>",
              "far <span class=\"unit\">mm</span>", "total <span class=\"unit\">mm</span>", "focus scale <span class=\"unit\">mm</span>"},
             {{"in air", F(t.air.focus_mm, 0), F(t.air.near_mm, 0), F(t.air.far_mm, 0), F(t.air.total_mm, 0),
               t.air.focus_distance_mm ? F(*t.air.focus_distance_mm, 0) : "–"},
              {"under water, virtual image", F(t.water.virtual_focus_mm, 1), F(t.water.virtual_near_mm, 1),
               F(t.water.virtual_far_mm, 1), F(t.water.virtual_total_mm, 1), ""},
              {"under water, real objects", F(t.water.focus_mm, 0), F(t.water.near_mm, 0), F(t.water.far_mm, 0),
               F(t.water.total_mm, 0), t.focus.focus_distance_mm ? F(*t.focus.focus_distance_mm, 0) : "–"}});
  h += "</div>\n" + figs_of("dof") + "</section>\n";

  // Dome vs flat.
  const auto fov_row = [](const std::string& name, const planning::Fov& f) {
    return std::vector<std::string>{Html(name), F(f.horizontal_deg, 1), F(f.vertical_deg, 1), F(f.diagonal_deg, 1)};
  };
  h += "<section id=\"ports\"><h2>Dome against flat port</h2>\n<div class=\"scroll\">";
  h += Table(fmt::format("Field of view, full angles, the lens focused on the target (c = {} mm; at infinity "
                         "focus c = f and the field is wider)", F(p.principal_distance_mm, 2)),
             {"", "horizontal <span class=\"unit\">°</span>", "vertical <span class=\"unit\">°</span>",
              "diagonal <span class=\"unit\">°</span>"},
             {fov_row("in air", p.fov.air), fov_row("under water, " + port, p.fov.water),
              fov_row("under water, " + other, r.other_plan.fov.water)});
  if (r.flat) {
    const auto& fl = *r.flat;
    h += Table(fmt::format("The flat port {} (Section 2.2)", Html(fl.system.spec.name)), {"quantity", "value"},
               {{"apparent focal length", F(fl.apparent_focal_length_mm, 2) + " mm (+" + F(fl.focal_length_increase_pct, 1) + " %)"},
                {"critical angle, widest possible field", F(fl.critical_angle_deg, 1) + "°, " + F(fl.max_fov_deg, 1) + "°"},
                {"lateral colour at the corner", F(fl.lateral_colour_corner_px, 1) + " px (F − C lines)"}});
  }
  h += "</div>\n" + figs_of("ports") + "</section>\n";

  // Simulation.
  std::vector<std::pair<std::string, camera::BrownParams>> cols = {
      {"air (fit)", sim.air.params}, {"water (fit)", sim.water.params}, {"change", sim.change}};
  std::vector<std::pair<std::string, double>> rms = {{"RMS residual <span class=\"unit\">µm</span>", sim.air.rms_um},
                                                     {"", sim.water.rms_um}, {"", NAN}};
  if (sim.predicted_water) {
    cols.push_back({"your in-air calibration", sim.camera.lens});
    cols.push_back({"water, predicted", *sim.predicted_water});
    rms.push_back({"", NAN});
    rms.push_back({"", NAN});
  }
  h += "<section id=\"simulate\"><h2>The underwater calibration to expect</h2>\n<p class=\"lead\">";
  h += Html(fmt::format("Rays from a {} × {} image grid traced through the port onto {} at {} mm; the central "
                        "{} model fitted to them as a self-calibration would (docs/simulate.md). Lens focused "
                        "under water on an object {:.0f} mm from its pupil (focus scale {:.1f} mm), c = {:.3f} mm.",
                        sim.options.grid_cols, sim.options.grid_rows, sim.water_fisheye ? "spheres" : "planes",
                        fmt::join(simulate::Distances(sim.options), ", "), sim_water.model_name(),
                        sim.object_distance_mm, sim.focus.focus_distance_mm.value_or(NAN), sim.camera.lens.c_mm));
  h += "</p>\n<div class=\"scroll\">";
  if (sim.water_fisheye) {
    // The fitted fisheye model, parameter by parameter (pixels; the model's own units).
    const camera::ModelInfo& info = sim.water_fisheye->camera.info();
    rows.clear();
    for (int i = 0; i < info.num_params; ++i) {
      const double a = sim.air_fisheye->camera.params[i], w = sim.water_fisheye->camera.params[i];
      rows.push_back({fmt::format("{} <span class=\"unit\">{}</span>", Html(std::string(info.params[i].name)), Html(std::string(info.params[i].unit))),
                      G(a), G(w), G(w - a)});
    }
    rows.push_back({"RMS residual <span class=\"unit\">px</span>", F(sim.air_fisheye->rms_px, 4),
                    F(sim.water_fisheye->rms_px, 4), ""});
    h += Table(fmt::format("{} parameters fitted (the lens is an ideal {} fisheye)", Html(std::string(info.name)),
                           camera::ProjectionName(sim.lens_projection)),
               {"parameter", "air (fit)", "water (fit)", "change"}, rows);
  } else {
    h += BrownTable("Brown parameters (correction form, image mm)", cols, rms);
  }
  rows.clear();
  const double corner = simulate::ProfileRadiiMm(sim.camera.sensor).back();
  for (const auto& row : r.sweep_z) {
    const simulate::FitView w = row.water_view(), a = row.air_view();
    rows.push_back({F(row.offset_mm, 1), F(w.c_mm() - a.c_mm(), 4), F(w.c_mm() / a.c_mm(), 5),
                    F(1000 * (w.RadialProfileMm(10) - a.RadialProfileMm(10)), 2),
                    F(1000 * (w.RadialProfileMm(corner) - a.RadialProfileMm(corner)), 2), F(w.rms_um(), 3)});
  }
  h += Table("Pupil moved along z (toward the glass): the change water − air",
             {"offset <span class=\"unit\">mm</span>", "Δc <span class=\"unit\">mm</span>", "c water/air",
              "Δδr at 10 mm <span class=\"unit\">µm</span>",
              fmt::format("Δδr at {:.1f} mm <span class=\"unit\">µm</span>", corner), "water RMS <span class=\"unit\">µm</span>"},
             rows);
  h += "</div>\n" + figs_of("simulate") + "</section>\n";

  // Comparison.
  if (r.compare) {
    const auto& c = *r.compare;
    rows.clear();
    for (const auto& row : c.rows) {
      const int i = row.index;
      if (!row.adjusted_a && !row.adjusted_b && row.a == 0 && row.b == 0) continue;  // in neither
      const auto& info = camera::kBrownParamInfo[i];
      auto val = [i](bool adj, double v, double sg) {
        return adj ? Param(i, v) + " ± " + G(sg) : (v != 0 ? Param(i, v) + " (fixed)" : std::string("–"));
      };
      const double pred = sim.predicted_water ? sim.predicted_water->ToArray()[i] : NAN;
      rows.push_back({fmt::format("{} <span class=\"unit\">{}</span>", info.name, info.unit),
                      val(row.adjusted_a, row.a, row.sigma_a), val(row.adjusted_b, row.b, row.sigma_b),
                      Param(i, row.diff), std::isfinite(row.z) ? F(row.z, 1) : "",
                      i <= camera::kBrownP2 && std::isfinite(pred) ? Param(i, pred) : ""});
    }
    h += "<section id=\"compare\"><h2>Your calibrations: in air and under water</h2>\n<div class=\"scroll\">";
    h += Table("Parameters with their standard deviations (the paper's Table 6)",
               {"parameter", "air ± σ", "water ± σ", "water − air", "z", "water, predicted"}, rows);
    h += "</div>\n<p>" +
         Html(std::isfinite(c.chi2)
                  ? fmt::format("χ² = {:.2f} with {} degrees of freedom (the parameters both calibrations "
                                "adjusted), p = {:.3g}: the calibrations {} (covariance: {}).",
                                c.chi2, c.dof, c.p_value, c.significant ? "differ significantly" : "do not differ significantly",
                                c.covariance_note)
                  : "χ² not computed: " + c.covariance_note) +
         (c.left_out_note.empty() ? std::string() : " " + Html(c.left_out_note) + ".") +
         "</p>\n" + figs_of("compare") + "</section>\n";
  }

  // The rig: lengths planned over the common field.
  if (r.rig_plan) {
    const measure::RigPlan& p = *r.rig_plan;
    rows.clear();
    for (const auto& row : p.rows) {
      rows.push_back({F(row.range_mm / 1000, 1), F(row.common_width_mm / 1000, 2) + " × " + F(row.common_height_mm / 1000, 2),
                      std::to_string(row.n_lengths), G(row.sigma_median_mm), G(row.sigma_p90_mm),
                      F(row.sigma_median_percent, 3),
                      p.central ? G(row.central_abs_median_mm) + " / " + G(row.central_abs_max_mm) : std::string("–")});
    }
    h += "<section id=\"rig\"><h2>Your rig: lengths before the dive</h2>\n<p>" +
         Html(fmt::format("{}: a {:g} mm length in {} directions over the field every camera sees, each end's image "
                          "points with σ = {:g} px; σ from {}.",
                          r.in->rig->what, p.length_mm, p.orientations, p.sigma_px, p.calibration_sigma)) +
         (p.central ? Html(fmt::format(" Central model: each camera's lens without refraction, calibrated with the "
                                       "rig at {:.0f} mm (RMS {:.3f} px), as most tools do; its error is systematic.",
                                       p.central_fit_range_mm, p.central_fit_rms_px))
                    : std::string()) +
         "</p>\n<div class=\"scroll\">";
    h += Table("The σ of a length against range (the plan's JSON has every number)",
               {"range <span class=\"unit\">m</span>", "common field <span class=\"unit\">m</span>", "lengths",
                "σ median <span class=\"unit\">mm</span>", "σ 90 % <span class=\"unit\">mm</span>",
                "σ median <span class=\"unit\">%</span>",
                "central |error| median / max <span class=\"unit\">mm</span>"},
               rows);
    h += "</div>\n";
    for (const auto& n : p.notes) h += "<p>" + Html(n) + "</p>\n";
    h += figs_of("rig") + "</section>\n";
  }
  // The scale bar after a dive.
  if (r.in->scale_bar) {
    const measure::ScaleBarCheck& c = *r.in->scale_bar;
    rows.clear();
    for (const auto& b : c.by_range) {
      rows.push_back({F(b.range_min_mm / 1000, 1) + "–" + F(b.range_max_mm / 1000, 1), std::to_string(b.n),
                      G(b.mean_error_mm), G(b.rms_error_mm), G(b.rms_sigma_mm)});
    }
    h += "<section id=\"scale-bar\"><h2>Scale bar</h2>\n<p>" +
         Html(fmt::format("{}: the bar between points {} and {}, {:g} mm long, in {} frames. Mean error {:+.3f} mm "
                          "({:+.3f} %) ± {:.3f} mm, z = {}: {}",
                          r.in->scale_bar_source, c.bar.id_a, c.bar.id_b, c.bar.length_mm, c.rows.size(),
                          c.mean_error_mm, c.mean_error_percent, c.sigma_mean_mm,
                          std::isfinite(c.z) ? fmt::format("{:.2f}", c.z) : std::string("unknown: no sigma"), c.verdict)) +
         "</p>\n<div class=\"scroll\">";
    h += Table("The error against range",
               {"range <span class=\"unit\">m</span>", "frames", "mean error <span class=\"unit\">mm</span>",
                "RMS error <span class=\"unit\">mm</span>", "RMS σ <span class=\"unit\">mm</span>"},
               rows);
    h += "</div>\n" + figs_of("scale-bar") + "</section>\n";
  }

  h += "</main>\n<footer>Every number on this page is in <a href=\"report.json\">report.json</a>; each figure's data file "
       "and gnuplot script are in <code>figures/</code> (run <code>gnuplot all.gp</code> there to remake them all). "
       "porthole: optics and geometry of underwater camera housings.</footer>\n</body>\n</html>\n";
  return h;
}

}  // namespace porthole::report
