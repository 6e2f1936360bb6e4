// JSON (de)serialisation of Brown–Conrady parameters (docs/camera-model.md, "Parameters"): keys
// from kBrownParamInfo (c_mm, x0_mm, y0_mm, K1 … B2), an optional `sigma` object with the same
// keys (standard deviations), and a `units` object naming every key's unit
// (docs/conventions.md, porthole extension).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "porthole/camera/brown.h"

namespace porthole::camera {

// Parameters with, optionally, their standard deviations (same units).
struct BrownEstimate {
  BrownParams value;
  std::optional<BrownParams> sigma;
};

// {"c_mm": …, "x0_mm": …, …, "B2": …}: every parameter, in BrownIndex order.
nlohmann::ordered_json BrownToJson(const BrownParams& p);
// The parameters, then "sigma": {…} if present, then "units": {…}.
nlohmann::ordered_json BrownToJson(const BrownEstimate& e);
// {"c_mm": "mm", …, "B2": "1"}.
nlohmann::ordered_json BrownUnitsJson();

// Reads an object written by BrownToJson (or by hand, e.g. the paper's Table 6 in-air column).
// c_mm is required; any other parameter may be omitted and is then 0 (not adjusted). "sigma" and
// "units" are read or ignored; any other key throws InvalidInput("<where>.<key>", …) so that a
// typo ("k1" for "K1") is never silently dropped. The values are validated (ValidateBrownParams).
BrownEstimate BrownFromJson(const nlohmann::json& j, const std::string& where = "camera");

// The same from a JSON text or a file path (anything not starting with '{' is a path), which may
// also hold a whole calibration as `porthole calibrate --out` writes it (its "camera" and "sigma",
// nulls = not adjusted; its model must be brown); `field` names the option in errors (e.g.
// "air_calibration").
BrownEstimate LoadBrownJson(const std::string& text_or_path, const std::string& field);

}  // namespace porthole::camera
