// COLMAP cameras.txt with refractive COLMAP's housing tokens (interop/colmap.cc), read as every
// command reads it: each camera id the file holds, and the default (the only camera).
#include <cstddef>
#include <cstdint>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (int id : {0, 1, 2}) {
    try {
      porthole::interop::ReadCalibration(text, porthole::interop::Format::kColmapText, 0.0055, "A", id);
    } catch (const porthole::InvalidInput&) {
    }
  }
  return 0;
}
