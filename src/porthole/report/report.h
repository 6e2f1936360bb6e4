// `porthole report`: everything the paper shows about one camera–lens–port–water system, as
// figures and tables in one self-contained HTML page (docs/report.md). The numbers come from the
// libraries (planning, simulate, calib, ports); this module only gathers them, writes each figure's
// data file and gnuplot script, runs gnuplot once for all figures (PNG and SVG), and writes
// index.html (figures inline as SVG) and report.json (every number).
//
// Units and frames are those of docs/conventions.md: mm, degrees in files, housing frame, image mm
// with y up; every JSON field name carries its unit.
//
// Output is whole or absent: the report is built in a temporary directory beside the output
// directory and renamed into place at the end; on any failure the temporary directory is removed
// and an existing report is left as it was.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/measure/measure.h"
#include "porthole/measure/plan_rig.h"
#include "porthole/planning/focus.h"

namespace porthole::report {

// The system and what to show about it.
struct ReportInputs {
  planning::Setup setup;      // camera, lens, port, water (the pupil follows the lens's focus)
  ports::PortSpec other_port; // the port compared with setup.port: a flat one for a dome, or back
  double subject_distance_mm = 1000;  // the paper's focus: a target 1 m from the entrance pupil
  double f_number = 8;                // the paper's Section 4 aperture
  std::optional<double> coc_mm;       // unset: planning's default, two pixel pitches
  // Calibrations of the camera in its housing (calib JSON or OpenCV YAML): the air one is the lens
  // model of the prediction; with both, the comparison section (Figs. 14 and 15) is added.
  std::optional<calib::CalibrationRecord> air_calibration, water_calibration;
  // A rig of cameras behind their ports (issue 27): the section "Your rig" plans the σ of a length
  // over the common field against range and a central model's error (measure::PlanRig).
  struct RigInputs {
    measure::Rig rig;
    std::string what;  // one line naming it (its file)
    measure::RigPlanOptions plan;
  };
  std::optional<RigInputs> rig;
  // A scale-bar check after a dive (`porthole measure --scale-bar … --json`): its error against
  // range and position in the image, the section "Scale bar".
  std::optional<measure::ScaleBarCheck> scale_bar;
  std::string scale_bar_source;  // its file, named on the page
  // The inputs as the user gave them (option, value), echoed in the report.
  std::vector<std::pair<std::string, std::string>> echo;
};

struct ReportOptions {
  std::filesystem::path out_dir;
  bool force = false;            // replace an existing report directory
  std::string gnuplot = "gnuplot";  // the gnuplot executable (Debian gnuplot-nox)
  // Receives one line for every step that took more than a second (the CLI prints it on stderr).
  std::function<void(const std::string&)> progress;
};

struct ReportSummary {
  std::filesystem::path index_html;  // the finished report's page
  std::vector<std::string> figures;  // figure ids, in page order
  std::vector<std::pair<std::string, double>> step_seconds;  // each step's wall time
  double seconds = 0;                // total
};

// An empty existing directory is filled; a previous report is replaced only with force.
// Throws InvalidInput("out", …) when the output directory cannot be written, is not empty and
// force is off, or is not empty and holds no porthole report (never replaced, even with force);
// InvalidInput naming the input for bad inputs; InvalidInput("gnuplot", …) when gnuplot is
// missing or fails. Nothing is left behind on failure.
ReportSummary WriteReport(const ReportInputs& inputs, const ReportOptions& options);

// The comparison port a report uses when none is given: the generic flat port for a dome, the
// nominal NI320 dome for a flat port (preset names).
std::string DefaultOtherPort(const ports::PortSpec& port);

// The comparison port chosen to fit the camera (`porthole report` without --compare-port): for a
// dome the generic flat port; for a flat port the first of the domes nimar-ni320-nominal,
// generic-dome-8in, generic-dome-230mm-glass (growing radius: a larger dome puts the virtual image
// farther) on whose virtual image of a subject subject_distance_mm from the pupil the lens can
// focus. A fixed-focus action camera sharp from 300 mm (the GoPro presets) cannot focus on the
// NI320's image of a subject 1 m away (237.5 mm from the pupil) and gets the 230 mm dome.
struct OtherPortChoice {
  std::string name;  // a preset name
  std::string why;   // one line: why this port (empty for the usual choice, the first candidate)
};
// Throws InvalidInput("compare_port") when no candidate fits (naming them and --compare-port's
// field), and whatever the lens's focus throws for the main port is left to the report.
OtherPortChoice ChooseOtherPort(const planning::Setup& setup, double subject_distance_mm);

}  // namespace porthole::report
