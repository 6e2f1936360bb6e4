// Detection sets and per-image detections (calib/detections_json.cc LoadDetections) through a file.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "porthole/calib/detections_json.h"
#include "porthole/core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = std::filesystem::temp_directory_path() / ("porthole_fuzz_" + std::to_string(getpid()) + ".json");
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    porthole::calib::TargetSpec target;
    porthole::calib::LoadDetections(path.string(), "--detections", &target);
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
