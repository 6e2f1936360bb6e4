// Calibration JSON (calib/result_json.cc) parsed as the CLI does: ParseJsonText, then
// CalibrationFromJson.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "porthole/calib/result_json.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    porthole::calib::CalibrationFromJson(porthole::ParseJsonText(text, "A", "fuzz.json"), "A");
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
