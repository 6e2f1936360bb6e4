// `porthole virtual-image`: where a port forms the virtual image of objects at a list of working
// distances (the paper's Table 5 for any port, water and wavelength), paraxially and with real
// rays, and the port's focal lengths.
#include <fmt/format.h>

#include <cmath>

#include "commands.h"
#include "common.h"
#include "porthole/ports/virtual_image.h"

namespace porthole::cli {
namespace {

// An astigmatic port (a cylinder) images across one axis and along the other at two focal lines;
// shown where they lie more than 1 % apart (a decentred dome's 0.1 mm at 282 mm is not shown).
bool Astigmatic(const ports::VirtualImage& v) {
  return std::abs(v.focal_line_far_d_s2ep_mm - v.focal_line_near_d_s2ep_mm) > 0.01 * std::abs(v.focal_line_near_d_s2ep_mm);
}

// A focal line's distance from the pupil: mm, or the word at infinity (a flat section's line).
std::string FocalLine(double d_mm) { return std::isinf(d_mm) ? "infinity" : Fixed(d_mm, 1); }
std::string FocalLineAt(double d_mm) { return std::isinf(d_mm) ? "infinity" : Fixed(d_mm, 1) + " mm"; }

}  // namespace


void RegisterVirtualImage(CLI::App& app) {
  struct Options {
    PortOptions port;
    WaterOptions water;
    std::vector<std::string> wd = {"200", "300", "400", "500", "750", "1000", "3000", "5000", "10000", "inf"};
    double aperture_height_mm = 1.5;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "virtual-image",
      "Virtual image of objects in the water: distance from the entrance pupil (D_S2EP) and from the "
      "port's outer vertex (VWD) against working distance WD, paraxial and by real rays");
  o->port.Add(cmd);
  o->water.Add(cmd);
  cmd->add_option("--wd", o->wd, "Working distances (object to outer vertex), mm; 'inf' allowed")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--aperture-height", o->aperture_height_mm,
                  "Height in the entrance pupil of the real rays, mm (1.5 = 24 mm lens at f/8)")
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON output for scripts");

  cmd->callback([o] {
    const std::vector<double> wds = ParseLengthList(o->wd, "--wd");
    const ports::Environment env = o->water.ToEnvironment();
    const ports::PortSystem sys = ports::MakeSystem(o->port.Spec(), env, o->port.Ep());
    const ports::FocalProperties focal = ports::ParaxialFocal(sys);

    Json rows = Json::array();
    std::string table = fmt::format("{:>9} {:>11} {:>9} {:>13} {:>10} {:>11} {:>9}\n", "WD mm", "D_S2EP mm",
                                    "VWD mm", "real D_S2EP", "real VWD", "sph. ab. mm", "magnif.");
    std::string astigmatism;  // a cylinder's two focal lines
    for (double wd : wds) {
      const ports::VirtualImage par = ports::ParaxialVirtualImage(sys, wd);
      const auto real = ports::RealRayVirtualImage(sys, wd, o->aperture_height_mm);
      const double nan = std::nan("");
      const double real_d = real ? real->d_s2ep_mm : nan, real_v = real ? real->vwd_mm : nan;
      rows.push_back({{"wd_mm", Length(wd)},
                      {"d_s2ep_mm", Length(par.d_s2ep_mm)},
                      {"vwd_mm", Length(par.vwd_mm)},
                      {"d_s2ep_real_mm", Length(real_d)},
                      {"vwd_real_mm", Length(real_v)},
                      {"spherical_aberration_mm", Length(real_d - par.d_s2ep_mm)},
                      {"image_offset_real_mm", Length(real ? real->lateral_offset_mm : nan)},
                      {"focal_line_near_d_s2ep_mm", Length(par.focal_line_near_d_s2ep_mm)},
                      {"focal_line_far_d_s2ep_mm", Length(par.focal_line_far_d_s2ep_mm)},
                      {"magnification", par.magnification}});
      if (Astigmatic(par)) {
        astigmatism += fmt::format("{:>9} {:>11} {:>11}\n", Fixed(wd, 0), FocalLine(par.focal_line_near_d_s2ep_mm),
                                   FocalLine(par.focal_line_far_d_s2ep_mm));
      }
      table += fmt::format("{:>9} {:>11} {:>9} {:>13} {:>10} {:>11} {:>9}\n", Fixed(wd, 0), Fixed(par.d_s2ep_mm, 1),
                           Fixed(par.vwd_mm, 1), Fixed(real_d, 2), Fixed(real_v, 2),
                           Fixed(real_d - par.d_s2ep_mm, 3), Fixed(par.magnification, 4));
    }
    Json focal_json = {{"power_per_m", focal.power_per_mm * 1000},
                       {"efl_air_mm", Length(focal.efl_mm)},
                       {"efl_water_mm", Length(focal.efl_water_mm)},
                       {"back_focal_mm", Length(focal.back_focal_mm)},
                       {"front_focal_mm", Length(focal.front_focal_mm)}};
    if (o->json) {
      Json out = DescribeSystem(sys, env);
      out["aperture_height_mm"] = o->aperture_height_mm;
      out["focal"] = focal_json;
      out["rows"] = rows;
      fmt::print("{}\n", out.dump(2));
      return;
    }
    std::string text = DescribeSystemLine(sys, env) + "\n";
    text += fmt::format("port focal length {} mm in air, {} mm in water; real rays at {:g} mm pupil height\n\n",
                        Fixed(focal.efl_mm, 1), Fixed(focal.efl_water_mm, 1), o->aperture_height_mm);
    text += table;
    if (!astigmatism.empty()) {
      text += fmt::format("\nThis {} is astigmatic: it images across one axis and along the other at two focal lines. "
                          "D_S2EP above is the\nleast-squares image; the two focal lines, from the entrance pupil:\n",
                          sys.spec.KindName());
      text += fmt::format("{:>9} {:>11} {:>11}\n", "WD mm", "nearer mm", "farther mm") + astigmatism;
    }
    // A curved port (ports::PortSpec::IsCurved) images infinity at a finite distance.
    const ports::VirtualImage at_inf = ports::ParaxialVirtualImage(sys, std::numeric_limits<double>::infinity());
    if (sys.spec.IsCurved() && std::isfinite(at_inf.d_s2ep_mm)) {
      // An astigmatic port's least-squares image, with its two focal lines.
      const bool astigmatic = Astigmatic(at_inf);
      text += fmt::format("\nFocus on the virtual image, not on the object: behind this {} even infinity is "
                          "imaged {} mm from the entrance pupil{}.\n",
                          sys.spec.KindName(), Fixed(at_inf.d_s2ep_mm, 1),
                          astigmatic ? fmt::format(" (its focal lines at {} and {})",
                                                   FocalLineAt(at_inf.focal_line_near_d_s2ep_mm),
                                                   FocalLineAt(at_inf.focal_line_far_d_s2ep_mm))
                                     : "");
    }
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
