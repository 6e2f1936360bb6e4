#include "common.h"

#include <fmt/format.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <system_error>

#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/core/json_length.h"
#include "porthole/housing/plausible.h"
#include "porthole/catalogue/presets.h"
#include "porthole/materials/materials.h"

namespace porthole::cli {

void WaterOptions::Add(CLI::App* cmd) {
  cmd->add_option("--water", water, "Water model: seawater (Quan-Fry 1995), freshwater, water-iapws, "
                                    "seawater-millard-seaver, or a constant index")
      ->capture_default_str()->group("Water");
  cmd->add_option("--lambda", lambda_nm, "Wavelength, nm")->capture_default_str()->group("Water");
  cmd->add_option("--temperature", temperature_c, "Water temperature, degC")->capture_default_str()->group("Water");
  cmd->add_option("--salinity", salinity_psu, "Salinity, PSU (permil)")->capture_default_str()->group("Water");
  auto* p = cmd->add_option("--pressure", pressure_dbar, "Gauge pressure, dbar")->group("Water");
  auto* d = cmd->add_option("--depth", depth_m, "Depth, m (converted to dbar, UNESCO 1983 at 45 deg)")->group("Water");
  p->excludes(d);
  cmd->add_option("--water-index", water_index, "Force a constant water index (e.g. 1.341, the paper's)")->group("Water");
  cmd->add_option("--glass-index", glass_index, "Force a constant port index (e.g. 1.5168, N-BK7 at d)")->group("Water");
  cmd->add_flag("--extrapolate", extrapolate, "Allow models outside their published validity ranges")->group("Water");
}

ports::Environment WaterOptions::ToEnvironment() const {
  ports::Environment env;
  env.water = water;
  env.conditions.lambda_nm = RequirePositive("--lambda", lambda_nm);
  env.conditions.temperature_c = RequireFinite("--temperature", temperature_c);
  env.conditions.salinity_psu = RequireNonNegative("--salinity", salinity_psu);
  env.conditions.extrapolate = extrapolate;
  if (pressure_dbar) env.conditions.pressure_dbar = RequireNonNegative("--pressure", *pressure_dbar);
  if (depth_m) env.conditions.pressure_dbar = materials::DepthToPressureDbar(RequireNonNegative("--depth", *depth_m));
  if (water_index) {
    if (!(std::isfinite(*water_index) && *water_index >= 1)) throw InvalidInput("--water-index", "must be a number >= 1");
    env.water_index = water_index;
  } else if (const auto note = materials::SeawaterNote(water, env.conditions)) {
    materials::Index(water, env.conditions);  // out of every range: the error alone, no note
    fmt::print(stderr, "porthole: note: {}\n", *note);
  }
  if (glass_index) {
    if (!(std::isfinite(*glass_index) && *glass_index >= 1)) throw InvalidInput("--glass-index", "must be a number >= 1");
    env.glass_index = glass_index;
  }
  return env;
}

void PortOptions::Add(CLI::App* cmd) {
  cmd->add_option("--port", port, "Port: a preset name ('porthole presets') or a TOML file")
      ->capture_default_str()->group("Port");
  cmd->add_option("--ep", ep, "Entrance pupil X,Y,Z in the housing frame, mm (default: the port's)")
      ->delimiter(',')->expected(3)->group("Port");
}

ports::PortSpec PortOptions::Spec() const {
  ports::PortSpec spec = catalogue::LoadPort(port);
  WarnIfImplausiblePort(spec, port + ": port");
  return spec;
}

std::optional<ports::Vec3> PortOptions::Ep() const {
  if (ep.empty()) return std::nullopt;
  const ports::Vec3 v(ep[0], ep[1], ep[2]);
  if (!v.allFinite()) throw InvalidInput("--ep", "must be three finite numbers X,Y,Z in mm");
  return v;
}

Json Length(double mm) { return JsonLength<Json>(mm); }

Json Vec3Json(const ports::Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

std::vector<double> ParseLengthList(const std::vector<std::string>& items, const std::string& field) {
  std::vector<double> out;
  for (const std::string& s : items) {
    if (s == "inf" || s == "infinity") {
      out.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || !std::isfinite(v) || v <= 0) {
      throw InvalidInput(field, "'" + s + "' is not a positive distance in mm (or 'inf')");
    }
    out.push_back(v);
  }
  return out;
}

std::string Fixed(double v, int decimals) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.{}f}", v, decimals);
}

