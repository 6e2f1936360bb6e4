// Image headers (calib/detect.cc ReadImageSize) through a file: the first byte picks the extension.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "porthole/calib/detect.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = std::filesystem::temp_directory_path() / ("porthole_fuzz_" + std::to_string(getpid()) + ".img");
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  const auto wh = porthole::calib::ReadImageSize(path.string());
  if (wh && (wh->first < 0 || wh->second < 0)) __builtin_trap();
  return 0;
}
