// How a length (or any quantity that may be infinite) is written to JSON, everywhere in porthole:
// a number; the string "inf" / "-inf" for infinity (JSON has no infinity; the paper's tables write
// "Infinity"); null when it is not available (NaN).
#pragma once

#include <cmath>
#include <nlohmann/json.hpp>

namespace porthole {

template <typename Json = nlohmann::ordered_json>
Json JsonLength(double v) {
  if (std::isnan(v)) return Json(nullptr);
  if (std::isinf(v)) return Json(v > 0 ? "inf" : "-inf");
  return Json(v);
}

}  // namespace porthole
