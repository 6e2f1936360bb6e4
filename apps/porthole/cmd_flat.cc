// `porthole flat`: what a flat port does to the camera behind it (the paper's Section 2.2): field
// of view in water against air (thin port and real geometry by ray trace), the maximum field of
// view, the distortion factor of Eq. 1 against angle, the apparent focal length, lateral colour.
#include <fmt/format.h>

#include <cmath>

#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "porthole/planning/json.h"

namespace porthole::cli {

namespace {

// A number for the text: fixed decimals, or the word for what it is — "infinity" (an object at
// infinity), "n/a" (not applicable: the ray does not pass) — never "inf", "nan" or "-".
std::string Val(double v, int decimals) {
  if (std::isinf(v)) return v > 0 ? "infinity" : "-infinity";
  if (std::isnan(v)) return "n/a";
  return Fixed(v, decimals);
}

struct FlatCliOptions {
  PortOptions port;
  WaterOptions water;
  CameraLensOptions camera;
  std::string wd = "inf";
  planning::FlatOptions flat;
  bool json = false;
};

void RunFlat(const FlatCliOptions* o) {
  const planning::Setup setup = o->camera.ToHoused(o->port, o->water);
  planning::FlatOptions fo = o->flat;
  fo.wd_mm = ParseLengthList({o->wd}, "--wd").front();
  const planning::FlatAnalysis a = planning::AnalyseFlat(setup, fo);

  if (o->json) {
    fmt::print("{}\n", planning::FlatToJson(setup, a).dump(2));
    return;
  }
  auto fov = [](const planning::Fov& f) {
    return fmt::format("{:>7} {:>7} {:>7}", Val(f.horizontal_deg, 1), Val(f.vertical_deg, 1),
                       Val(f.diagonal_deg, 1));
  };
  std::string t = fmt::format("{} + {} behind {} (water n = {:.4f}, glass n = {:.4f}), c = {:.2f} mm\n\n",
                              setup.camera.name, setup.lens.name, a.system.spec.name, a.n_water, a.n_glass,
                              a.principal_distance_mm);
  t.insert(t.size() - 1, catalogue::DescribeCameraAndLens(setup.camera, setup.lens));
  t += fmt::format("{:<34} {:>7} {:>7} {:>7}\n", "field of view, deg", "horiz.", "vert.", "diag.");
  t += fmt::format("{:<34} {}\n", "in air", fov(a.air));
  t += fmt::format("{:<34} {}\n", "in water, thin port at the pupil", fov(a.water_thin));
  t += fmt::format("{:<34} {}\n", "in water, traced real port", fov(a.water_traced));
  t += fmt::format("\nmaximum field of view            {:.2f} deg (critical angle {:.2f} deg)\n", a.max_fov_deg,
                   a.critical_angle_deg);
  t += fmt::format("apparent focal length            {:.2f} mm (+{:.1f} %)\n", a.apparent_focal_length_mm,
                   a.focal_length_increase_pct);
  t += std::isfinite(a.wd_mm)
           ? fmt::format("scene width at WD {} mm          thin {} mm, traced {} mm\n", Val(a.wd_mm, 0),
                         Val(a.coverage_thin_mm, 0), Val(a.coverage_traced_mm, 0))
           : "scene width                      unlimited (focused at infinity; give --wd for a width)\n";
  t += fmt::format("lateral colour {:g}-{:g} nm     n_w {:.5f} / {:.5f}; {}\n\n",
                   fo.lambda_blue_nm, fo.lambda_red_nm, a.n_water_blue, a.n_water_red,
                   std::isfinite(a.lateral_colour_corner_px)
                       ? Val(a.lateral_colour_corner_px, 2) + " px at the corner"
                       : std::string("not applicable at the corner (its ray does not reach the water)"));
  t += fmt::format("{:>8} {:>8} {:>10} {:>10} {:>10} {:>12} {:>10}\n", "air deg", "water", "D (Eq. 1)", "D traced",
                   "radius mm", "distort. px", "colour px");
  for (const auto& r : a.rows) {
    t += fmt::format("{:>8} {:>8} {:>10} {:>10} {:>10} {:>12} {:>10}\n", Val(r.theta_air_deg, 1),
                     Val(r.theta_water_deg, 2), Val(r.distortion_factor, 5), Val(r.distortion_factor_traced, 5),
                     Val(r.image_radius_mm, 3), Val(r.distortion_px, 1), Val(r.lateral_colour_px, 2));
  }
  t += "\n";
  // The plausibility warnings (core/plausible.h) went to stderr in the CLI's words; the advice here.
  for (const auto& w : a.warnings) {
    if (w.find(kImplausiblePhrase) == std::string::npos) t += "! " + w + "\n";
  }
  fmt::print("{}", t);
}

}  // namespace

void RegisterFlat(CLI::App& app) {
  auto o = std::make_shared<FlatCliOptions>();
  o->port.port = "flat-acrylic-10mm";
  CLI::App* cmd = app.add_subcommand(
      "flat", "Flat port: field of view in water vs air (thin and traced), maximum field of view, Eq. 1 "
              "distortion factor against angle, apparent focal length, lateral colour in pixels");
  o->camera.Add(cmd);
  o->port.Add(cmd);
  o->water.Add(cmd);
  cmd->add_option("--wd", o->wd, "Working distance for focus and scene coverage, mm ('inf' allowed)")
      ->capture_default_str();
  cmd->add_option("--step", o->flat.step_deg, "Table step in the air angle, deg")->capture_default_str();
  cmd->add_option("--lambda-blue", o->flat.lambda_blue_nm, "Blue wavelength for lateral colour, nm")
      ->capture_default_str();
  cmd->add_option("--lambda-red", o->flat.lambda_red_nm, "Red wavelength for lateral colour, nm")
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  cmd->callback([o] {
    WithFieldNames({PORTHOLE_CAMERA_FLAGS, {"wd_mm", "--wd"}, {"step_deg", "--step"},
                    {"lambda_blue_nm", "--lambda-blue"}, {"lambda_red_nm", "--lambda-red"}},
                   [&] { RunFlat(o.get()); });
  });
}


}  // namespace porthole::cli
