// `porthole report`: everything the paper shows about one camera–lens–port–water system, as
// figures (gnuplot, PNG and SVG, with their data and scripts), one self-contained index.html and
// report.json, written whole into --out or not at all (docs/report.md).
#include <fmt/format.h>

#include "calibration_check.h"
#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "porthole/calib/result_json.h"
#include "porthole/interop/interop.h"
#include "porthole/core/input.h"
#include "porthole/catalogue/presets.h"
#include "porthole/measure/measure.h"
#include "porthole/measure/rig_model.h"
#include "porthole/report/report.h"

namespace porthole::cli {

void RegisterReport(CLI::App& app) {
  struct Options {
    CameraLensOptions camera;
    std::string port = "nimar-ni320", other_port;
    WaterOptions water;
    double subject_distance_mm = 1000;
    std::optional<double> aperture;  // unset: f/8, or the nearest the lens has
    std::optional<double> coc_mm;
    std::string air_calibration, water_calibration;
    double calibration_pitch_mm = 0;
    std::string rig, scale_bar_check;  // issue 27
    measure::RigPlanOptions rig_plan;
    std::string out;
    bool force = false;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "report", "Figures and one HTML page of a camera-lens-port-water system: port and rays, virtual image "
                "and focus, minimum WD, depth of field, field curvature, dome vs flat, predicted calibration, "
                "tolerances, distortion maps, and your calibrations compared");
  o->camera.Add(cmd);
  cmd->add_option("--port", o->port, "Port: a preset name ('porthole presets') or a TOML file")
      ->capture_default_str()->group("Port");
  cmd->add_option("--compare-port", o->other_port,
                  "The port to compare with (default: flat-acrylic-10mm for a dome; for a flat port nimar-ni320-nominal, or the first larger generic dome the lens can focus through)")
      ->group("Port");
  o->water.Add(cmd);
  cmd->add_option("--subject-distance", o->subject_distance_mm, "Target: subject to entrance pupil, mm")
      ->capture_default_str();
  cmd->add_option("--aperture", o->aperture,
                  "f-number N (default: f/8, or the nearest the lens has: a fixed-aperture lens its own)");
  cmd->add_option("--coc", o->coc_mm, "Circle of confusion, mm (default: 2 pixel pitches)");
  cmd->add_option("--air-calibration", o->air_calibration,
                  "In-air calibration of the camera in its housing: porthole JSON, OpenCV YAML, COLMAP, mrcal or "
                  "Metashape XML (a pixel model is refit to Brown)")
      ->group("Calibrations");
  cmd->add_option("--water-calibration", o->water_calibration,
                  "Underwater calibration (needs --air-calibration): adds the comparison, Figs. 14 and 15")
      ->group("Calibrations");
  const std::string rig_group = "Rig and scale bar";
  cmd->add_option("--rig", o->rig,
                  "A rig calibration JSON (calibrate with one --images/--detections per camera): adds 'Your rig', "
                  "the sigma of a length over the common field against range and a central model's error "
                  "(as porthole plan --rig)")
      ->group(rig_group);
  cmd->add_option("--rig-sigma-px", o->rig_plan.sigma_px, "Rig: the image points' sigma, px")
      ->capture_default_str()->group(rig_group);
  cmd->add_option("--rig-length", o->rig_plan.length_mm, "Rig: the length to plan for (e.g. a fish), mm")
      ->capture_default_str()->group(rig_group);
  cmd->add_option("--scale-bar-check", o->scale_bar_check,
                  "The JSON of 'porthole measure --scale-bar A,B,LENGTH --json' (or its --out): adds 'Scale bar', "
                  "the length error against range and position in the image")
      ->group(rig_group);
  cmd->add_option("--out", o->out, "Directory to write the report into")->required();
  cmd->add_flag("--force", o->force, "Replace an existing report in --out");
  cmd->add_flag("--json", o->json, "Print the summary (page, report.json, figures, timings) as JSON");

  cmd->callback([o, cmd] {
    report::ReportInputs in;
    in.setup = WithFieldNames({PORTHOLE_CAMERA_FLAGS}, [&] {
      return HousedWithCalibrationPitch(o->camera, PortOptions{o->port, {}}, o->water, o->air_calibration,
                                        "--air-calibration");
    });
    std::string why;  // why the comparison port is not the usual one
    if (o->other_port.empty()) {
      // Chosen to fit the camera: a fixed-focus action camera behind a flat port cannot focus through
      // a small dome (docs/report.md); the line says which dome and why.
      const report::OtherPortChoice choice =
          WithFieldNames({{"compare_port", "--compare-port"}},
                         [&] { return report::ChooseOtherPort(in.setup, o->subject_distance_mm); });
      if (!choice.why.empty()) fmt::print(stderr, "porthole report: {}\n", choice.why);
      in.other_port = catalogue::LoadPort(choice.name);
      why = choice.why;
    } else {
      in.other_port = catalogue::LoadPort(o->other_port);
    }
    in.subject_distance_mm = o->subject_distance_mm;
    in.f_number = o->aperture.value_or(lens::DefaultFNumber(in.setup.lens));
    in.coc_mm = o->coc_mm;
    const double pitch = in.setup.camera.sensor.pixel_pitch_mm;
    // Each calibration checked against the body and lens before it is refit to Brown
    // (camera/validate.h): the air one fully, the water one for image size and pitch (under a flat
    // port its focal length is the air one's times about the water index).
    if (!o->air_calibration.empty()) {
      in.air_calibration =
          ReadCalibrationFor(o->air_calibration, in.setup, camera::CameraModelId::kBrown, "--air-calibration").calibration;
    }
    if (!o->water_calibration.empty()) {
      interop::ReadResult r = interop::ReadCalibrationFile(o->water_calibration, pitch, "--water-calibration");
      const std::string where = "--water-calibration '" + o->water_calibration + "'";
      camera::ExpectedCamera body = simulate::ExpectedCameraOf(in.setup);
      body.focal_length_mm = 0;  // size and pitch only
      camera::CheckCalibrationFits(r.camera(), r.pitch_known, body, where);
      const std::string label = r.calibration.label;
      in.water_calibration = interop::ConvertRead(std::move(r), camera::CameraModelId::kBrown, where).calibration;
      in.water_calibration->label = label;
    }
    if (!o->rig.empty()) {
      report::ReportInputs::RigInputs rig;
      rig.rig = measure::LoadRig(o->rig, "--rig");
      rig.what = fmt::format("{} cameras ({})", rig.rig.cameras.size(), o->rig);
      rig.plan = o->rig_plan;
      in.rig = std::move(rig);
    }
    if (!o->scale_bar_check.empty()) {
      const std::string text = ReadInputFile(o->scale_bar_check, "--scale-bar-check");
      nlohmann::json j;
      try {
        j = nlohmann::json::parse(text);
      } catch (const nlohmann::json::exception& e) {
        throw InvalidInput("--scale-bar-check", o->scale_bar_check + ": not JSON: " + JsonMessage(e));
      }
      in.scale_bar = measure::ScaleBarFromJson(j, "--scale-bar-check");
      in.scale_bar_source = o->scale_bar_check;
    }
    for (const CLI::Option* opt : cmd->get_options()) {
      if (opt->count() == 0 || opt->get_name() == "--help" || opt->get_name() == "--out" || opt->get_name() == "--force" ||
          opt->get_name() == "--json") {
        continue;
      }
      const auto results = opt->results();
      std::string v = results.empty() ? "true" : fmt::format("{}", fmt::join(results, ","));
      in.echo.emplace_back(opt->get_name(), v);
    }
    if (in.echo.empty()) in.echo.emplace_back("(defaults)", "the paper's system");
    if (!why.empty()) in.echo.emplace_back("(comparison port)", why);

    report::ReportOptions ro;
    ro.out_dir = o->out;
    ro.force = o->force;
    ro.progress = [](const std::string& line) { fmt::print(stderr, "porthole report: {}\n", line); };
    const report::ReportSummary s = WithFieldNames(
        {PORTHOLE_CAMERA_FLAGS, {"f_number", "--aperture"}, {"subject_distance_mm", "--subject-distance"},
         {"coc_mm", "--coc"}, {"sigma_px", "--rig-sigma-px"}, {"length_mm", "--rig-length"}},
        [&] { return report::WriteReport(in, ro); });
    if (o->json) {
      Json steps = Json::object();
      for (const auto& [name, sec] : s.step_seconds) steps[name] = sec;
      const Json j = {{"index_html", s.index_html.string()},
                      {"report_json", (s.index_html.parent_path() / "report.json").string()},
                      {"figures", s.figures}, {"step_seconds", steps}, {"seconds", s.seconds}};
      fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
      return;
    }
    fmt::print("report: {} ({} figures, {:.1f} s)\n", s.index_html.string(), s.figures.size(), s.seconds);
  });
}

}  // namespace porthole::cli
