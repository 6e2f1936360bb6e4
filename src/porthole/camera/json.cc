#include "porthole/camera/json.h"

#include "porthole/core/error.h"
#include "porthole/core/input.h"

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

// ValidateBrownParams with its errors named under `where` ("c_mm" -> "where.c_mm").
void Validate(const BrownParams& p, const std::string& where) {
  try {
    ValidateBrownParams(p);
  } catch (const InvalidInput& e) {
    for (const auto& info : kBrownParamInfo) {
      if (e.field() == info.json_key) {
        throw InvalidInput(where + "." + e.field(), std::string(e.what()).substr(e.field().size() + 2));
      }
    }
    throw;
  }
}

// The σ object: the same keys, non-negative.
BrownParams ReadSigma(const nlohmann::json& j, const std::string& where) {
  BrownParams s;
  ReadKeys(j, where, /*require_c=*/false, &s);
  const auto a = s.ToArray();
  for (int i = 0; i < kBrownNumParams; ++i) {
    RequireNonNegative(where + "." + std::string(kBrownParamInfo[i].json_key), a[i]);
  }
  return s;
}

// The non-null members of an object (a calibration file's null = not adjusted).
nlohmann::json WithoutNulls(const nlohmann::json& j) {
  if (!j.is_object()) return j;
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, val] : j.items()) {
    if (!val.is_null()) out[key] = val;
  }
  return out;
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
  Validate(e.value, where);
  if (j.contains("sigma")) e.sigma = ReadSigma(j["sigma"], where + ".sigma");
  return e;
}

BrownEstimate LoadBrownJson(const std::string& text_or_path, const std::string& field) {
  const auto first = text_or_path.find_first_not_of(" \t\r\n");
  const bool is_text = first != std::string::npos && text_or_path[first] == '{';
  const std::string origin = is_text ? "(JSON text)" : text_or_path;
  const std::string text = is_text ? text_or_path : ReadInputFile(text_or_path, field, kMaxCalibrationFileBytes);
  const nlohmann::json j = ParseJsonText(text, field, origin);
  // Errors name the key and, for a file, the line it is on (field.camera.K1: file.json:12: …).
  const auto read = [&] {
    // A calibration file as `porthole calibrate --out` writes it (calib/result_json.h): the Brown
    // parameters under "camera" (null = not adjusted) and their σ under "sigma".
    if (j.is_object() && j.contains("camera") && j["camera"].is_object()) {
      if (j.contains("model") && !(j["model"].is_string() && j["model"].get<std::string>() == "brown")) {
        throw InvalidInput(field + ".model", "needs a Brown calibration, got model " + j["model"].dump());
      }
      BrownEstimate e;
      ReadKeys(WithoutNulls(j["camera"]), field + ".camera", /*require_c=*/true, &e.value);
      Validate(e.value, field + ".camera");
      if (j.contains("sigma") && j["sigma"].is_object()) e.sigma = ReadSigma(WithoutNulls(j["sigma"]), field + ".sigma");
      return e;
    }
    return BrownFromJson(j, field);
  };
  return is_text ? read() : WithJsonLines(text, field, origin, read);
}

}  // namespace porthole::camera