namespace {
const CLI::App* command_tree = nullptr;
}  // namespace

void SetCommandTree(const CLI::App* root) { command_tree = root; }

std::optional<std::string> FlagOfField(std::string_view field) {
  if (command_tree == nullptr || field.empty() || field.front() == '-') return std::nullopt;
  for (char c : field) {
    if (!(std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_')) {
      return std::nullopt;
    }
  }
  std::string flag = "--" + std::string(field);
  std::replace(flag.begin(), flag.end(), '_', '-');
  for (const CLI::App* sub : command_tree->get_subcommands()) {
    if (sub->get_option_no_throw(flag) != nullptr) return flag;
  }
  return std::nullopt;
}

std::string CliWords(std::string_view text) { return RenameQuotedFieldsBy(FlagOfField, text); }

bool WarnIfImplausible(const std::string& field, double value, const PlausibleRange& range) {
  const auto w = porthole::PlausibilityWarning(field, value, range);
  if (w) fmt::print(stderr, "porthole: warning: {}\n", *w);
  return w.has_value();
}

void WarnIfImplausiblePort(const ports::PortSpec& spec, const std::string& where) {
  for (const std::string& w : housing::PortPlausibilityWarnings(spec, where)) {
    fmt::print(stderr, "porthole: warning: {}\n", w);
  }
}

namespace {

// Throws InvalidInput(field) unless `dir` is an existing directory this process may write into.
void RequireWritableDirectory(const std::filesystem::path& dir, const std::string& field) {
  if (!std::filesystem::is_directory(dir)) throw InvalidInput(field, dir.string() + " is not a directory");
  if (access(dir.c_str(), W_OK | X_OK) != 0) throw InvalidInput(field, dir.string() + " is not writable");
}

}  // namespace

void EnsureOutputDirectory(const std::string& dir, const std::string& field) {
  if (dir.empty()) throw InvalidInput(field, "give a directory");
  const std::filesystem::path p(dir);
  std::error_code ec;
  if (std::filesystem::exists(p, ec)) {
    if (!std::filesystem::is_directory(p, ec)) throw InvalidInput(field, dir + " exists and is not a directory");
  } else if (!std::filesystem::create_directories(p, ec) && !std::filesystem::is_directory(p)) {
    throw InvalidInput(field, fmt::format("cannot create {}: {}", dir, ec ? ec.message() : "unknown error"));
  }
  RequireWritableDirectory(p, field);
}

void CheckOutputFile(const std::string& file, const std::string& field) {
  CheckOutput(file, field, OutputRules{.force = true, .inputs = {}});
}

void AddForceFlag(CLI::App* cmd, bool* force) {
  cmd->add_flag("--force", *force,
                "Replace existing output files (never an input of this command, nor a file porthole wrote for another "
                "purpose: a calibration, ground truth, detections or a report); devices and FIFOs are written into, "
                "symlinks through to their target");
}

std::vector<std::filesystem::path> InputFiles(const CLI::App* cmd, const std::vector<std::string>& outputs) {
  std::vector<std::filesystem::path> files;
  for (const CLI::Option* opt : cmd->get_options()) {
    if (opt->count() == 0 || std::find(outputs.begin(), outputs.end(), opt->get_name()) != outputs.end()) continue;
    for (const std::string& v : opt->results()) {
      std::error_code ec;
      if (!v.empty() && std::filesystem::is_regular_file(v, ec)) files.emplace_back(v);
    }
  }
  return files;
}

std::string PrintableJson(const Json& j, int indent) {
  return j.dump(indent, ' ', false, Json::error_handler_t::replace);
}

}  // namespace porthole::cli
