#include "porthole/camera/json.h"

#include <fstream>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::camera {
namespace {

using OJson = nlohmann::ordered_json;

// Reads the Brown keys of `j` into *p (omitted keys keep their value); rejects unknown keys other
// than those in `extra`.
void ReadKeys(const nlohmann::json& j, const std::string& where, bool require_c, BrownParams* p) {
  if (!j.is_object()) throw InvalidInput(where, "must be a JSON object of Brown parameters");
  std::array<double, kBrownNumParams> a = p->ToArray();
  for (const auto& [key, value] : j.items()) {
    if (key == "sigma" || key == "units") continue;
    int index = -1;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (key == kBrownParamInfo[i].json_key) index = i;
    }
    if (index < 0) {
      std::string known;
      for (const auto& info : kBrownParamInfo) known += (known.empty() ? "" : ", ") + std::string(info.json_key);
      throw InvalidInput(where + "." + key, "unknown key (Brown parameters are " + known + ")");
    }
    if (!value.is_number()) throw InvalidInput(where + "." + key, "must be a number");
    a[index] = value.get<double>();
  }
  if (require_c && !j.contains(std::string(kBrownParamInfo[kBrownC].json_key))) {
    throw InvalidInput(where + ".c_mm", "the principal distance is required");
  }
  *p = BrownParams::FromArray(a.data());
}

}  // namespace

OJson BrownToJson(const BrownParams& p) {
  OJson j = OJson::object();
  const auto a = p.ToArray();
  for (int i = 0; i < kBrownNumParams; ++i) j[std::string(kBrownParamInfo[i].json_key)] = a[i];
  return j;
}

OJson BrownUnitsJson() {
  OJson j = OJson::object();
  for (const auto& info : kBrownParamInfo) j[std::string(info.json_key)] = std::string(info.unit);
  return j;
}

OJson BrownToJson(const BrownEstimate& e) {
  OJson j = BrownToJson(e.value);
  if (e.sigma) j["sigma"] = BrownToJson(*e.sigma);
  j["units"] = BrownUnitsJson();
  return j;
}

BrownEstimate BrownFromJson(const nlohmann::json& j, const std::string& where) {
  BrownEstimate e;
  ReadKeys(j, where, /*require_c=*/true, &e.value);
  ValidateBrownParams(e.value);
  if (j.contains("sigma")) {
    BrownParams s;
    ReadKeys(j["sigma"], where + ".sigma", /*require_c=*/false, &s);
    const auto a = s.ToArray();
    for (int i = 0; i < kBrownNumParams; ++i) {
      RequireNonNegative(where + ".sigma." + std::string(kBrownParamInfo[i].json_key), a[i]);
    }
    e.sigma = s;
  }
  return e;
}

BrownEstimate LoadBrownJson(const std::string& text_or_path, const std::string& field) {
  std::string text = text_or_path;
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || text[first] != '{') {
    std::ifstream in(text_or_path);
    if (!in) throw InvalidInput(field, "cannot read '" + text_or_path + "'");
    std::ostringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& err) {
    throw InvalidInput(field, std::string("not valid JSON: ") + err.what());
  }
  // A calibration file as `porthole calibrate --out` writes it (calib/result_json.h): the Brown
  // parameters under "camera" (null = not adjusted) and their σ under "sigma".
  if (j.is_object() && j.contains("camera") && j["camera"].is_object()) {
    if (j.contains("model") && !(j["model"].is_string() && j["model"].get<std::string>() == "brown")) {
      throw InvalidInput(field, "needs a Brown calibration, got model " + j["model"].dump());
    }
    nlohmann::json brown = nlohmann::json::object();
    for (const auto& [key, val] : j["camera"].items()) {
      if (!val.is_null()) brown[key] = val;
    }
    if (j.contains("sigma") && j["sigma"].is_object()) {
      nlohmann::json sigma = nlohmann::json::object();
      for (const auto& [key, val] : j["sigma"].items()) {
        if (!val.is_null()) sigma[key] = val;
      }
      brown["sigma"] = sigma;
    }
    return BrownFromJson(brown, field);
  }
  return BrownFromJson(j, field);
}

}  // namespace porthole::camera
