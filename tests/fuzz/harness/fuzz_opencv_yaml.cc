// OpenCV calibration YAML (interop/opencv_storage.cc, the reader of every command).
#include <cstddef>
#include <cstdint>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    porthole::interop::ReadCalibration(text, porthole::interop::Format::kOpenCVYaml, 0.0055, "A");
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
