// Writing outputs all at once: a file or directory appears complete or not at all.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace porthole {

// Writes `content` to `path` through a temporary file in the same directory, then renames it over
// `path`. Throws InvalidInput(field, ...) when the directory is missing or not writable; on any
// failure no file is left at `path` (an existing one is left untouched).
// A stale temporary file from a run that was killed (SIGKILL, power loss) is removed by the next
// write to the same path (see DirLock).
void WriteFileAtomically(const std::filesystem::path& path, std::string_view content,
                         const std::string& field = "output");

// An exclusive advisory lock (flock) on a directory, held for the object's life; released by the
// kernel when the process dies, even by SIGKILL. Writers of outputs into `dir` hold it while they
// create, fill and rename their temporaries, so whoever holds it knows that any temporary of theirs
// already there is stale. Blocks while another porthole writes into `dir`.
class DirLock {
 public:
  explicit DirLock(const std::filesystem::path& dir);
  ~DirLock();
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;

 private:
  int fd_ = -1;
};

// Removes the entries of `dir` whose names start with `prefix` (files or whole directories): the
// leftovers of killed runs. Call only while holding DirLock(dir).
void RemoveStaleTemporaries(const std::filesystem::path& dir, const std::string& prefix);

}  // namespace porthole
