// Option groups shared by the subcommands: the port, the water it works in, the entrance pupil;
// and small output helpers (JSON numbers that may be infinite, fixed-width tables).
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/ports/environment.h"
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

// Echo of the inputs for JSON outputs: the port, the pupil and the resolved indices.
Json DescribeSystem(const ports::PortSystem& sys, const ports::Environment& env);
std::string DescribeSystemLine(const ports::PortSystem& sys, const ports::Environment& env);

// A length for JSON: a number, "inf" for infinity, null for NaN.
Json Length(double mm);
Json Vec3Json(const ports::Vec3& v);

// Parses "200,300,inf" into lengths (mm); throws InvalidInput(field) for anything else.
std::vector<double> ParseLengthList(const std::vector<std::string>& items, const std::string& field);

// Formats a number for a table: fixed decimals, "inf", or "-" for NaN.
std::string Fixed(double v, int decimals);

}  // namespace porthole::cli
