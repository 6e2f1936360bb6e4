// The report's parts: the gathered library results (Gather), the figures (data file + gnuplot
// script each), the page and the JSON. Private to src/porthole/report/.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "porthole/calib/compare.h"
#include "porthole/planning/flat.h"
#include "porthole/planning/plan.h"
#include "porthole/report/report.h"
#include "porthole/simulate/simulate.h"

namespace porthole::report {

using Json = nlohmann::ordered_json;

// One working distance: where its virtual image is and the focus that makes it sharp. The report's
// one convention for D_S2EP (docs/report.md): measured from the entrance pupil where the lens puts
// it when focused on that image (planning::SolveFocus), as `porthole plan` does for its target and
// its minimum WD. The image itself is a point fixed in the housing (image_z_mm); only its distance
// from the pupil depends on the focus.
struct VirtualRow {
  double wd_mm = 0;
  double d_s2ep_mm = 0, vwd_mm = 0, magnification = 0;  // paraxial
  double d_s2ep_real_mm = NAN;      // real rays through the pupil rim at f/(2N)
  std::optional<double> fd_mm;      // the focus scale to set; nullopt: closer than the lens goes
  double closeup_dioptre = 0;       // the weakest close-up that reaches it (0: reachable)
  double ep_z_mm = 0;               // the pupil at that focus, housing frame (at min focus if unreachable)
  double image_z_mm = 0;            // the virtual image, housing frame: ep_z_mm + d_s2ep_mm
};

// The virtual image of infinity, computed once and used by every table, figure and caption: the
// Table 5 row WD = ∞ (lens focused on it, what `porthole plan` prints as d_s2ep_infinity_mm), and the
// same point seen from the pupil where the lens puts it with its focus scale at ∞.
struct InfinityImage {
  VirtualRow focused;                    // lens focused on the image of infinity
  double d_s2ep_at_infinity_focus_mm = 0;  // from the pupil at the focus-scale infinity
  double ep_z_at_infinity_focus_mm = 0;  // housing frame
};

// Depth of field for one subject distance from the pupil, in air and under water.
struct DofRow {
  double subject_mm = 0;
  planning::DofAir air;
  planning::DofWater water;
};

// A chief ray's angle in the water against its angle in air, for both ports (NaN: blocked).
struct AngleRow {
  double theta_air_deg = 0, theta_main_deg = NAN, theta_other_deg = NAN;
};

// Everything the report shows, straight from the libraries.
struct Results {
  const ReportInputs* in = nullptr;
  planning::Setup other_setup;            // the same camera and lens behind the other port
  planning::Plan plan, other_plan;        // at the target subject distance
  std::optional<planning::FlatAnalysis> flat;  // of whichever of the two ports is flat
  std::vector<VirtualRow> table;          // the paper's Table 5 working distances
  std::vector<VirtualRow> curve;          // dense, for the figures
  InfinityImage infinity;                 // table.back() and the plan's infinity-focus view of it
  std::vector<DofRow> dof;
  double min_subject_mm = 0;              // the minimum WD as a distance from the pupil (at min focus)
  std::vector<AngleRow> angles;
  std::vector<optics::RayPath> fan;       // chief rays in the x-z plane, out into the water
  std::vector<double> fan_angles_deg;
  simulate::Prediction prediction, other_prediction;
  std::vector<simulate::MapPoint> map;
  std::vector<double> offsets_z_mm, offsets_x_mm;
  std::vector<simulate::SweepRow> sweep_z, sweep_x;
  std::optional<calib::CompareResult> compare;
  std::optional<measure::RigPlan> rig_plan;  // in->rig
};

// Times each step; reports those over a second through options.progress.
class Steps {
 public:
  explicit Steps(const ReportOptions& o) : options_(o) {}
  template <typename F>
  auto Run(const std::string& what, F&& f) {
    const auto t0 = Now();
    if constexpr (std::is_void_v<decltype(f())>) {
      f();
      Done(what, t0);
    } else {
      auto r = f();
      Done(what, t0);
      return r;
    }
  }
  const std::vector<std::pair<std::string, double>>& seconds() const { return seconds_; }

 private:
  static double Now();
  void Done(const std::string& what, double t0);
  const ReportOptions& options_;
  std::vector<std::pair<std::string, double>> seconds_;
};

// Runs the libraries (planning, simulate, calib). Throws InvalidInput for bad inputs.
Results Gather(const ReportInputs& in, Steps& steps);

struct Figure {
  std::string id;       // file stem: figures/<id>.{dat,gp,png,svg}
  std::string section;  // the page section it belongs to
  std::string title, caption;
  int width_px = 960, height_px = 560;
  std::string data;     // the data file, with a header naming columns and units
  std::string body;     // gnuplot commands after the terminal and output are set
};
std::vector<Figure> MakeFigures(const Results& r);

// The gnuplot script written beside a figure: sets each terminal in turn (pngcairo, svg) and runs
// the figure's commands; `gnuplot <id>.gp` in figures/ remakes <id>.png and <id>.svg.
std::string FigureScript(const Figure& f);

// An SVG from gnuplot made fit to inline in a page: no XML prolog, every id (and reference to it)
// prefixed with the figure id so that several figures on one page do not collide.
std::string InlineSvg(const std::string& svg, const std::string& id);

Json ReportJson(const Results& r, const std::vector<Figure>& figures);
// svgs: figure id → inline SVG text.
std::string ReportHtml(const Results& r, const std::vector<Figure>& figures,
                       const std::map<std::string, std::string>& svgs);

// Escapes &, <, >, " for HTML text and attributes.
std::string Html(const std::string& s);

// Escaping for gnuplot (escape.cc; docs/robustness.md). Every text from an input file (names,
// descriptions, sources) goes through one of these before it reaches a script or a data file.
// OneLine: control characters become spaces, no trailing backslash (for `#` comment lines).
std::string OneLine(const std::string& s);
// GpText: a single-quoted gnuplot string literal (no substitution inside) whose enhanced-text
// markup is escaped, so that it prints as typed: `title GpText(name)`.
std::string GpText(const std::string& s);
// Throws InternalError if the script could run a shell command (a backquote outside a
// single-quoted string) or has a string running past its line. Run on every script written.
void CheckGnuplotScript(const std::string& script, const std::string& id);

}  // namespace porthole::report
