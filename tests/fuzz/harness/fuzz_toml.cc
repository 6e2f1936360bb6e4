// Port, camera and lens TOML (io/presets.cc): the first byte picks the parser.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 3) {
      case 0: porthole::catalogue::ParsePortToml(text, "fuzz.toml"); break;
      case 1: porthole::catalogue::ParseCameraToml(text, "fuzz.toml"); break;
      default: porthole::catalogue::ParseLensToml(text, "fuzz.toml"); break;
    }
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
