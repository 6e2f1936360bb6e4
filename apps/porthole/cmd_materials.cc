// `porthole materials`: refractive indices (relative to air) of the media a housing meets, at given
// wavelength, temperature, salinity and pressure (or depth). See docs/materials.md.
//
//   porthole materials [MEDIUM...] [--lambda NM] [--temperature C] [--salinity PSU]
//                      [--pressure DBAR | --depth M] [--extrapolate] [--json]
//
// With media: one row per medium; a medium outside its validity range (without --extrapolate) or
// an unknown name is an error (InvalidInput, exit 2). Without media: every known medium with its
// index at the conditions ("n/a" and the reason where the conditions are outside its range) and
// its validity ranges.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "porthole/core/error.h"
#include "porthole/materials/materials.h"

namespace porthole::cli {
namespace {

namespace mat = porthole::materials;
using Json = nlohmann::ordered_json;

struct MaterialsOptions {
  std::vector<std::string> media;
  double lambda_nm = mat::kDefaultLambdaNm;
  double temperature_c = 20.0;
  double salinity_psu = 35.0;
  double pressure_dbar = 0.0;
  double depth_m = 0.0;
  bool extrapolate = false;
  bool json = false;
  CLI::Option* pressure_option = nullptr;
  CLI::Option* depth_option = nullptr;
};

// Depth is converted at 45° latitude (DepthToPressureDbar's default).
constexpr double kDepthLatitudeDeg = 45.0;

struct Row {
  std::string name;
  std::optional<double> n;  // empty when the conditions are outside the medium's range
  std::string model;
  std::string error;                    // why n is empty
  std::optional<mat::MediumInfo> info;  // listing mode only
};

std::string Range(double lo, double hi) {
  if (std::isnan(lo)) return "-";
  return fmt::format("{:g}-{:g}", lo, hi);
}

std::string PressureRange(double max_dbar) {
  if (std::isnan(max_dbar)) return "-";
  if (max_dbar == 0.0) return "1 atm";
  return fmt::format("0-{:g} dbar", max_dbar);
}

Json RangeJson(double lo, double hi) {
  if (std::isnan(lo)) return nullptr;
  return Json::array({lo, hi});
}

std::string Render(const MaterialsOptions& o, const mat::Conditions& c,
                   const std::vector<Row>& rows) {
  if (o.json) {
    Json conditions = {{"lambda_nm", c.lambda_nm},
                       {"temperature_c", c.temperature_c},
                       {"salinity_psu", c.salinity_psu},
                       {"pressure_dbar", c.pressure_dbar}};
    if (o.depth_option->count() > 0) {
      conditions["depth_m"] = o.depth_m;
      conditions["depth_latitude_deg"] = kDepthLatitudeDeg;
    }
    conditions["extrapolate"] = c.extrapolate;
    Json media = Json::array();
    for (const Row& r : rows) {
      Json m = {{"name", r.name}, {"n", r.n ? Json(*r.n) : Json(nullptr)}, {"model", r.model}};
      if (!r.error.empty()) m["error"] = r.error;
      if (r.info) {
        const mat::MediumInfo& i = *r.info;
        m["description"] = i.description;
        m["valid"] = {
            {"lambda_nm", RangeJson(i.lambda_min_nm, i.lambda_max_nm)},
            {"temperature_c", RangeJson(i.temperature_min_c, i.temperature_max_c)},
            {"salinity_psu", RangeJson(i.salinity_min_psu, i.salinity_max_psu)},
            {"pressure_max_dbar",
             std::isnan(i.pressure_max_dbar) ? Json(nullptr) : Json(i.pressure_max_dbar)}};
      }
      media.push_back(std::move(m));
    }
    return Json{{"conditions", conditions}, {"media", media}}.dump(2) + "\n";
  }

  std::string out;
  const bool listing = !rows.empty() && rows.front().info.has_value();
  if (listing) {
    out += fmt::format("{:<24} {:>9}  {:<13} {:<9} {:<8} {:<13} {}\n", "medium", "n", "lambda (nm)",
                       "T (C)", "S (PSU)", "pressure", "model");
  } else {
    out += fmt::format("{:<24} {:>9}  {}\n", "medium", "n", "model");
  }
  for (const Row& r : rows) {
    const std::string n = r.n ? fmt::format("{:.6f}", *r.n) : "n/a";
    if (listing) {
      const mat::MediumInfo& i = *r.info;
      out += fmt::format("{:<24} {:>9}  {:<13} {:<9} {:<8} {:<13} {}\n", r.name, n,
                         Range(i.lambda_min_nm, i.lambda_max_nm),
                         Range(i.temperature_min_c, i.temperature_max_c),
                         Range(i.salinity_min_psu, i.salinity_max_psu),
                         PressureRange(i.pressure_max_dbar), r.model);
    } else {
      out += fmt::format("{:<24} {:>9}  {}\n", r.name, n, r.model);
    }
  }
  out += fmt::format(
      "conditions: lambda {:g} nm, temperature {:g} C, salinity {:g} PSU, "
      "pressure {:g} dbar",
      c.lambda_nm, c.temperature_c, c.salinity_psu, c.pressure_dbar);
  if (o.depth_option->count() > 0) {
    out += fmt::format(" (depth {:g} m at {:g} deg latitude, UNESCO 1983)", o.depth_m,
                       kDepthLatitudeDeg);
  }
  if (c.extrapolate) out += ", extrapolating";
  out += "\nindices relative to air at the same wavelength";
  if (listing) out += "; ranges are the models' published validity";
  out += "\n";
  for (const Row& r : rows) {
    if (!r.error.empty()) out += fmt::format("n/a {}: {}\n", r.name, r.error);
  }
  return out;
}

void Run(const MaterialsOptions& o) {
  mat::Conditions c;
  c.lambda_nm = RequireFinite("lambda_nm", o.lambda_nm);
  c.temperature_c = RequireFinite("temperature_c", o.temperature_c);
  c.salinity_psu = RequireFinite("salinity_psu", o.salinity_psu);
  c.pressure_dbar = RequireFinite("pressure_dbar", o.pressure_dbar);
  c.extrapolate = o.extrapolate;
  if (o.depth_option->count() > 0) {
    c.pressure_dbar = mat::DepthToPressureDbar(o.depth_m, kDepthLatitudeDeg);
  }

  std::vector<Row> rows;
  if (!o.media.empty()) {
    for (const std::string& name : o.media) {
      rows.push_back(Row{name, mat::Index(name, c), mat::ModelOf(name), "", std::nullopt});
    }
  } else {
    // Conditions bad for every medium (NaN, λ ≤ 0) are still an error; a range one is a row note.
    mat::Index("air", c);
    for (const mat::MediumInfo& info : mat::ListMedia()) {
      Row r{info.name, std::nullopt, mat::ModelOf(info.name), "", info};
      try {
        r.n = mat::Index(info.name, c);
      } catch (const InvalidInput& e) {
        r.error = e.what();
      }
      rows.push_back(std::move(r));
    }
  }
  const std::string out = Render(o, c, rows);
  for (const Row& r : rows) {
    if (!r.n) continue;
    if (const auto note = mat::SeawaterNote(r.name, c)) fmt::print(stderr, "porthole: note: {}\n", *note);
  }
  fmt::print("{}", out);
}

}  // namespace

void RegisterMaterials(CLI::App& app) {
  auto o = std::make_shared<MaterialsOptions>();
  CLI::App* sub = app.add_subcommand(
      "materials",
      "Refractive indices relative to air: water and seawater (Quan-Fry 1995, IAPWS R9-97, "
      "Millard-Seaver 1990), port glasses and plastics. No MEDIUM: list all with validity ranges.");
  sub->add_option("medium", o->media,
                  "media: air, seawater, freshwater, water-iapws, seawater-millard-seaver, n-bk7, "
                  "fused-silica, pmma, polycarbonate, sapphire-o, or a constant index like 1.341");
  sub->add_option("--lambda", o->lambda_nm, "wavelength in air, nm (default: e line)")
      ->capture_default_str();
  sub->add_option("--temperature", o->temperature_c, "water temperature, deg C")
      ->capture_default_str();
  sub->add_option("--salinity", o->salinity_psu, "salinity, PSU (seawater models only)")
      ->capture_default_str();
  o->pressure_option = sub->add_option("--pressure", o->pressure_dbar, "gauge pressure, dbar")
                           ->capture_default_str();
  o->depth_option = sub->add_option("--depth", o->depth_m,
                                    "depth, m (converted to dbar by UNESCO 1983 at 45 deg)");
  o->pressure_option->excludes(o->depth_option);
  sub->add_flag("--extrapolate", o->extrapolate, "allow use outside the models' validity ranges");
  sub->add_flag("--json", o->json, "print JSON instead of a table");
  sub->callback([o] { Run(*o); });
}

}  // namespace porthole::cli
