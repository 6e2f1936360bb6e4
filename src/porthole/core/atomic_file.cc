#include "porthole/core/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>

#include "porthole/core/error.h"

namespace porthole {

DirLock::DirLock(const std::filesystem::path& dir) {
  fd_ = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) return;  // the caller's own checks report a missing directory
  while (flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
  }
}

DirLock::~DirLock() {
  if (fd_ >= 0) close(fd_);  // releases the lock
}

void RemoveStaleTemporaries(const std::filesystem::path& dir, const std::string& prefix) {
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(dir, ec); !ec && it != std::filesystem::directory_iterator();
       it.increment(ec)) {
    if (it->path().filename().string().rfind(prefix, 0) == 0) {
      std::error_code ignore;
      std::filesystem::remove_all(it->path(), ignore);
    }
  }
}

void WriteFileAtomically(const std::filesystem::path& path, std::string_view content,
                         const std::string& field) {
  namespace fs = std::filesystem;
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InvalidInput(field, "directory does not exist: " + dir.string());
  const DirLock lock(dir);
  std::string prefix = path.filename().string();  // ".<name>.tmp", built so as not to trip GCC 12's -Wrestrict
  prefix.insert(0, 1, '.');
  prefix += ".tmp";
  RemoveStaleTemporaries(dir, prefix);
  std::random_device rd;
  const fs::path tmp = dir / (prefix + std::to_string(rd()));
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
