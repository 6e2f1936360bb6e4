// `porthole assemble`: the camera flange, the housing flange, the dome's sphere fits and the lens's
// entrance pupil put together in the housing frame (the paper's Section 3.4 and Table 4), written
// as an as-built port TOML for virtual-image, plan and simulate. Input formats: docs/fit.md.
#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/fit/assembly.h"
#include "porthole/catalogue/presets.h"

namespace porthole::cli {
namespace {

Eigen::Vector3d Hint(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

}  // namespace

void RegisterAssemble(CLI::App& app) {
  struct Options {
    std::string camera_flange = "0,0,0,0,0,1", housing_flange, outer, inner, dome_rear;
    bool dome_rear_flip = false, dome_centered = false, json = false, force = false;
    std::vector<double> x_hint{1, 0, 0}, dome_x_hint{1, 0, 0};
    std::string lens, focus;
    std::optional<double> pupil_offset_mm;
    std::string material = "n-bk7", name = "as-built", output;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "assemble",
      "Put flanges (photogrammetric survey), dome spheres (scan fits) and the lens's entrance "
      "pupil into the housing frame (paper Table 4); write the as-built port TOML");
  const char* plane = "X,Y,Z,NX,NY,NZ or a 'porthole fit circle|plane --json' file";
  cmd->add_option("--camera-flange", o->camera_flange,
                  fmt::format("Camera flange centre and normal, survey frame: {}", plane))
      ->capture_default_str();
  cmd->add_option("--housing-flange", o->housing_flange,
                  fmt::format("Housing flange centre and normal, survey frame: {}", plane))
      ->required();
  cmd->add_option("--outer", o->outer,
                  "Outer dome sphere X,Y,Z,R or a 'porthole fit sphere --json' file")
      ->required();
  cmd->add_option("--inner", o->inner,
                  "Inner dome sphere X,Y,Z,R or a 'porthole fit sphere --json' file")
      ->required();
  cmd->add_option("--dome-rear", o->dome_rear,
                  fmt::format("Dome rear face in the scan frame, normal toward the apex: {}. "
                              "Without it the spheres are in the survey frame",
                              plane));
  cmd->add_flag("--dome-rear-flip", o->dome_rear_flip, "Reverse the --dome-rear normal");
  cmd->add_flag("--dome-centered", o->dome_centered,
                "Centre the dome on its rear face (outer centre projected on it), as the paper");
  cmd->add_option("--x-hint", o->x_hint, "Survey direction that becomes housing +X")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  cmd->add_option("--dome-x-hint", o->dome_x_hint, "Scan direction that becomes housing +X")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  CLI::Option* lens = cmd->add_option("--lens", o->lens, "Lens preset or TOML (pupil table)");
  cmd->add_option("--focus", o->focus, "Focus-scale distance FD for --lens, mm or 'inf'")
      ->needs(lens);
  cmd->add_option("--pupil-offset", o->pupil_offset_mm,
                  "Entrance pupil ahead of the camera flange D_EP2F, mm (instead of --lens)")
      ->excludes(lens);
  cmd->add_option("--material", o->material, "Dome glass (see 'porthole materials')")
      ->capture_default_str();
  cmd->add_option("--name", o->name, "Port name in the TOML")->capture_default_str();
  cmd->add_option("-o,--output", o->output, "Write the as-built port TOML here");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  AddForceFlag(cmd, &o->force);

  cmd->callback([o, cmd] {
    const OutputRules rules{.force = o->force, .inputs = InputFiles(cmd, {"--output"})};
    if (!o->output.empty()) CheckOutput(o->output, "--output", rules);
    fit::AssemblyInput in;
    in.camera_flange = fit::ParsePlaneSpec(o->camera_flange, "--camera-flange");
    in.housing_flange = fit::ParsePlaneSpec(o->housing_flange, "--housing-flange");
    in.outer = fit::ParseSphereSpec(o->outer, "--outer");
    in.inner = fit::ParseSphereSpec(o->inner, "--inner");
    if (!o->dome_rear.empty()) {
      in.dome_rear = fit::ParsePlaneSpec(o->dome_rear, "--dome-rear");
      if (o->dome_rear_flip) in.dome_rear->normal *= -1;
    } else if (o->dome_rear_flip) {
      throw InvalidInput("--dome-rear-flip", "needs --dome-rear");
    }
    in.dome_centered = o->dome_centered;
    in.survey_x_hint = Hint(o->x_hint);
    in.scan_x_hint = Hint(o->dome_x_hint);
    double focus_mm = NAN;
    if (!o->lens.empty()) {
      if (o->focus.empty()) throw InvalidInput("--focus", "required with --lens");
      focus_mm = ParseLengthList({o->focus}, "--focus")[0];
      const lens::LensSpec spec = catalogue::LoadLens(o->lens);
      try {
        in.pupil_to_flange_mm = spec.PupilToFlangeMm(focus_mm);
      } catch (const InvalidInput& e) {  // the library names it "focus"
        throw InvalidInput("--focus", std::string(e.what()).substr(e.field().size() + 2));
      }
    } else if (o->pupil_offset_mm) {
      in.pupil_to_flange_mm = *o->pupil_offset_mm;
    } else {
      throw InvalidInput("--lens", "give --lens NAME --focus MM, or --pupil-offset MM");
    }
    const fit::HousingAssembly a = fit::AssembleHousing(in);
    const std::string toml = catalogue::PortToToml(fit::AsBuiltPort(a, o->name, o->material));

    Json j = fit::AssemblyToJson(a, in.pupil_to_flange_mm);
    j["lens"] = o->lens.empty() ? Json(nullptr) : Json(o->lens);
    j["focus_mm"] = Length(focus_mm);
    j["port_file"] = o->output.empty() ? Json(nullptr) : Json(o->output);
    std::string text = o->json ? j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n" : a.Report();
    if (!o->json && !o->output.empty()) text += "as-built port written to " + o->output + "\n";
    if (!o->output.empty()) WriteOutput(o->output, toml, "--output", rules);
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
