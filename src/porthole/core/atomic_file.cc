#include "porthole/core/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>

#include "porthole/core/error.h"

namespace porthole {

void WriteFileAtomically(const std::filesystem::path& path, std::string_view content,
                         const std::string& field) {
  namespace fs = std::filesystem;
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InvalidInput(field, "directory does not exist: " + dir.string());
  std::random_device rd;
  const fs::path tmp = dir / ("." + path.filename().string() + ".tmp" + std::to_string(rd()));
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw InvalidInput(field, "cannot write in " + dir.string() + ": " + std::strerror(errno));
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      throw InvalidInput(field, "write failed for " + path.string());
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw InvalidInput(field, "cannot replace " + path.string() + ": " + ec.message());
  }
}

}  // namespace porthole
