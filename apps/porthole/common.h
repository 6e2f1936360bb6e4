// Option groups shared by the subcommands: the port, the water it works in, the entrance pupil;
// and small output helpers (JSON numbers that may be infinite, fixed-width tables).
#pragma once

#include "porthole/core/plausible.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/core/output.h"
#include "porthole/lens/lens.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/describe.h"
#include "porthole/ports/port.h"

namespace porthole::cli {

using Json = nlohmann::ordered_json;

// --water, --lambda, --temperature, --salinity, --pressure | --depth, --water-index,
// --glass-index, --extrapolate.
struct WaterOptions {
  std::string water = "seawater";
  double lambda_nm = 546.07;
  double temperature_c = 20;
  double salinity_psu = 35;
  std::optional<double> pressure_dbar;
  std::optional<double> depth_m;
  std::optional<double> water_index;
  std::optional<double> glass_index;
  bool extrapolate = false;

  void Add(CLI::App* cmd);
  ports::Environment ToEnvironment() const;  // validates; depth → pressure (UNESCO, 45°)
};

// --port NAME|FILE and --ep X,Y,Z (the entrance pupil in the housing frame).
struct PortOptions {
  std::string port = "nimar-ni320";
  std::vector<double> ep;

  void Add(CLI::App* cmd);
  ports::PortSpec Spec() const;
  std::optional<ports::Vec3> Ep() const;  // validates the three numbers
};

// Echo of the inputs for JSON outputs: the port, the pupil and the resolved indices (the one port
// JSON, ports/describe.h).
using ports::DescribeSystem;
using ports::DescribeSystemLine;

// The CLI's words for the library's fields (core/field_names.h). The library names its fields
// (`pixel_pitch_mm`, `images`), never a flag; the field is the flag of the command being run when
// it has one of that name with dashes (--pixel-pitch-mm, --images). main() sets the command tree.
void SetCommandTree(const CLI::App* root);
std::optional<std::string> FlagOfField(std::string_view field);
// `text` with each backquoted field the running command has as a flag written as that flag; other
// backquoted words lose their quotes. For the library's warnings and notes before they are printed.
std::string CliWords(std::string_view text);
// CliWords on every string of a JSON result the CLI prints or writes (its statuses and notes).
template <typename J>
void CliWordsInJson(J* j) {
  if (j->is_string()) {
    const auto& s = j->template get_ref<const std::string&>();
    if (s.find('`') != std::string::npos) *j = CliWords(s);
  } else if (j->is_structured()) {
    for (auto& v : *j) CliWordsInJson(&v);
  }
}

// A length for JSON: a number, "inf" for infinity, null for NaN.
Json Length(double mm);
Json Vec3Json(const ports::Vec3& v);

// Parses "200,300,inf" into lengths (mm); throws InvalidInput(field) for anything else.
std::vector<double> ParseLengthList(const std::vector<std::string>& items, const std::string& field);

// Formats a number for a table: fixed decimals, "inf", or "-" for NaN.
std::string Fixed(double v, int decimals);

// ---- Plausibility and outputs (issue 12) ----

// The ranges of values physical cameras, lenses and ports have live in the library
// (core/plausible.h: one definition, hints computed from the value given).
using porthole::PlausibleRange;
using porthole::kPixelPitchRange;
using porthole::kCocRange;
using porthole::kDomeRadiusRange;
using porthole::kPortThicknessRange;
using porthole::kFocalLengthRange;

// Prints `porthole: warning: ` and the library's PlausibilityWarning(field, value, range) on
// stderr when there is one; returns whether it warned. Never throws: implausible is not invalid.
bool WarnIfImplausible(const std::string& field, double value, const PlausibleRange& range);

// Warns (WarnIfImplausible) for a port's radii or thickness, naming the port's fields.
void WarnIfImplausiblePort(const ports::PortSpec& spec, const std::string& where = "port");

// Makes `dir` a directory outputs can be written into: creates it (and missing parents) when it
// does not exist, as `report --out` does, and checks it is writable. Throws InvalidInput(field, ...)
// when it exists and is not a directory, cannot be created, or is not writable. Call it before
// long work, so that a typo fails at once.
void EnsureOutputDirectory(const std::string& dir, const std::string& field);

// Checks, before long work, that `file` can be written: not a directory, and its directory exists
// and is writable. Throws InvalidInput(field, ...). Writes nothing. Commands check their outputs with
// CheckOutput and their own OutputRules (--force, inputs) instead: this one assumes --force.
void CheckOutputFile(const std::string& file, const std::string& field);

// ---- Outputs: the one overwrite rule of every command (core/output.h, docs/robustness.md) ----

// The --force flag of a command that writes files, with the rule in its help.
void AddForceFlag(CLI::App* cmd, bool* force);

// The files among the values of `cmd`'s options (every option but `outputs`, e.g. {"--out"}): the
// command's inputs, which no output of it may replace.
std::vector<std::filesystem::path> InputFiles(const CLI::App* cmd, const std::vector<std::string>& outputs);

// JSON text for stdout: names from the file system that are not UTF-8 are written with U+FFFD
// instead of failing after the outputs were written.
std::string PrintableJson(const Json& j, int indent = 2);

}  // namespace porthole::cli
