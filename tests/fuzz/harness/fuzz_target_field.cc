// Target-field files (calib/target.cc LoadTargetField → coded/sheet.cc ParseField) through a file,
// and the target's points built from what was read (TargetPoints indexes them by ID).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "porthole/calib/target.h"
#include "porthole/core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = std::filesystem::temp_directory_path() / ("porthole_fuzz_" + std::to_string(getpid()) + ".txt");
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    porthole::calib::TargetSpec target = porthole::calib::ParseTarget("coded:12:2");
    porthole::calib::LoadTargetField(path.string(), &target);
    const auto points = porthole::calib::TargetPoints(target);
    if (static_cast<int>(points.size()) != target.NumPoints()) __builtin_trap();
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
