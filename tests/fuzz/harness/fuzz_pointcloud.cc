// Point clouds (pointcloud/read.cc) through a file, as the CLI reads them: the first byte picks the
// format (PLY, XYZ, CSV, OBJ, STL).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "porthole/core/error.h"
#include "porthole/pointcloud/pointcloud.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const char* kExt[] = {".ply", ".xyz", ".csv", ".obj", ".stl"};
  const auto path = std::filesystem::temp_directory_path() /
                    ("porthole_fuzz_" + std::to_string(getpid()) + kExt[data[0] % 5]);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data) + 1, static_cast<std::streamsize>(size - 1));
  try {
    porthole::pointcloud::ReadPointCloud(path);
  } catch (const porthole::InvalidInput&) {
  }
  return 0;
}
