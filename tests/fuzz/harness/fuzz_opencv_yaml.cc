// OpenCV calibration YAML (calib/result_json.cc ImportOpenCVYaml).
#include <cstddef>
#include <cstdint>
#include <string>

#include "porthole/calib/result_json.h"
#include "porthole/core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    porthole::calib::ImportOpenCVYaml(text, 0.0055, "A", nullptr);
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
