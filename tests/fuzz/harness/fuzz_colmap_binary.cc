// COLMAP cameras.bin (interop/colmap.cc ParseColmapBinary), every camera id the file may hold, read as every command reads a calibration: an InvalidInput is the answer to bad bytes.
#include <cstddef>
#include <cstdint>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (int id : {0, 1}) {
    try {
      porthole::interop::ReadCalibration(text, porthole::interop::Format::kColmapBinary, 0.0055, "A", id);
    } catch (const porthole::InvalidInput&) {
    }
  }
  return 0;
}
